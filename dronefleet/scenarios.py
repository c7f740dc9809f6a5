"""The scenarios dronefleet simulates, registered once by name, and the contract each implements.

The CLI, the sweeps (:mod:`dronefleet.sweeps`: plan, run on local processes, a job array or
Dask, status, collect) and ``reproduce`` work on this contract, never on a concrete scenario
(``dronefleet run`` keeps a delivery-only path for fleet files and the progress bar). A config file names its scenario
with a top-level ``scenario = "<name>"``; a file without the key is a delivery config, so
every existing config, sweep and result keeps working.

The contract: a scenario is a module defining

``NAME``
    its name in :data:`SCENARIOS`.
``SCHEMA``, ``DEFAULTS``
    ``{key: Field(section, unit, allowed, doc)}`` and ``{key: default}``: every config key,
    its TOML section, unit, allowed values and meaning. A default's type (int, float, str;
    tuple for a list of numbers) is the key's type: a sweep's partition columns take it.
``load(path, overrides, seed) -> config``
    the one validation entry point: the TOML file (or None for the defaults), ``--set``
    strings ``"key=value"`` (``section.key`` or the bare key), a seed (None: the file's).
    Any bad input raises :class:`dronefleet.config.ConfigError` (one line) before any work.
    ``config.to_json()`` is its deterministic JSON (the default run folder hashes it),
    ``config.to_dict()`` the same as sections of a config file; ``read_config(path)`` reads
    it back from a table the scenario wrote.
``resolve_key(key) -> name``
    a key as ``--set`` and sweep files write it (``section.key`` or the bare key) -> the key's
    name in ``SCHEMA``; ConfigError, listing the allowed keys, if there is none.
``replace(config, changes) -> config``
    a validated copy of ``config`` with ``changes`` (``{name: value}``) applied, the types as
    strict as in ``load``; ConfigError naming the key and what is allowed otherwise.
``value(config, name)``
    the value of key ``name`` in ``config``.
``SEED_KEY``, ``SEEDS_REQUIRED``
    the key that a sweep's ``[sweep] seeds`` sets, one run per value (the last partition key
    of a sweep's dataset), and whether a sweep must list them (if not, each configuration is
    one run at its base config's value).
``simulate(config) -> dict[str, pyarrow.Table]``
    the run's tables, named as in ``TABLES`` (which holds ``"summary"``); written by
    :func:`dronefleet.records.write_tables`, atomically, a run folder complete or absent,
    each file with the config and :func:`dronefleet.provenance.stamp` in its metadata.
``table_schemas() -> dict[str, pyarrow.Schema]``
    the columns and types of each table ``simulate`` makes: a sweep refuses, as damaged, a
    file it reads back that holds other ones.
``format_summary(tables) -> str``
    what ``dronefleet run`` prints, from the tables alone.
``describe(config)``, ``label(config)``
    a one-line description (the head of ``run``), a short tag for the default folder name.
``FIGURES``
    the names of its figures in ``dronefleet reproduce`` (possibly empty).
``format_bounds(config) -> str`` (optional)
    analytic bounds, for ``dronefleet bounds``; refusing parameters where none exists.
``replicates(config) -> range`` (optional)
    the replicates (trials) a run holds, if a run holds several: a sweep refuses seeds whose
    runs would hold a replicate twice. Without it, a run is the one replicate its seed names.
``replay_data(run_dir[, trial]) -> dict`` (optional)
    what the replay page (:mod:`dronefleet.replay`) shows of the complete run folder
    ``run_dir`` (a :class:`pathlib.Path`), JSON-ready (``title`` and ``duration_s`` [s] at
    least); the script ``replay.js`` beside the module draws it (it defines
    ``makeScene(data)``, see ``dronefleet/replay.html``). A scenario with ``replicates``
    takes ``trial`` too (``replay --trial K``; None: the run's first), ConfigError if the run
    does not hold it.
``check_replayable(config)`` (optional)
    ConfigError (one line) if the page of a run of ``config`` would be refused:
    ``run --replay`` calls it before the run.
``outdated(config, summary) -> bool`` (optional)
    True if a done run (its ``summary`` file at the path ``summary``) must run again because
    an input it read besides its config changed since (delivery: a saved fleet written again).

Where each scenario's pieces are:

* ``delivery``: :mod:`dronefleet.delivery.scenario` over the subpackage (simulation,
  engine, metrics, fleet, analysis, figures), with its schema in :mod:`dronefleet.delivery.config`.
* ``replenishment``: :mod:`dronefleet.replenishment.scenario` over the subpackage
  (params, simulate, kernel, bounds).
* ``items``: :mod:`dronefleet.items.scenario` over the subpackage (params, simulate, kernel).

Registering is one entry in :data:`SCENARIOS`: a plain dict, no import by string; each entry
imports its module only when first used, so ``dronefleet --help`` stays cheap.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from types import ModuleType
from typing import TYPE_CHECKING, Any

from .config import SCENARIO_KEY, ConfigError, _show, _suggest, read_toml

if TYPE_CHECKING:
    import pyarrow

__all__ = ["Field", "Scenario", "SCENARIOS", "get", "scenario_of", "load"]


@dataclass(frozen=True)
class Field:
    """Declaration of one config key: TOML section, unit, allowed values, meaning."""

    section: str
    unit: str
    allowed: str
    doc: str


@dataclass(frozen=True)
class Scenario:
    """A registered scenario: its name and a function importing its contract module."""

    name: str
    entry: Callable[[], ModuleType]

    @property
    def module(self) -> ModuleType:
        return self.entry()  # Python caches the import

    @property
    def tables(self) -> tuple[str, ...]:
        return self.module.TABLES

    @property
    def figures(self) -> tuple[str, ...]:
        return self.module.FIGURES

    @property
    def schema(self) -> dict[str, Field]:
        return self.module.SCHEMA

    @property
    def defaults(self) -> dict:
        return self.module.DEFAULTS

    @property
    def seed_key(self) -> str:
        return self.module.SEED_KEY

    @property
    def seeds_required(self) -> bool:
        return self.module.SEEDS_REQUIRED

    def load(self, path: str | os.PathLike | None = None, overrides: Iterable[str] = (),
             seed: int | None = None) -> Any:
        return self.module.load(path, overrides, seed)

    def resolve_key(self, key: str) -> str:
        return self.module.resolve_key(key)

    def replace(self, config: Any, changes: Mapping[str, Any]) -> Any:
        return self.module.replace(config, changes)

    def value(self, config: Any, name: str) -> Any:
        return self.module.value(config, name)

    def replicates(self, config: Any) -> range | None:
        """The replicates a run of ``config`` holds; None if it is the one its seed names."""
        replicates = getattr(self.module, "replicates", None)
        return None if replicates is None else replicates(config)

    def outdated(self, config: Any, summary: Path) -> bool:
        outdated = getattr(self.module, "outdated", None)
        return outdated is not None and outdated(config, summary)

    def read_config(self, path: str | os.PathLike) -> Any:
        return self.module.read_config(path)

    def table_schemas(self) -> dict[str, pyarrow.Schema]:
        return self.module.table_schemas()

    def simulate(self, config: Any) -> dict[str, pyarrow.Table]:
        return self.module.simulate(config)

    def format_summary(self, tables: Mapping[str, pyarrow.Table]) -> str:
        return self.module.format_summary(tables)

    def describe(self, config: Any) -> str:
        return self.module.describe(config)

    def label(self, config: Any) -> str:
        return self.module.label(config)

    @property
    def format_bounds(self) -> Callable | None:
        return getattr(self.module, "format_bounds", None)

    def _replay_data(self) -> Callable[..., dict[str, Any]]:
        replay_data = getattr(self.module, "replay_data", None)
        if replay_data is None:
            having = [s.name for s in SCENARIOS.values() if hasattr(s.module, "replay_data")]
            raise ConfigError(f"scenario {self.name!r} has no replay page; scenarios with one: {', '.join(having)}")
        return replay_data

    def replay_data(self, run_dir: Path, trial: int | None = None) -> dict[str, Any]:
        """The replay page's data of the run folder ``run_dir`` (of its trial ``trial``; None: its
        first); ConfigError if the scenario has no replay or its runs no trials to choose."""
        replay_data = self._replay_data()
        if trial is None:
            return replay_data(run_dir)
        if not hasattr(self.module, "replicates"):
            raise ConfigError(f"--trial {trial}: a {self.name} run is one replicate, it has no trials to choose")
        return replay_data(run_dir, trial)

    def check_replayable(self, config: Any) -> None:
        """ConfigError (one line) if the replay page of a run of ``config`` would be refused."""
        self._replay_data()
        check = getattr(self.module, "check_replayable", None)
        if check is not None:
            check(config)

    @property
    def replay_script(self) -> str:
        """The JavaScript that draws the scenario's replay page (``replay.js`` beside its module)."""
        return resources.files(self.module.__package__).joinpath("replay.js").read_text(encoding="utf-8")


def _delivery() -> ModuleType:
    from .delivery import scenario

    return scenario


def _replenishment() -> ModuleType:
    from .replenishment import scenario

    return scenario


def _items() -> ModuleType:
    from .items import scenario

    return scenario


SCENARIOS: dict[str, Scenario] = {
    "delivery": Scenario("delivery", _delivery),
    "replenishment": Scenario("replenishment", _replenishment),
    "items": Scenario("items", _items),
}


def get(name: object, where: str = "") -> Scenario:
    """The scenario registered as ``name``; ConfigError listing the registered ones if none."""
    if isinstance(name, str) and name in SCENARIOS:
        return SCENARIOS[name]
    suggestion = _suggest(name, SCENARIOS) if isinstance(name, str) else ""
    raise ConfigError(f"{where}unknown scenario {_show(name)}{suggestion}; "
                      f"registered scenarios: {', '.join(SCENARIOS)}", [SCENARIO_KEY])


def scenario_of(path: str | os.PathLike | None) -> Scenario:
    """The scenario a config file names (``scenario = "..."`` at its top level; absent or no
    file: delivery)."""
    if path is None:
        return SCENARIOS["delivery"]
    _, document = read_toml(path)
    return get(document.get(SCENARIO_KEY, "delivery"), f"config file {str(path)!r}: ")


def load(path: str | os.PathLike | None = None, overrides: Iterable[str] = (),
         seed: int | None = None) -> tuple[Scenario, Any]:
    """``(scenario, config)`` of a config file: dispatch on its scenario, then its ``load``."""
    scenario = scenario_of(path)
    return scenario, scenario.load(path, overrides, seed)
