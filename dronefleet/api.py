"""The Python API: :func:`run` one simulation, :func:`sweep` a grid of them, for any scenario.

Both are exported at the package top level (``dronefleet.run``, ``dronefleet.sweep``) and go
through the scenario contract (:mod:`dronefleet.scenarios`) and the machinery of the command
line: :func:`run` is ``dronefleet run`` (its :meth:`Run.save` writes the same bytes as
``dronefleet run --out``), :func:`sweep` is a sweep file planned, run and collected by
:mod:`dronefleet.sweeps`, built from the arguments instead of a TOML file.

Configs and changes are given as on the command line. ``config`` (``base`` of a sweep) is
None (the paper's delivery scenario), a registered scenario's name (its defaults:
``"delivery"``, ``"replenishment"``, ``"items"``, ``"lunar"``)
or the path of a TOML config file. Changes are config keys, bare
(``tau_minutes=20``, ``rule="random"``) or, in the ``set`` dict, also as ``section.key``
(``set={"auction.rule": "random"}``); values have the types of a config file (an int is
taken for a float, never the reverse). ``seed`` / ``seeds`` set the root seed, as ``dronefleet
run --seed`` and a sweep file's ``seeds`` do (delivery, items, lunar); replenishment has none and
refuses them: its trials ``first_trial`` .. ``first_trial + trials - 1`` are its streams. Bad
arguments raise :class:`dronefleet.config.ConfigError`
(a ``ValueError``) with a one-line message naming the value and what is allowed, before
anything is simulated.

Importing this module is cheap: pandas, numpy and the simulators are imported when a run
or a table is asked for.
"""

from __future__ import annotations

import dataclasses
import itertools
import json
import os
import re
import tempfile
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

from . import scenarios
from .config import ConfigError, _show, _suggest, check_depth, given_twice, named_file, shipped_files
from .scenarios import Scenario
from .sweeps import (MAX_RUNS, Progress, Sweep, _probe, available_cpus, check_collected, check_layout, collect,
                     run_sweep, simulate, sweep_of_document)

if TYPE_CHECKING:
    import pandas
    import pyarrow

__all__ = ["Run", "run", "sweep"]

#: How :func:`sweep` names its definition in messages (where a sweep file's path would be).
SWEEP_LABEL = "dronefleet.sweep()"


def _source(config: Any, argument: str) -> tuple[Scenario, str | os.PathLike | None]:
    """``(scenario, config file or None)`` of a ``config``/``base`` argument (see the module doc)."""
    if config is None:
        return scenarios.SCENARIOS["delivery"], None
    registered = scenarios.registered()
    if isinstance(config, str) and config in registered:
        return scenarios.get(config), None  # an installed one is loaded and checked here
    if not isinstance(config, (str, os.PathLike)):
        raise ConfigError(f"{argument}={_show(config)}: expected None, a scenario name "
                          f"({', '.join(map(repr, registered))}) or the path of a TOML config file")
    if isinstance(config, str) and re.fullmatch(r"[\w-]+", config) and not os.path.lexists(config):
        # a bare word is a name, as on the command line: a shipped config's, or a typo of one
        shipped = shipped_files("config")
        if config not in shipped:
            raise ConfigError(f"{argument}={config!r} is neither a scenario, a shipped config nor a file"
                              f"{_suggest(config, [*registered, *shipped])}: scenarios {', '.join(registered)}; "
                              f"shipped configs {', '.join(shipped)}")
        config = named_file(config)
    return scenarios.scenario_of(config), config


def _changes(scenario: Scenario, fixed: Mapping[str, Any] | None, overrides: Mapping[str, Any],
             seed: int | None) -> dict[str, Any]:
    """``set`` and keyword changes (and ``seed``) -> ``{parameter name: value}``; a key given twice is refused."""
    if fixed is not None and not isinstance(fixed, Mapping):
        raise ConfigError(f"set={_show(fixed)}: expected a dict of config keys to values, "
                          "e.g. set={'auction.rule': 'random'}")
    # each change with the way the caller wrote it, for a refusal of a key given twice
    given = [*((key, value, f"set[{_show(key)}]") for key, value in (fixed or {}).items()),
             *((key, value, f"{key}={_show(value)}") for key, value in overrides.items())]
    if seed is not None:
        if scenario.seed_key is None:
            raise scenario.seed_refusal(f"seed={_show(seed)}")
        given.append((scenario.seed_key, seed, f"seed={_show(seed)}"))
    changes: dict[str, Any] = {}
    how: dict[str, str] = {}
    for key, value, written in given:
        if not isinstance(key, str):
            raise ConfigError(f"config key {_show(key)} is not a string: keys are names such as 'tau_minutes' "
                              "or 'orders.tau_minutes'")
        name = scenario.resolve_key(key)  # ConfigError listing the allowed keys
        check_depth(value, "", key)
        if name in changes:
            raise given_twice(name, how[name], written)
        changes[name], how[name] = value, written
    return changes


class Run:
    """One simulated run: its config and its tables.

    Every table of the scenario (``scenario.tables``) is an attribute holding a pandas
    DataFrame, converted when first asked for: a delivery run has ``.orders``,
    ``.attempts``, ``.fleet``, ``.timeseries`` and ``.summary`` (one row of metrics); an
    energy-replenishment run ``.summary`` (one row per trial) and ``.timeseries``. Their
    columns and units are documented in :mod:`dronefleet.delivery.records` and
    :mod:`dronefleet.replenishment.simulate`.

    Attributes
    ----------
    scenario : dronefleet.scenarios.Scenario
        The run's scenario (``scenario.name``: ``"delivery"``, ``"replenishment"``).
    config
        The resolved, validated config (``config.to_dict()``: as sections of a config file).
    arrow : dict of str to pyarrow.Table
        The tables as the simulation made them, which :meth:`save` writes.
    """

    def __init__(self, scenario: Scenario, config: Any, arrow: dict[str, pyarrow.Table]) -> None:
        self.scenario, self.config, self.arrow = scenario, config, arrow
        self._frames: dict[str, pandas.DataFrame] = {}

    def table(self, name: str) -> pandas.DataFrame:
        """The table ``name`` as a pandas DataFrame (the same object on every call)."""
        if name not in self.arrow:
            raise ConfigError(f"no table {_show(name)} in a {self.scenario.name} run; "
                              f"its tables: {', '.join(self.arrow)}")
        if name not in self._frames:
            self._frames[name] = self.arrow[name].to_pandas()
        return self._frames[name]

    @property
    def tables(self) -> dict[str, pandas.DataFrame]:
        """Every table by name, as pandas DataFrames."""
        return {name: self.table(name) for name in self.arrow}

    def __getattr__(self, name: str) -> pandas.DataFrame:
        # only for names that are not attributes: the tables, by the names the scenario gives them
        arrow = self.__dict__.get("arrow", {})  # empty while a copy or an unpickling builds the object
        if name not in arrow:
            raise AttributeError(f"{type(self).__name__!r} object has no attribute {name!r}; its tables: "
                                 f"{', '.join(arrow)}")
        return self.table(name)

    def __dir__(self) -> list[str]:
        return [*super().__dir__(), *self.arrow]

    def __repr__(self) -> str:
        return f"<dronefleet {self.scenario.name} run: {self.scenario.describe(self.config)}>"

    def report(self) -> str:
        """The summary that ``dronefleet run`` prints (without the wall time)."""
        return self.scenario.format_summary(self.arrow)

    def save(self, out: str | os.PathLike, *, overwrite: bool = False) -> Path:
        """Write the run folder ``out`` exactly as ``dronefleet run --out out`` does (same bytes).

        One parquet file per table, each with the config and provenance in its metadata;
        the folder is written complete or not at all.

        Parameters
        ----------
        out : path
            The run folder: absent, empty or (with ``overwrite``) holding a run.
        overwrite : bool
            Replace a run already in ``out``; without it that is refused before anything is written.

        Returns
        -------
        pathlib.Path
            ``out``.

        Raises
        ------
        dronefleet.outputs.OutputError
            (a ConfigError) ``out`` cannot take the run: a file, a folder of other files, a
            run without ``overwrite``, a folder in a sweep dataset, not writable, or a write that failed.
        """
        from .cli import check_outputs
        from .outputs import writing
        from .records import write_tables

        if not isinstance(out, (str, os.PathLike)):
            raise ConfigError(f"out={_show(out)}: expected the path of a folder for the run's tables")
        out = Path(os.path.normpath(out))
        check_outputs(out, None, overwrite, self.scenario.tables)
        with writing(out):
            write_tables(self.arrow, out, self.config, overwrite=overwrite)
        return out


def run(config: str | os.PathLike | None = None, *, seed: int | None = None,
        set: Mapping[str, Any] | None = None, **overrides: Any) -> Run:
    """Simulate one run and return its tables.

    Parameters
    ----------
    config : str, path or None
        None: the paper's delivery scenario (``configs/paper.toml``); a registered scenario's
        name: its defaults. The built-in ones: ``"delivery"`` (on-demand delivery by a learning,
        auction-bidding UAV fleet; OpenSwarm D4.4, Talamali et al. AAMAS 2025), ``"replenishment"``
        (energy replenishment by fixed and mobile chargers; OpenSwarm D4.4), ``"items"``
        (multi-robot item delivery and foraging; Liemhetcharat et al., Robotics 2015) and
        ``"lunar"`` (beacon-guided lunar foraging with recharging; Angyal, TU Delft MSc thesis
        2024); or one installed from another package. Else a TOML config file of any scenario
        (it names its own).
    seed : int, optional
        The root seed, as ``dronefleet run --seed``: all randomness of a delivery, items or
        lunar run derives from it. Default: the config's. Refused for replenishment, whose
        trials are its streams (trial k uses seed 876 k): choose them with ``first_trial``
        (from 1) and ``trials``.
    set : dict, optional
        Config changes whose keys are not Python names: ``{"auction.rule": "random"}``.
    **overrides
        Config changes by bare key, as ``dronefleet run --set`` takes them:
        ``tau_minutes=20`` (minutes), ``horizon_weeks=1`` (weeks), ``rule="random"``.

    Returns
    -------
    Run
        ``.config``, ``.tables``, each table as an attribute (``.orders``, ``.summary``, ...)
        and ``.save(dir)``.

    Raises
    ------
    dronefleet.config.ConfigError
        (a ValueError) An unknown scenario, an unreadable config file, an unknown key, a key
        given twice, a value of the wrong type or out of range, a run too large: before
        anything is simulated.
    RuntimeError
        A delivery run that stopped: a degenerate config whose UAVs keep aborting
        (:class:`dronefleet.delivery.simulation.RunTooLargeError`), a supervisor that refuses
        an event (:class:`dronefleet.supervisor.SupervisorError`); ``dronefleet run`` reports
        the same in one line.
    dronefleet.scenarios.HookError
        (a RuntimeError) A hook of an installed scenario that calls ``sys.exit``, raises (other than
        a ConfigError), returns what the contract does not allow, or whose ``simulate`` (run in a
        process of its own) ends that process: one line naming the scenario, the hook and what
        was wrong.

    Examples
    --------
    >>> import dronefleet
    >>> r = dronefleet.run(seed=3, horizon_weeks=0.1, n_uavs=5, rule="random")
    >>> r.config.rule, r.config.seed, len(r.summary)
    ('random', 3, 1)
    >>> dronefleet.run("replenishment", trials=2, ticks=300).summary.trial.tolist()
    [1, 2]
    """
    scenario, path = _source(config, "config")
    changes = _changes(scenario, set, overrides, seed)
    resolved = scenario.replace(scenario.load(path), changes)
    return Run(scenario, resolved, simulate(scenario, resolved))


def _bounded_list(values: Iterable, argument: str, what: str) -> list:
    """``values`` as a list, refused if it holds more than a sweep may run: never built whole
    (``range(10**12)`` would exhaust memory, an endless iterator never end)."""
    shown = _show(values)  # before an iterator is advanced
    listed = list(itertools.islice(values, MAX_RUNS + 1))
    if len(listed) > MAX_RUNS:
        raise ConfigError(f"{argument}={shown}: more than {MAX_RUNS:,} {what}; a sweep may hold at most "
                          f"{MAX_RUNS:,} runs")
    return listed


def _grid(grid: Any) -> dict | list[dict]:
    """A ``grid`` argument as a sweep file's ``[grid]`` (one dict) or ``[[grid]]`` (a list of
    dicts): tuples and ranges of values become lists; the machinery checks the rest."""
    def product(table):
        if not isinstance(table, Mapping):
            raise ConfigError(f"grid={_show(grid)}: expected a dict of config keys to lists of values, "
                              "e.g. {'rule': ['least_confident', 'random']}, or a list of such dicts")
        return {key: _bounded_list(values, f"grid[{_show(key)}]", "values") if isinstance(values, (tuple, range))
                else values for key, values in table.items()}

    return [product(table) for table in grid] if isinstance(grid, list) else product(grid)


def _seed_list(seeds: Any) -> list:
    if isinstance(seeds, (str, bytes, Mapping)) or not isinstance(seeds, Iterable):
        raise ConfigError(f"seeds={_show(seeds)}: expected a list of integers, e.g. [0, 1] or range(20)")
    return _bounded_list(seeds, "seeds", "seeds")


def _check_workers_can_import(document: dict) -> None:
    """Refuse a plugin in the calling script (``"__main__:function"``) when a sweep has workers.

    The workers import dronefleet and the modules a config names, never the caller's main
    module (see :func:`dronefleet.executors.local`): there ``__main__`` is not the script.
    """
    tables = document["grid"] if isinstance(document["grid"], list) else [document["grid"]]
    for key, value in itertools.chain(document["set"].items(), *(table.items() for table in tables)):
        for one in value if isinstance(value, list) else [value]:
            if isinstance(one, str) and one.partition(":")[0] == "__main__":
                raise ConfigError(f"{key}={one!r} names the calling script, which the sweep's worker processes "
                                  "do not run: put it in a module ('package.module:function') or pass jobs=1")


def sweep(grid: Mapping[str, Iterable] | list[Mapping[str, Iterable]], *, seeds: Iterable[int] | None = None,
          base: str | os.PathLike | None = None, set: Mapping[str, Any] | None = None,
          jobs: int | None = None, out: str | os.PathLike | None = None) -> pandas.DataFrame:
    """Run every configuration of ``grid`` times ``seeds``; return their summaries, one table.

    The sweep a sweep file with these ``[grid]``, ``[set]``, ``seeds`` and ``base`` would
    be (see :mod:`dronefleet.sweeps`), planned, run and collected in a temporary folder that
    is removed afterwards, or in the dataset folder ``out``, which is kept: every run's
    config is validated before the first one starts.

    Parameters
    ----------
    grid : dict or list of dicts
        Config keys (bare or ``section.key``) to lists of values: the runs are their
        product, the last key varying fastest, as ``[grid]``. A list of such dicts is
        ``[[grid]]``: the union of their products, in order.
    seeds : iterable of int, optional
        Root seeds, one run per value and configuration (innermost), as ``seed`` of
        :func:`run`. Required for delivery; optional for items and lunar (without them each
        configuration is one run at the base's seed); refused for replenishment, which has
        no seed: put ``first_trial`` in the grid to run blocks of trials.
    base : str, path or None
        The config the grid changes, as ``config`` of :func:`run`: None (the paper's
        delivery scenario), a scenario's name or a TOML config file.
    set : dict, optional
        Fixed changes to ``base`` for every run (``[set]``), e.g. ``{"horizon_weeks": 1}``.
    jobs : int, optional
        Processes of this machine to run on (default: every CPU this process may use). The
        workers never run the calling script, which needs no ``__name__ == "__main__"``
        guard; a plugin defined in it (``rule="__main__:function"``) therefore needs ``jobs=1``.
    out : path, optional
        Keep the sweep's dataset in this folder, as ``dronefleet sweep run`` writes
        ``<results>/<name>``: a parquet dataset per table, partitioned by the grid keys and
        the seed key (read it with ``pandas.read_parquet(out / "orders")``), its
        ``collected.parquet``, and ``dronefleet replay out --run KEY=VALUE ...`` plays any of
        its runs. Runs already done there (same config) are kept, not run again. A folder that
        is not absent, empty or a dataset dronefleet wrote (e.g. ``out="."``), a dataset of
        another layout or scenario, a ``collected.parquet`` that dronefleet did not write, a
        file, or a folder that cannot be written is refused before any run.
        Default: a temporary folder, removed.

    Returns
    -------
    pandas.DataFrame
        ``dronefleet sweep collect``'s table: per run (replenishment: per trial of each run)
        its grid values, its seed key, then its summary's columns; in run order.

    Raises
    ------
    dronefleet.sweeps.SweepError
        (a ConfigError, a ValueError) Bad arguments: an unknown key, an empty grid, a value
        given twice, a key both in ``grid`` and ``set``, missing or repeated seeds, any
        value the scenario refuses (the message names the key, the grid point and what is
        allowed); a plugin of the calling script with workers; before anything runs.
    RuntimeError
        If a run failed while running (its error in the message).

    Examples
    --------
    >>> import dronefleet
    >>> table = dronefleet.sweep({"rule": ["least_confident", "random"]}, seeds=[0, 1], jobs=1,
    ...                          set={"horizon_weeks": 0.1, "n_uavs": 5})
    >>> table[["rule", "seed"]].values.tolist()
    [['least_confident', 0], ['least_confident', 1], ['random', 0], ['random', 1]]
    """
    scenario, path = _source(base, "base")
    if jobs is not None and (not isinstance(jobs, int) or isinstance(jobs, bool) or jobs < 1):
        raise ConfigError(f"jobs={_show(jobs)}: expected an integer >= 1 (processes), or None for every CPU")
    head: dict[str, Any] = {"name": "api"}
    if path is None:
        head["scenario"] = scenario.name
    else:  # relative to the folder of SWEEP_LABEL, which is the working directory
        head["base"] = os.fspath(path)
    if seeds is not None:
        if scenario.seed_key is None:
            raise scenario.seed_refusal(f"seeds={_show(seeds)}")
        head["seeds"] = _seed_list(seeds)
    if set is not None and not isinstance(set, Mapping):
        raise ConfigError(f"set={_show(set)}: expected a dict of config keys to values, e.g. {{'horizon_weeks': 1}}")
    document = {"sweep": head, "set": dict(set or {}), "grid": _grid(grid)}
    planned = sweep_of_document(document, Path(SWEEP_LABEL), "")
    workers = jobs or available_cpus()
    if workers > 1:  # every run then runs in a worker, a single one too
        _check_workers_can_import(document)
    # kept in collected.parquet; only now, when every key and value is known to be one a config holds
    planned = dataclasses.replace(planned, text=json.dumps(document, default=str))
    if out is not None:
        if not isinstance(out, (str, os.PathLike)):
            raise ConfigError(f"out={_show(out)}: expected the path of a folder for the sweep's dataset, or None")
        out = Path(out)
        # a folder of the user's files, a dataset of other keys or scenario, a damaged _layout.json, a
        # collected.parquet collect did not write: before anything is made
        check_layout(planned, out)
        check_collected(out)
        _probe([out], f"out={_show(os.fspath(out))} must be a folder where files can be written", keep=False)
        return _run_and_collect(planned, out, workers)
    with tempfile.TemporaryDirectory(prefix="dronefleet-sweep-") as folder:
        return _run_and_collect(planned, Path(folder) / planned.name, workers)


def _run_and_collect(planned: Sweep, out: Path, workers: int) -> pandas.DataFrame:
    """Run the sweep ``planned`` into the dataset ``out`` on ``workers`` processes; its collected table."""
    # a bar in a notebook; elsewhere as the caller's logging shows dronefleet's INFO lines
    _, failures = run_sweep(planned, out, planned.runs, workers, progress=Progress(planned.scenario.replicate_noun))
    if failures:
        shown = "; ".join(f"{run.partition}: {error}" for run, error in list(failures.items())[:3])
        raise RuntimeError(f"{len(failures)} of {len(planned.runs)} runs failed: {shown}")
    table, _ = collect(planned, out)
    return table.to_pandas()
