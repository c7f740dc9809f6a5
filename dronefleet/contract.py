"""The scenario contract: what a scenario gives dronefleet, in one typed object (docs/scenario-contract.md).

A scenario is any object (a module, usually) with the members of :class:`ScenarioContract`.
The CLI, the Python API, the sweeps, the replay page and ``reproduce`` see a scenario only
through it; :mod:`dronefleet.scenarios` registers the built-in ones and those installed as
entry points of :data:`ENTRY_POINT_GROUP`, each checked by :func:`contract_problems`.

This module is shared infrastructure: it imports nothing of dronefleet, so the scenario
packages, which sit below the sweeps and ``reproduce``, can use it.
"""

from __future__ import annotations

import inspect
import os
from collections.abc import Callable, Iterable, Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol, runtime_checkable

if TYPE_CHECKING:
    import pandas
    import pyarrow

__all__ = ["ENTRY_POINT_GROUP", "Field", "Column", "ScenarioContract", "REQUIRED", "OPTIONAL", "StudyContext",
           "FigureStudy", "STUDY_OPTIONAL", "contract_problems", "study_problems", "check_configurations"]

#: Entry-point group of scenarios installed from other packages: name -> the scenario object.
ENTRY_POINT_GROUP = "dronefleet.scenarios"


@dataclass(frozen=True)
class Field:
    """Declaration of one config key: TOML section, unit, allowed values, meaning."""

    section: str
    unit: str
    allowed: str
    doc: str


@dataclass(frozen=True)
class Column:
    """Documentation of one column of a table: its unit ("" for words, flags and identifiers;
    "count", "index" or "1" for plain numbers) and what it holds."""

    unit: str
    doc: str


@runtime_checkable
class ScenarioContract(Protocol):
    """What a scenario is. ``config`` is the scenario's own validated config: hashable, with
    ``to_json() -> str`` (deterministic; the default run folder hashes it) and ``to_dict()``
    (the sections of a config file). Every bad input raises :class:`dronefleet.config.ConfigError`,
    one line, before any work. Optional hooks (:data:`OPTIONAL`) are documented below the class."""

    NAME: str                         # its name in the registry and in a config's ``scenario = "..."``
    SCHEMA: Mapping[str, Field]       # every config key -> its section, unit, allowed values, meaning
    DEFAULTS: Mapping[str, Any]       # key -> default; its type (int, float, str, tuple) is the key's type
    TABLES: tuple[str, ...]           # the tables ``simulate`` makes, ``"summary"`` among them
    FIGURES: tuple[str, ...]          # its figures in ``dronefleet reproduce`` (possibly empty)
    SEED_KEY: str | None              # the root seed: what --seed, seed= and [sweep] seeds set (None: it has none)
    SEEDS_REQUIRED: bool              # whether a sweep must list seeds (False where SEED_KEY is None)

    def load(self, path: str | os.PathLike | None, overrides: Iterable[str], seed: int | None) -> Any:
        """The config of a TOML file (None: the defaults), ``--set "key=value"`` strings, a seed (None: the file's)."""

    def resolve_key(self, key: str) -> str:
        """``section.key`` or the bare key -> its name in SCHEMA; ConfigError listing the keys if none."""

    def replace(self, config: Any, changes: Mapping[str, Any]) -> Any:
        """A validated copy of ``config`` with ``{name: value}`` applied, as strict as ``load``."""

    def value(self, config: Any, name: str) -> Any:
        """The value of key ``name`` in ``config``."""

    def read_config(self, path: str | os.PathLike) -> Any:
        """The config a table this scenario wrote carries (:func:`dronefleet.records.read_config`)."""

    def table_schemas(self) -> dict[str, pyarrow.Schema]:
        """Columns and types of each table of TABLES: a sweep refuses, as damaged, a file with others."""

    def simulate(self, config: Any) -> dict[str, pyarrow.Table]:
        """One run: its tables by name (TABLES), deterministic from the config (its seed included)."""

    def format_summary(self, tables: Mapping[str, pyarrow.Table]) -> str:
        """What ``dronefleet run`` prints, from the tables alone."""

    def describe(self, config: Any) -> str:
        """A one-line description: the head of ``dronefleet run``."""

    def label(self, config: Any) -> str:
        """A short tag for the default run folder's name (``seed3``)."""


#: The members every scenario has: :class:`ScenarioContract`'s.
REQUIRED = ("NAME", "SCHEMA", "DEFAULTS", "TABLES", "FIGURES", "SEED_KEY", "SEEDS_REQUIRED", "load", "resolve_key",
            "replace", "value", "read_config", "table_schemas", "simulate", "format_summary", "describe", "label")
#: The optional hooks, each with its parameters (what it gets and returns: docs/scenario-contract.md):
#:
#: - ``format_bounds(config) -> str``: analytic bounds for ``dronefleet bounds``; ConfigError where none exists.
#: - ``replicates(config) -> range``: the trials a run holds, if several (numbered from 1).
#: - ``replay_data(run_dir[, trial]) -> dict``: the replay page's data of a run folder (JSON-ready, ``title``
#:   and ``duration_s`` [s] at least), drawn by the ``replay.js`` beside the scenario's module; a scenario
#:   with ``replicates`` takes ``trial`` too (``replay --trial K``; None: the run's first).
#: - ``check_replayable(config)``: ConfigError (one line) if the page of a run of ``config`` would be
#:   refused; ``run --replay`` calls it before the run.
#: - ``outdated(config, summary) -> bool``: True if a done run must run again (an input besides its config changed).
#: - ``study() -> FigureStudy``: its figures' tables, drawings and check for ``dronefleet reproduce``.
#: - ``columns() -> {table: {column: Column}}``: what every column of its tables holds, with its unit
#:   (the documentation site's table pages are made from it).
OPTIONAL = {"format_bounds": ("config",), "replicates": ("config",), "replay_data": ("run_dir",),
            "check_replayable": ("config",), "outdated": ("config", "summary"), "study": (),
            "columns": ()}
_PARAMETERS = {"load": ("path", "overrides", "seed"), "resolve_key": ("key",), "replace": ("config", "changes"),
               "value": ("config", "name"), "read_config": ("path",), "table_schemas": (), "simulate": ("config",),
               "format_summary": ("tables",), "describe": ("config",), "label": ("config",), **OPTIONAL}
_TYPES = {"NAME": str, "SCHEMA": Mapping, "DEFAULTS": Mapping, "TABLES": tuple, "FIGURES": tuple,
          "SEED_KEY": (str, type(None)), "SEEDS_REQUIRED": bool}


def _takes(function: Callable, count: int) -> bool:
    """Whether ``function`` can be called with ``count`` positional arguments."""
    try:
        inspect.signature(function).bind(*range(count))
    except TypeError:
        return False
    except ValueError:  # no signature to inspect (a builtin): trust it
        return True
    return True


def contract_problems(scenario: object) -> list[str]:
    """What keeps ``scenario`` from meeting the contract, one phrase each (empty: it does).

    Checked without running anything: the members of :data:`REQUIRED` present and of their
    kind, each function (and optional hook present) callable with its parameters, SCHEMA and
    DEFAULTS naming the same keys, ``"summary"`` among TABLES, SEED_KEY None or a key of SCHEMA.
    """
    problems = [f"has no {name}" for name in REQUIRED if not hasattr(scenario, name)]
    for name, kind in _TYPES.items():
        if hasattr(scenario, name) and not isinstance(getattr(scenario, name), kind):
            kinds = " or ".join("None" if k is type(None) else k.__name__ for k in (kind if isinstance(kind, tuple)
                                                                                      else (kind,)))
            problems.append(f"{name} is a {type(getattr(scenario, name)).__name__}, not a {kinds}")
    for name, parameters in _PARAMETERS.items():
        function = getattr(scenario, name, None)
        if function is None:
            continue
        if not callable(function):
            problems.append(f"{name} is not callable")
        elif not _takes(function, len(parameters)):
            problems.append(f"{name} does not take ({', '.join(parameters)})")
    if problems:
        return problems
    if set(scenario.SCHEMA) != set(scenario.DEFAULTS):
        differ = sorted(set(scenario.SCHEMA) ^ set(scenario.DEFAULTS))
        problems.append(f"SCHEMA and DEFAULTS name different keys ({', '.join(differ)})")
    problems += [f"SCHEMA[{key!r}] is not a dronefleet.contract.Field" for key, field in scenario.SCHEMA.items()
                 if not isinstance(field, Field)]
    if "summary" not in scenario.TABLES:
        problems.append("TABLES has no 'summary'")
    if scenario.SEED_KEY is not None and scenario.SEED_KEY not in scenario.SCHEMA:
        problems.append(f"SEED_KEY {scenario.SEED_KEY!r} is not a key of SCHEMA")
    if scenario.SEED_KEY is None and scenario.SEEDS_REQUIRED:
        problems.append("SEEDS_REQUIRED is True, but SEED_KEY is None (no seed to list)")
    return problems


class StudyContext(Protocol):
    """What ``dronefleet reproduce`` gives a scenario's study (:class:`dronefleet.reproduce.Study` is one):
    where to write, how many processes, and the orchestration the study may not import itself."""

    root: Path                        # the results root (``<out>``, or ``<out>/quick`` with --quick)
    quick: bool                       # --quick: a check in seconds, few trials or seeds
    jobs: int                         # local processes
    memo: dict                        # results the figures of one reproduce call share, by scenario
    log: Callable[[str], object]      # one line of progress

    def figure_dir(self, figure: str) -> Path:
        """``<root>/<figure>/``, made."""

    def load_sweep(self, path: Path, changes: Mapping[str, Any] | None = None) -> Any:
        """The sweep file at ``path``: a :class:`dronefleet.sweeps.Sweep` (``name``, ``runs``, ``run.config``)."""

    def map(self, function: Callable, items: Iterable) -> Iterator[tuple[Any, Any, BaseException | None]]:
        """``function`` over ``items`` on ``jobs`` processes: ``(item, result, error)`` as each finishes."""

    def write_table(self, frame: pandas.DataFrame, path: Path) -> Path:
        """Write ``frame`` as the parquet file ``path`` (atomically, with the provenance)."""

    def read_table(self, figure: str, name: str) -> pandas.DataFrame:
        """``<root>/<figure>/<name>.parquet``, each column checked against the study's TABLE_COLUMNS."""


class FigureStudy(Protocol):
    """A scenario's figures in ``dronefleet reproduce`` (what its ``study()`` hook returns)."""

    TITLE: str                        # one line: the source study, for ``reproduce --list``
    FIGURES: tuple[str, ...]          # its figure names, distinct from every other study's
    QUICK: str                        # what --quick changes, in words (for --help)
    #: table -> {column: kind}, kinds of :data:`dronefleet.reproduce.KINDS` ("text", "count", "number", ...)
    TABLE_COLUMNS: Mapping[str, Mapping[str, str]]
    # Optional (:data:`STUDY_OPTIONAL`): MAY_BE_EMPTY, a tuple of the tables that may hold no rows.

    def run_together(self, study: StudyContext, figures: list[str]) -> None:
        """Run what several of ``figures`` share, once, before each one's ``tidy`` (may do nothing)."""

    def tidy(self, study: StudyContext, figure: str) -> None:
        """Run the figure's experiments; write its tables under ``study.figure_dir(figure)``."""

    def draw(self, study: StudyContext, figure: str) -> list[Path]:
        """Draw the figure's files (PNG, PDF, SVG) from its tables alone; their paths."""

    def check(self, study: StudyContext, figure: str) -> list[str]:
        """Re-run a few of the figure's runs and compare them with its tables: the differences, one line each."""


#: The members of a :class:`FigureStudy`: attributes with their types, then its functions and their parameters.
_STUDY_TYPES = {"TITLE": str, "QUICK": str, "FIGURES": tuple, "TABLE_COLUMNS": Mapping}
#: The optional attributes of a :class:`FigureStudy` and their types. ``MAY_BE_EMPTY``: the tables that
#: may hold no rows (a record of events a run need not have, such as deaths); ``reproduce`` refuses
#: any other table without rows, as a broken run's.
STUDY_OPTIONAL = {"MAY_BE_EMPTY": tuple}
_STUDY_FUNCTIONS = {"run_together": ("study", "figures"), "tidy": ("study", "figure"), "draw": ("study", "figure"),
                    "check": ("study", "figure")}


def study_problems(study: object) -> list[str]:
    """What keeps ``study`` (a ``study()`` hook's result) from being a :class:`FigureStudy`, one
    phrase each (empty: it is one), checked without running anything."""
    problems = [f"its {name} is a {type(getattr(study, name, None)).__name__}, not a {kind.__name__}"
                for name, kind in {**_STUDY_TYPES, **STUDY_OPTIONAL}.items()
                if (name in _STUDY_TYPES or hasattr(study, name)) and not isinstance(getattr(study, name, None), kind)]
    if isinstance(getattr(study, "FIGURES", None), tuple):
        problems += [f"its figure {figure!r} is not a string" for figure in study.FIGURES
                     if not isinstance(figure, str)]
    for name, parameters in _STUDY_FUNCTIONS.items():
        function = getattr(study, name, None)
        if not callable(function) or not _takes(function, len(parameters)):
            problems.append(f"its {name} does not take ({', '.join(parameters)})")
    return problems


def check_experiments(table: pandas.DataFrame, path: Path, known: Iterable[str]) -> None:
    """Refuse (SweepError, one line naming the file ``path`` and the value) an ``experiment`` value
    of a figure's table that is not one of ``known`` (the figure's experiments): it names the
    sweep file a check runs again, so a tampered one must not become a path."""
    from .config import SweepError, one_line

    known = tuple(known)
    unknown = sorted(set(table["experiment"]) - set(known))
    if unknown:
        shown = one_line(unknown[0])
        shown = repr(shown if len(shown) <= 40 else shown[:37] + "...")
        raise SweepError(f"{path}: experiment {shown} is not one of this figure's ({', '.join(known)})")


def check_configurations(table: pandas.DataFrame, columns: Iterable[str], path: Path, limit: int,
                         validate: Callable[[dict[str, Any]], Any], label: Callable[[dict[str, Any]], str]) -> None:
    """Hold each distinct configuration of a figure's table (its ``columns``, at most ``limit`` of
    them) to a config file's rules: ``validate(values)`` raises ConfigError for one the model does
    not allow. SweepError (one line) naming the file ``path`` and the configuration (``label``)
    otherwise, so that a tampered table is refused before anything is drawn or run."""
    from .config import ConfigError, SweepError

    configs = table[list(columns)].drop_duplicates()
    if len(configs) > limit:
        raise SweepError(f"{path} holds {len(configs)} configurations; a figure's table holds at most {limit}")
    for values in configs.to_dict("records"):
        try:
            validate(values)
        except ConfigError as error:
            raise SweepError(f"{path}: the configuration {label(values)} is not one the model allows: "
                             f"{error}") from None
