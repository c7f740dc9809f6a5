"""The scenarios dronefleet simulates: registered by name, built-in or installed, each meeting the contract.

The contract is :class:`dronefleet.contract.ScenarioContract` (docs/scenario-contract.md):
the schema and defaults, load/resolve_key/replace/value, simulate -> tables, table_schemas,
format_summary, describe/label, FIGURES, and the optional hooks (format_bounds, replicates,
replay_data, outdated, study). The CLI, the Python API, the sweeps, the replay page and
``reproduce`` work on it through a :class:`Scenario` of this registry, never on a concrete
scenario (``dronefleet run`` keeps a delivery-only path for fleet files and the progress bar).

A config file names its scenario with a top-level ``scenario = "<name>"``; a file without the
key is a delivery config, so every existing config, sweep and result keeps working. The name
selects a registered scenario, never code: no module path is ever imported from a file.

Registered are:

* the built-ins, in :data:`SCENARIOS` (the one place they are listed), each imported only
  when first used, so ``dronefleet --help`` stays cheap: ``delivery``
  (:mod:`dronefleet.delivery.scenario`), ``replenishment`` (:mod:`dronefleet.replenishment.scenario`),
  ``items`` (:mod:`dronefleet.items.scenario`) and ``lunar`` (:mod:`dronefleet.lunar.scenario`);
* scenarios installed from other packages as entry points of the group ``dronefleet.scenarios``
  (:data:`dronefleet.contract.ENTRY_POINT_GROUP`), ``name = "package.module"`` or
  ``"package.module:object"``. One is loaded when a config, sweep or call names it (or
  ``reproduce`` lists every study), its import tried first in a child process
  (:func:`dronefleet.plugins.importing`); one that fails to import, hangs or ends the process
  when imported, does not meet the contract (:func:`dronefleet.contract.contract_problems`), or
  whose name two installed distributions declare, is refused in one line naming the entry point
  where something names it (:func:`get`) and left out with a warning from the lists of every
  scenario (:func:`loading`); one named like a built-in is left out with a warning.
"""

from __future__ import annotations

import functools
import importlib
import json
import os
import logging
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from importlib import resources
from importlib.metadata import entry_points
from pathlib import Path
from typing import TYPE_CHECKING, Any

from .config import SCENARIO_KEY, ConfigError, _show, _suggest, one_line, read_toml, seed_refusal
from .contract import ENTRY_POINT_GROUP, Column, FigureStudy, Field, contract_problems
from .plugins import importing

if TYPE_CHECKING:
    import pyarrow

__all__ = ["Scenario", "HookError", "SCENARIOS", "installed", "registered", "loading", "warn_left_out", "get",
           "scenario_of", "load"]

logger = logging.getLogger(__name__)


class HookError(RuntimeError):
    """A scenario's hook that exits, raises, returns what the contract does not allow or (an installed
    scenario's ``simulate``, in a process of its own) ends its process: one line naming the scenario,
    the hook and what was wrong. ``dronefleet`` reports it with exit code 2."""

    def __init__(self, message: str) -> None:
        super().__init__(one_line(message))  # a plugin's error may hold many lines


@dataclass(frozen=True)
class Scenario:
    """A registered scenario: its name and a function giving its contract object (a module, usually)."""

    name: str
    entry: Callable[[], Any]

    @property
    def module(self) -> Any:
        return self.entry()  # imported once: Python caches the import, entry points are cached here

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
    def seed_key(self) -> str | None:
        """The root seed's key (what ``--seed``, ``seed=`` and a sweep's ``seeds`` set), or None."""
        return self.module.SEED_KEY

    @property
    def replicate_noun(self) -> str:
        """What one of a run's replicates is called ("trial", "run"; a scenario's ``REPLICATE_NOUN``), as
        progress counts them; "run" for a scenario whose run is one replicate."""
        return getattr(self.module, "REPLICATE_NOUN", "replicate" if hasattr(self.module, "replicates") else "run")

    def seed_refusal(self, word: str) -> ConfigError:
        """The one-line refusal of a seed given as ``word`` to a scenario without one (:attr:`seed_key` None)."""
        return seed_refusal(word, self.name, getattr(self.module, "NO_SEED", ""))

    @property
    def seeds_required(self) -> bool:
        return self.module.SEEDS_REQUIRED

    @property
    def builtin(self) -> bool:
        """Whether it is one of :data:`SCENARIOS` (trusted), not installed from another package."""
        return SCENARIOS.get(self.name) == self  # equal, not the same: a worker process gets a copy

    def problem(self, hook: str, what: str) -> HookError:
        """The HookError of this scenario's ``hook``: ``what`` it did wrong."""
        return HookError(f"scenario {self.name!r}: its {hook} {what}")

    def _hook(self, hook: str, *args: Any) -> Any:
        """The scenario's ``hook`` called with ``args``. One that calls ``sys.exit`` is a HookError (it
        would end the command silently); so is an installed scenario's that raises anything but a
        ConfigError (its refusal of bad input). A built-in's errors are its documented ones
        (RunTooLargeError, ...), passed on as they are."""
        try:
            return getattr(self.module, hook)(*args)
        except SystemExit as exiting:
            raise self.problem(hook, f"called sys.exit({exiting.code!r})") from None
        except (ConfigError, KeyboardInterrupt):
            raise
        except BaseException as error:  # not only Exception: a plugin's BaseException would be a traceback
            if self.builtin:
                raise
            raise self.problem(hook, f"raised {type(error).__name__}: {error}") from error

    def _text(self, hook: str, *args: Any) -> str:
        text = self._hook(hook, *args)
        if not isinstance(text, str):
            raise self.problem(hook, f"returned {type(text).__name__}, not a text (str)")
        return text

    def load(self, path: str | os.PathLike | None = None, overrides: Iterable[str] = (),
             seed: int | None = None) -> Any:
        config = self._hook("load", path, overrides, seed)
        if not callable(getattr(config, "to_json", None)):  # every command hashes or stores its JSON
            raise self.problem("load", f"returned {type(config).__name__}, not a config (with to_json and to_dict)")
        return config

    def resolve_key(self, key: str) -> str:
        return self._hook("resolve_key", key)

    def replace(self, config: Any, changes: Mapping[str, Any]) -> Any:
        return self._hook("replace", config, changes)

    def value(self, config: Any, name: str) -> Any:
        return self._hook("value", config, name)

    def replicates(self, config: Any) -> range | None:
        """The replicates a run of ``config`` holds; None if it is the one its seed names."""
        if not hasattr(self.module, "replicates"):
            return None
        replicates = self._hook("replicates", config)
        if not isinstance(replicates, range):
            raise self.problem("replicates", f"returned {type(replicates).__name__}, not a range of replicates")
        return replicates

    def outdated(self, config: Any, summary: Path) -> bool:
        return hasattr(self.module, "outdated") and self._hook("outdated", config, summary)

    def read_config(self, path: str | os.PathLike) -> Any:
        return self._hook("read_config", path)

    def table_schemas(self) -> dict[str, pyarrow.Schema]:
        return self._hook("table_schemas")

    def columns(self) -> dict[str, dict[str, Column]]:
        """What each column of each table holds (the optional ``columns`` hook): ``{table: {column:
        Column}}``, empty if the scenario documents none."""
        return self._hook("columns") if hasattr(self.module, "columns") else {}

    def simulate(self, config: Any) -> dict[str, pyarrow.Table]:
        """The run's tables: a dict of exactly the scenario's :attr:`tables`, each a pyarrow Table
        (HookError, one line, otherwise). An installed scenario's is called through
        :func:`dronefleet.sweeps.simulate`, in a process of its own, by the commands and the API."""
        import pyarrow as pa  # here, not at the top: the registry imports no pyarrow until a run

        tables = self._hook("simulate", config)
        if not isinstance(tables, dict):
            raise self.problem("simulate", f"returned {type(tables).__name__}, not a dict of its tables "
                                            f"({', '.join(self.tables)}) as pyarrow Tables")
        if set(tables) != set(self.tables):
            raise self.problem("simulate", f"returned the tables {', '.join(map(_show, tables)) or 'none'}; "
                                            f"its TABLES are {', '.join(self.tables)}")
        for name, table in tables.items():
            if not isinstance(table, pa.Table):
                raise self.problem("simulate", f"returned its table {name!r} as {type(table).__name__}, "
                                                "not a pyarrow Table")
        if not self.builtin:  # what a sweep would refuse as damage, said now, of the hook
            schemas = self.table_schemas()
            for name, table in tables.items():
                columns = {field.name: str(field.type) for field in table.schema}
                if name in schemas and columns != {field.name: str(field.type) for field in schemas[name]}:
                    raise self.problem("simulate", f"returned its table {name!r} with the columns {columns}, "
                                                    f"not those of its table_schemas()")
            replicates = len(self.replicates(config) or range(1))
            if tables["summary"].num_rows != replicates:
                raise self.problem("simulate", f"returned a summary of {tables['summary'].num_rows} rows, not one "
                                                f"per replicate ({replicates})")
        return tables

    def format_summary(self, tables: Mapping[str, pyarrow.Table]) -> str:
        return self._text("format_summary", tables)

    def describe(self, config: Any) -> str:
        """One line (the head of ``dronefleet run``)."""
        text = self._text("describe", config)
        if not text.isprintable():
            raise self.problem("describe", f"returned {_show(text)}, not one line of printable text")
        return text

    def label(self, config: Any) -> str:
        """A tag of the default run folder's name: one path component."""
        text = self._text("label", config)
        if not (text.isprintable() and 0 < len(text) <= 100) or any(c in text for c in "/\\") or \
                text in (".", ".."):
            raise self.problem("label", f"returned {_show(text)}, not a tag of at most 100 printable characters "
                                        "without / or \\ (a folder name)")
        return text

    @property
    def format_bounds(self) -> Callable | None:
        return getattr(self.module, "format_bounds", None)

    def _check_has_replay(self) -> None:
        if not hasattr(self.module, "replay_data"):
            having = [s.name for s in loading().values() if hasattr(s.module, "replay_data")]
            raise ConfigError(f"scenario {self.name!r} has no replay page; scenarios with one: {', '.join(having)}")

    def replay_data(self, run_dir: Path, trial: int | None = None) -> dict[str, Any]:
        """The replay page's data of the run folder ``run_dir`` (of its trial ``trial``; None: its
        first); ConfigError if the scenario has no replay or its runs no trials to choose, HookError
        if the data is not a JSON-ready dict with ``title`` and ``duration_s``."""
        self._check_has_replay()
        if trial is not None:
            self._check_has_trials(trial)
        data = self._hook("replay_data", run_dir, *(() if trial is None else (trial,)))
        if not isinstance(data, dict) or not isinstance(data.get("title"), str) or \
                not isinstance(data.get("duration_s"), (int, float)) or isinstance(data["duration_s"], bool):
            raise self.problem("replay_data", f"returned {type(data).__name__}, not a dict with a title (str) "
                                               "and duration_s (a number of seconds)")
        if not self.builtin:
            try:
                json.dumps(data)  # the page embeds it as JSON (NaN becomes null there)
            except (TypeError, ValueError, RecursionError) as error:
                raise self.problem("replay_data", f"returned data that is not JSON-ready: {error}") from None
        return data

    def _check_has_trials(self, trial: int) -> None:
        if not hasattr(self.module, "replicates"):
            raise ConfigError(f"--trial {trial}: a {self.name} run is one replicate, it has no trials to choose")

    def check_replayable(self, config: Any, trial: int | None = None) -> None:
        """ConfigError (one line) if the replay page of a run of ``config`` (of its trial
        ``trial``; None: its first) would be refused: asked before the run."""
        self._check_has_replay()
        if trial is not None:
            from .records import check_trial  # not at the top: the registry imports no numpy until used

            self._check_has_trials(trial)
            check_trial(trial, self.replicates(config), "the run")
        if hasattr(self.module, "check_replayable"):
            self._hook("check_replayable", config)

    @property
    def replay_script(self) -> str:
        """The JavaScript that draws the scenario's replay page (``replay.js`` beside the module of its
        ``replay_data``)."""
        package = importlib.import_module(self.module.replay_data.__module__).__package__
        return resources.files(package).joinpath("replay.js").read_text(encoding="utf-8")

    @property
    def study(self) -> FigureStudy | None:
        """Its figures in ``dronefleet reproduce`` (the optional ``study`` hook), or None."""
        study = getattr(self.module, "study", None)
        return None if study is None else study()


def _delivery() -> Any:
    from .delivery import scenario

    return scenario


def _replenishment() -> Any:
    from .replenishment import scenario

    return scenario


def _items() -> Any:
    from .items import scenario

    return scenario


def _lunar() -> Any:
    from .lunar import scenario

    return scenario


#: The built-in scenarios, the one place they are registered.
SCENARIOS: dict[str, Scenario] = {
    "delivery": Scenario("delivery", _delivery),
    "replenishment": Scenario("replenishment", _replenishment),
    "items": Scenario("items", _items),
    "lunar": Scenario("lunar", _lunar),
}


@functools.cache  # successes only: a refused entry point raises, and is tried again next time
def _load_entry_point(name: str) -> Any:
    """The scenario object of the installed entry point ``name``, checked against the contract."""
    declared = entry_points(group=ENTRY_POINT_GROUP, name=name)
    if len(declared) > 1:  # which one Python finds first depends on sys.path's order: neither is chosen
        raise ConfigError(f"the {ENTRY_POINT_GROUP} entry point {name!r} is declared by several installed "
                          f"distributions: {', '.join(sorted(f'{e.dist.name} ({e.value})' for e in declared))}; "
                          f"uninstall all but one")
    entry_point = next(iter(declared))
    where = f"the {ENTRY_POINT_GROUP} entry point {name!r} ({entry_point.value})"
    try:
        with importing(entry_point.module, f"scenario {name!r}"):
            scenario = entry_point.load()
    except Exception as error:  # the package's own error, whatever it is: the user must see it
        raise ConfigError(f"{where} fails to load: {type(error).__name__}: {error}".splitlines()[0]) from None
    problems = contract_problems(scenario)
    if not problems and scenario.NAME != name:
        problems = [f"its NAME is {scenario.NAME!r}"]
    if problems:
        raise ConfigError(f"{where} does not meet the scenario contract (docs/scenario-contract.md): "
                          f"{'; '.join(problems)}")
    return scenario


def installed() -> dict[str, Scenario]:
    """The scenarios installed as entry points of :data:`~dronefleet.contract.ENTRY_POINT_GROUP`, by name
    (read from the packages' metadata; nothing is imported until one is used). One named like a built-in
    would never run: it is left out, said in a warning, rather than silently shadowed."""
    found = {}
    for entry_point in sorted(entry_points(group=ENTRY_POINT_GROUP), key=lambda e: e.name):
        if entry_point.name in SCENARIOS:
            warn_left_out(entry_point.name, f"the {ENTRY_POINT_GROUP} entry point {entry_point.name!r} "
                                            f"({entry_point.value}) is named like the built-in scenario, which is "
                                            f"what runs: rename it in its package's pyproject.toml, or uninstall it")
            continue
        found[entry_point.name] = Scenario(entry_point.name, functools.partial(_load_entry_point, entry_point.name))
    return found


def registered() -> dict[str, Scenario]:
    """Every registered scenario by name: the built-ins, then the installed ones (:func:`installed`)."""
    return {**SCENARIOS, **installed()}


@functools.cache  # once per scenario, reason and process: every list of the scenarios meets it
def warn_left_out(name: str, why: str) -> None:
    """Say, once, that the installed scenario ``name`` is left out of the lists of scenarios, and ``why``."""
    logger.warning(f"dronefleet: warning: installed scenario {name!r} left out: {why}")


def loading() -> dict[str, Scenario]:
    """The registered scenarios that load: the built-ins and each installed one that imports and meets
    the contract. One that does not is left out, said once in a warning naming its entry point: it
    breaks only what names it (a config, sweep or call, refused there in one line by :func:`get`),
    not the lists of every scenario (studies, figures, replay pages, bounds) the others rely on."""
    found = {}
    for name, scenario in registered().items():
        if name not in SCENARIOS:
            try:
                _load_entry_point(name)
            except ConfigError as error:
                warn_left_out(name, str(error))
                continue
        found[name] = scenario
    return found


def get(name: object, where: str = "") -> Scenario:
    """The scenario registered as ``name``, its contract checked if installed; ConfigError listing the
    registered ones if none."""
    if isinstance(name, str) and name in SCENARIOS:
        return SCENARIOS[name]
    every = registered()
    if isinstance(name, str) and name in every:
        _load_entry_point(name)  # refused now, before any work, if it fails to load or breaks the contract
        return every[name]
    suggestion = _suggest(name, every) if isinstance(name, str) else ""
    raise ConfigError(f"{where}unknown scenario {_show(name)}{suggestion}; "
                      f"registered scenarios: {', '.join(every)}", [SCENARIO_KEY])


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
