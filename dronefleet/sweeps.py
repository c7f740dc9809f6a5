"""Parameter sweeps: a grid of config values times seeds, one hive-partitioned dataset, for any scenario.

From Python, ``dronefleet.sweep(grid, seeds=...)`` (:func:`dronefleet.api.sweep`) runs a sweep
without a file and returns its summaries as a pandas DataFrame.

A sweep file is TOML (``configs/sweeps/``). A delivery sweep::

    [sweep]
    name = "rules"              # the dataset is <results>/rules/ (default: the file's stem)
    base = "../paper.toml"      # config file, relative to this file (default: the scenario's defaults)
    seeds = { start = 0, count = 20 }   # or a list: seeds = [0, 1, 2]
    runs_per_task = 10          # runs per job-array task (default 10)
    [set]                       # fixed changes to the base: any config keys
    horizon_weeks = 8
    [grid]                      # lists of values: the runs are their full product times the seeds
    rule = ["least_confident", "most_confident", "random"]
    tau_minutes = [15, 20, 25, 30, 35, 40]

and an energy-replenishment one (``configs/sweeps/replenishment-fig10.toml``)::

    [sweep]
    name = "replenishment-fig10"
    scenario = "replenishment"  # or a base config that names it; default: "delivery"
    [set]
    trials = 50                 # a run holds all the trials of its configuration
    ticks = 6000
    [[grid]]                    # several products: the runs are their union, in file order
    strategy = ["fixed"]
    work_ratio = [0.1, 0.25, 0.5, 1.0]
    [[grid]]
    strategy = ["mobile"]
    n_chargers = [6]
    work_ratio = [0.1, 0.25, 0.5, 1.0]

The scenario (:mod:`dronefleet.scenarios`) is the one the base config names, or ``[sweep]
scenario``, or delivery; both given must agree. Everything scenario-specific comes through
its contract: the keys, their types and validation (``resolve_key``, ``replace``), the seed
key, the tables, ``simulate``, ``read_config`` and when a done run is outdated.

Keys in ``[set]`` and ``[grid]`` are ``section.key`` or bare key names, as with
``dronefleet run --set``. :func:`load_sweep` builds (and so validates) the config of
every run before anything runs; any problem is a :class:`SweepError` naming the key.

Seeds: ``[sweep] seeds`` sets the scenario's root seed (its seed key, ``seed``), one run per
value, as ``--seed`` and ``dronefleet.run(seed=...)`` do. A delivery run is one replicate of its
``seed``, and a delivery sweep must list its seeds. An items or lunar run holds several
replicates (trials ``first_trial ..``, runs ``first_run ..``) of its root seed: seeds are
optional, without them each configuration is one run at the base's seed. A replenishment run
has no root seed (trial k uses seed 876 k): its seeds are refused, and ``first_trial = [1, 51]``
in the grid with ``trials = 50`` runs trials 1-100 in two runs per configuration.

``[grid]`` is one table of lists: the runs are their product. Its keys are taken in one
canonical order, sorted by name, whatever their order in the file: two files that differ
only in the order of their ``[grid]`` keys are the same sweep (same runs, same tasks). ``[[grid]]``
(an array of tables) gives several products: the runs are their union, table after table
in file order, each product with its keys in the file's order (the first varies slowest),
so the author's order is the run order. A configuration given twice is refused. Runs are
enumerated in that order, the last key varying fastest and seeds innermost. Task ``k`` of a
job array (0-based) holds runs ``[k * runs_per_task, (k + 1) * runs_per_task)``.

``[design]``, in place of ``[grid]``, samples points from ranges of keys (:mod:`dronefleet.designs`):
each distinct point is a run like a grid cell (its keys, sorted, are the partition keys), in
sample order, seeds innermost.

The dataset of a sweep, under ``<results>/<name>/``::

    <table>/<key>=<value>/.../<seed key>=<N>/part-0.parquet   one file per run and table
    _failed/<run id>.json                               runs that raised or whose worker died, with the error
    _layout.json                                        the partition keys and scenario: a sweep of others is refused
    collected.parquet                                   `sweep collect`: each run's summary rows
    samples.parquet                                     a [design]'s points, in sample order (`sweep run`)
    <name>.sbatch, _logs/                               `sweep plan`: job-array script, its logs

``<table>`` is each of the scenario's tables (delivery: ``orders, attempts, fleet,
timeseries, summary``; replenishment: ``summary``, one row per trial, and ``timeseries``),
so every table is its own hive dataset that pandas, pyarrow and DuckDB read as one table.
The partition keys are the grid's parameter names (bare, sorted by name; with ``[[grid]]``
the keys of any of its tables), then the root seed if the scenario has one: ``seed``, or
``root_seed`` where a run holds several replicates whose tables carry each one's own stream
seed as ``seed`` (items, lunar; :func:`partition_name`); values are
``str(value)`` of the config's value (``15.0``, ``3``, ``random``), percent-encoded as hive
readers expect, so one layout holds every run of a ``[[grid]]`` union (a key that a table
does not name has the run's value from the base or ``[set]``). A file holds no column named
like a partition key (delivery's and lunar's ``summary`` repeat config values: they come back
from the path, and :func:`read_part` puts them back as the run folder's table holds them),
because readers refuse a column that is both. Directories starting with ``_`` are
skipped by dataset readers.

A dataset folder is absent, empty, a dataset or holds only what dronefleet writes there
(:func:`check_layout`): a sweep never writes among the user's files, nor replaces a
``collected.parquet`` that ``collect`` did not write (:func:`check_collected`).

A run is done when its ``summary`` file (written last, atomically, like every file) exists
and carries the run's config, and the scenario does not find it outdated (delivery: its
``fleet_file`` written again since; see :func:`state`): a sweep started again skips done runs
and redoes the others, replacing what an interrupted attempt wrote. (A kill in the middle of
a write can leave a hidden ``.part-0.parquet.<pid>.tmp``, which readers ignore.)
A run with a file that cannot be used (truncated, garbled, other columns, no config, a
summary of another number of rows than the run's replicates: see
:func:`damage`) is damaged: not done, named in one line wherever it is met, redone by a
sweep run. Side files (``_layout.json``, ``_failed/`` records) are read as data
(:func:`dronefleet.datafiles.read_json`: a regular file of at most 1 MB, nested at most 32
deep) and their keys checked before use.
"""

from __future__ import annotations

import itertools
import json
import logging
import math
import os
import re
import shlex
import stat
import sys
import time
import traceback
from collections.abc import Callable, Mapping, Sequence
from contextlib import suppress
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any
from urllib.parse import quote, unquote

from . import console, designs, scenarios
from .config import SCENARIO_KEY, ConfigError, SweepError, _show, check_depth, named_file, one_line, read_toml
from .datafiles import DataError, check_columns, parquet_rows, parquet_schema, parse_json, read_json, read_parquet
from .outputs import PROBE_PREFIX, OutputError, check_output_file, probe_folders, writing
from .scenarios import Scenario

if TYPE_CHECKING:
    import argparse

    import pyarrow
    import pyarrow.compute
    import pyarrow.dataset

log = logging.getLogger(__name__)

#: Environment variables that give a job-array task's index, with the index of the
#: scheduler's first task: SGE and LSF arrays start at 1, so their task k is index k + 1.
TASK_VARIABLES = (("SLURM_ARRAY_TASK_ID", 0), ("PBS_ARRAY_INDEX", 0), ("SGE_TASK_ID", 1), ("LSB_JOBINDEX", 1))

#: The most runs one sweep may hold: checked (from the grid's sizes) before any run's config
#: is built, so a typo in a seed count is refused at once, not after hours or a MemoryError.
MAX_RUNS = 100_000

#: Longest sweep name: it names a folder and its job-array script (file names hold 255 bytes).
MAX_NAME = 100

_SECTIONS = ("sweep", "set", "grid", "design")
_SWEEP_KEYS = ("name", "base", "seeds", "runs_per_task", SCENARIO_KEY)
_SEED_RANGE_KEYS = ("start", "count")
_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9._-]*")
#: A Dask scheduler address: [protocol://]host:port (Dask's default protocol is tcp), host a
#: name, an IPv4 or a bracketed IPv6 address.
_LABEL = r"[A-Za-z0-9](?:[A-Za-z0-9-]{0,61}[A-Za-z0-9])?"   # of a host name: 1-63 characters
_SCHEDULER = re.compile(rf"(?:(?:tcp|tls|ucx|ws|wss)://)?(?P<host>{_LABEL}(?:\.{_LABEL})*|\[[0-9A-Fa-f:.]+\])"
                        r":(?P<port>[0-9]{1,5})")


#: The partition name of the root seed of a scenario whose run holds several replicates: its tables
#: carry each replicate's own stream seed as a column ``seed`` (items, lunar), which a partition
#: named ``seed`` would replace with the root seed (hive readers refuse a column that is both).
ROOT_SEED = "root_seed"


def partition_name(scenario: Scenario, key: str) -> str:
    """The name of config key ``key`` in a sweep's partition paths: the key itself, but
    :data:`ROOT_SEED` for the root seed of a scenario whose runs hold several replicates."""
    several = hasattr(scenario.module, "replicates")
    return ROOT_SEED if several and key == scenario.seed_key else key


def config_key(scenario: Scenario, name: str) -> str:
    """The config key of partition name ``name`` (:func:`partition_name`'s inverse)."""
    return scenario.seed_key if name == ROOT_SEED and scenario.seed_key is not None else name


@dataclass(frozen=True)
class Run:
    """One run of a sweep: its resolved config, the partition keys that place it, its scenario."""

    config: Any
    keys: tuple[str, ...]   # the grid's parameter names (sorted), then the seed's partition name (if any)
    scenario: Scenario

    def value(self, key: str) -> Any:
        """The run's value of partition key or config key ``key``."""
        return self.scenario.value(self.config, config_key(self.scenario, key))

    @property
    def partition(self) -> str:
        """Hive path of the run, e.g. ``rule=random/tau_minutes=15.0/seed=3``."""
        return "/".join(f"{key}={quote(str(self.value(key)), safe='')}" for key in self.keys)

    @property
    def id(self) -> str:
        """The partition as one file name: ``rule=random,tau_minutes=15.0,seed=3``."""
        return self.partition.replace("/", ",")  # values are encoded, so "/" and "," only separate

    def path(self, out: Path, table: str) -> Path:
        """The run's file of ``table`` in the dataset ``out``."""
        return out / table / self.partition / "part-0.parquet"

    def failure_path(self, out: Path) -> Path:
        return out / "_failed" / f"{self.id}.json"


@dataclass(frozen=True)
class Sweep:
    """A sweep file, read and validated: its scenario, grid, seeds and every run's config."""

    path: Path                        # the sweep file, absolute
    name: str
    scenario: Scenario
    products: tuple[dict[str, tuple], ...]  # each [[grid]] table (or the [grid]): key -> values, in run order
    grid: dict[str, tuple]            # parameter name (sorted) -> every value it takes, as the config holds them
    seeds: tuple[int, ...]
    runs_per_task: int
    runs: tuple[Run, ...]             # in task order
    text: str                         # the file's content, kept in collected.parquet
    design: designs.Design | None = None  # a [design] sweep's sampled points (its products are then empty)

    @property
    def n_tasks(self) -> int:
        return math.ceil(len(self.runs) / self.runs_per_task)

    def task(self, k: int) -> tuple[Run, ...]:
        """The runs of job-array task ``k`` (0-based)."""
        if not 0 <= k < self.n_tasks:
            raise SweepError(f"task {k} does not exist: sweep {self.name} has {self.n_tasks} tasks, "
                             f"0-{self.n_tasks - 1} ({self.runs_per_task} runs each)")
        return self.runs[k * self.runs_per_task:(k + 1) * self.runs_per_task]

    def describe(self) -> str:
        """``3 rule x 6 tau_minutes x 20 seeds = 360 runs``; with ``[[grid]]``, the products summed:
        ``(9 work_ratio + 9 work_ratio) x 1 seed = 18 runs`` (a key of one value is not shown); a
        scenario without a root seed has no seeds factor; with ``[design]``, ``sobol design: 64 samples
        of 4 keys = 640 points (631 distinct) x 2 seeds = 1262 runs``."""
        n_seeds = len(self.seeds) if self.scenario.seed_key is not None else None
        if self.design is not None:
            seeds = "" if n_seeds is None else f" x {n_seeds} seed{'s' if n_seeds != 1 else ''}"
            return f"{self.design.describe()}{seeds} = {len(self.runs)} runs"
        return f"{_factors(self.products, n_seeds)} = {len(self.runs)} runs"


def _factors(products, n_seeds: int | None) -> str:
    """``3 rule x 6 tau_minutes x 20 seeds``, or ``(1 point + 7 n_chargers x 5 charger_capacity_factor) x 1 seed``;
    no seeds factor for ``n_seeds`` None (a scenario without a root seed)."""
    seeds = [] if n_seeds is None else [f"{n_seeds} seed{'s' if n_seeds != 1 else ''}"]
    if len(products) == 1:
        return " x ".join([*(f"{len(values)} {key}" for key, values in products[0].items()), *seeds]) or "1 point"
    terms = [" x ".join(f"{len(values)} {key}" for key, values in product.items() if len(values) > 1) or "1 point"
             for product in products]
    return " x ".join([f"({' + '.join(terms)})", *seeds])


# --------------------------------------------------------------------------- reading a sweep file


def _check_names(table: dict, allowed: tuple[str, ...], where: str) -> None:
    for key in table:
        if key not in allowed:
            raise SweepError(f"{where}: unknown key {key!r}. Allowed: {', '.join(allowed)}")


def _parameters(table, scenario: Scenario, where: str) -> dict:
    """The entries of [set] or a grid table by parameter name; keys are ``section.key`` or bare.

    TOML reads ``auction.rule = ...`` as a table ``auction`` holding ``rule``: one level of
    nesting is a section.
    """
    if not isinstance(table, dict):
        raise SweepError(f"{where} must be a table of key = value")
    out = {}
    for key, value in table.items():
        # keys from the Python API may be anything: a key is a name, never joined or resolved otherwise
        for name in (key, *(value if isinstance(value, dict) else ())):
            if not isinstance(name, str):
                raise SweepError(f"{where}: key {_show(name)} is not a string: keys are names such as "
                                 "'tau_minutes' or 'orders.tau_minutes'")
        entries = [(f"{key}.{k}", v) for k, v in value.items()] if isinstance(value, dict) else [(key, value)]
        for text, v in entries:
            try:
                name = scenario.resolve_key(text)
            except ConfigError as error:
                raise SweepError(f"{where}: {error}", error.keys) from None
            if name == scenario.seed_key:
                raise SweepError(f"{where}: {name} cannot be set here: it is the seed key, given by [sweep] seeds",
                                 [name])
            if name in out:
                raise SweepError(f"{where}: {name} is given twice", [name])
            out[name] = v
    return out


def _repeated(values: list):
    """The first value that equals an earlier one (15 equals 15.0 and True, [15] equals [15.0], as
    Python's ``==`` has them), or None; in one pass, lists too, as a grid of 100,000 values must
    not take minutes to check. The values are nested at most :data:`~dronefleet.config.MAX_DEPTH` deep."""
    seen = set()  # equal numbers hash alike: 15 and 15.0 meet here too
    for value in values:
        key = _hashable(value)
        if key in seen:
            return value
        seen.add(key)
    return None


class _Container:
    """Tags :func:`_hashable`'s stand-ins for lists and dicts: no value given can equal them."""

    def __init__(self, name: str) -> None:
        self.name = name


_LIST, _DICT, _OTHER = _Container("list"), _Container("dict"), _Container("unhashable")


def _hashable(value):
    """A hashable stand-in for ``value`` that equals another's exactly when the values are ``==``:
    a list by its items' stand-ins (never equal to a tuple, as ``[1] != (1,)``), a dict by its
    items, a set as a frozenset. Another unhashable value (from the API: a bytearray, an array)
    stands for itself alone; no config holds one, and its run is refused naming it."""
    if isinstance(value, list):
        return _LIST, tuple(_hashable(v) for v in value)
    if isinstance(value, tuple):
        return tuple(_hashable(v) for v in value)
    if isinstance(value, dict):
        return _DICT, frozenset((k, _hashable(v)) for k, v in value.items())
    if isinstance(value, set):
        return frozenset(value)
    try:
        hash(value)
    except TypeError:
        return _OTHER, id(value)
    return value


def _products(grid, scenario: Scenario, where: str) -> list[tuple[str, dict[str, list]]]:
    """``[grid]`` (one table) or ``[[grid]]`` (an array of tables) -> ``(label, {key: values})``
    per product, keys in run order: sorted for ``[grid]``, as written for each ``[[grid]]`` table."""
    if isinstance(grid, list):
        tables = [(f"[[grid]] {n}", table, False) for n, table in enumerate(grid, 1)]
    else:
        tables = [("[grid]", {} if grid is None else grid, True)]
    empty = ("is empty: a sweep needs at least one key with a list of values "
             "(to sweep seeds only, give one value: rule = [\"least_confident\"])")
    if not tables:
        raise SweepError(f"{where}: [[grid]] {empty}")
    products = []
    for label, table, canonical in tables:
        product = _parameters(table, scenario, f"{where}: {label}")
        if not product:
            raise SweepError(f"{where}: {label} {empty}")
        for name, values in product.items():
            if type(scenario.defaults[name]) is tuple:
                raise SweepError(f"{where}: {label}: {name} holds a list of numbers and cannot be a grid key "
                                 "(a partition value is one number or string); set it in [set] or the base",
                                 [name])
            if not isinstance(values, list):
                raise SweepError(f"{where}: {label}: {name} must be a list of values, got {_show(values)} "
                                 "(a fixed value goes in [set])", [name])
            if not values:
                raise SweepError(f"{where}: {label}: {name} is an empty list: it would make no runs", [name])
            if (value := _repeated(values)) is not None:
                raise SweepError(f"{where}: {label}: {name} lists {_show(value)} more than once", [name])
        # [grid]'s canonical key order: a file's key order changes neither its runs nor its tasks
        products.append((label, dict(sorted(product.items())) if canonical else product))
    return products


def _seeds(value, where: str) -> tuple:
    """``[0, 1, 2]`` or ``{ start = 0, count = 20 }`` -> the seeds (each then checked by the config)."""
    if isinstance(value, dict):
        _check_names(value, _SEED_RANGE_KEYS, where)
        start, count = value.get("start", 0), value.get("count")
        if not all(isinstance(x, int) and not isinstance(x, bool) for x in (start, count)) or count < 1:
            raise SweepError(f"{where}: a range is {{ start = <integer>, count = <integer >= 1> }}, "
                             f"got {_show(value)}", ["seed"])
        if count > MAX_RUNS:  # before the tuple is built: a count of 10**12 would exhaust memory
            raise SweepError(f"{where}: count = {count} seeds is more than a sweep may run: "
                             f"at most {MAX_RUNS:,} runs per sweep", ["seed"])
        return tuple(range(start, start + count))
    if isinstance(value, list) and value:
        if (seed := _repeated(value)) is not None:
            raise SweepError(f"{where}: seed {_show(seed)} is listed more than once", ["seed"])
        return tuple(value)
    raise SweepError(f"{where}: give a non-empty list (seeds = [0, 1, 2]) or a range "
                     f"(seeds = {{ start = 0, count = 20 }}), got {_show(value)}", ["seed"])


def _scenario(head: dict, base: Path | None, path: Path) -> Scenario:
    """The sweep's scenario: the one its base config names, or ``[sweep] scenario``, or delivery."""
    named = head.get(SCENARIO_KEY)
    try:
        scenario = None if named is None else scenarios.get(named, f"{path}: [sweep] ")
    except ConfigError as error:
        raise SweepError(str(error), error.keys) from None
    if base is None:
        return scenario or scenarios.SCENARIOS["delivery"]
    try:
        of_base = scenarios.scenario_of(base)
    except ConfigError as error:
        raise SweepError(f"{path}: [sweep] base: {error}", error.keys) from None
    if scenario is not None and scenario is not of_base:
        raise SweepError(f"{path}: [sweep] scenario = {named!r}, but the base {str(base)!r} is a {of_base.name} "
                         "config: name one scenario", [SCENARIO_KEY])
    return of_base


def load_sweep(path: str | os.PathLike, changes: Mapping[str, Any] | None = None,
               seeds: Sequence[int] | None = None) -> Sweep:
    """Read and validate a sweep file: every run's config is built here, before any run.

    ``changes`` (config keys -> values, as in ``[set]``) override the file's ``[set]``, and
    ``seeds`` (a list of ints) its seeds: a quicker variant of the same sweep, say.

    Raises
    ------
    SweepError
        Unreadable file, unknown section or key (the message lists the allowed ones), an
        unknown scenario or one the base contradicts, an empty or missing grid, a value given
        twice, a configuration given twice, seeds whose runs overlap, or any config value that
        the scenario refuses (the message names the key, the grid point and what is allowed).
    """
    path = Path(path)
    try:
        text, doc = read_toml(path, "sweep file")
    except ConfigError as error:
        raise SweepError(str(error)) from None
    return sweep_of_document(doc, path, text, changes, seeds)


def sweep_of_document(doc: dict, path: Path, text: str, changes: Mapping[str, Any] | None = None,
                      seeds: Sequence[int] | None = None) -> Sweep:
    """:func:`load_sweep` of a sweep file's TOML document ``doc``, already read (or built in
    memory, as :func:`dronefleet.api.sweep` does): ``path`` names it in messages, gives the
    default name (its stem) and the folder ``[sweep] base`` is relative to; ``text`` is kept
    in ``collected.parquet``. Raises SweepError as :func:`load_sweep` does."""
    try:  # a document built in Python (dronefleet.sweep) has not been through read_toml
        for value, what in ((doc, ""), (changes, "changes"), (seeds, "seeds")):
            check_depth(value, f"{path}: ", what)
    except ConfigError as error:
        raise SweepError(str(error)) from None
    _check_names(doc, _SECTIONS, f"{path}: sections")
    head = doc.get("sweep", {})
    if not isinstance(head, dict):
        raise SweepError(f"{path}: [sweep] must be a table")
    _check_names(head, _SWEEP_KEYS, f"{path}: [sweep]")

    name = head.get("name", path.stem)
    if not isinstance(name, str) or not _NAME.fullmatch(name) or len(name) > MAX_NAME:
        raise SweepError(f"{path}: [sweep] name = {_show(name)}: use up to {MAX_NAME} letters, digits, '.', '_' "
                         "and '-', starting with a letter or digit (it names the results directory)")
    runs_per_task = head.get("runs_per_task", 10)
    if not isinstance(runs_per_task, int) or isinstance(runs_per_task, bool) or runs_per_task < 1:
        raise SweepError(f"{path}: [sweep] runs_per_task must be an integer >= 1, got {_show(runs_per_task)}")
    base = head.get("base")
    if base is not None and not isinstance(base, str):
        raise SweepError(f"{path}: [sweep] base must be a path (string), got {_show(base)}")
    base = None if base is None else path.parent / base
    scenario = _scenario(head, base, path)
    key = scenario.seed_key

    fixed = _parameters(doc.get("set", {}), scenario, f"{path}: [set]")
    fixed.update(_parameters(dict(changes or {}), scenario, f"{path}: changes"))
    if "design" in doc and "grid" in doc:
        raise SweepError(f"{path}: give [grid] (values to combine) or [design] (ranges to sample), not both")
    products = [] if "design" in doc else _products(doc.get("grid"), scenario, path)
    for label, product in products:
        both = [k for k in product if k in fixed]
        if both:
            raise SweepError(f"{path}: {both[0]} is both fixed ([set] or changes) and in {label}", both)
    listed = head.get("seeds") if seeds is None else list(seeds)
    if key is None and listed is not None:  # "seed" means the root seed everywhere, never a replicate's index
        raise SweepError(str(scenario.seed_refusal(f"{path}: [sweep] seeds")), ["seeds"])
    # without seeds (where the scenario allows it), one run per configuration at the base's seed value
    seeds = None if listed is None and not scenario.seeds_required else _seeds(listed, f"{path}: [sweep] seeds")
    per_point = 1 if seeds is None else len(seeds)
    design = None
    if "design" in doc:  # sampled here: its points are checked against the run limit before they are drawn
        table = doc["design"]
        ranges = _parameters(table.get("ranges", {}) if isinstance(table, dict) else {}, scenario,
                             f"{path}: [design.ranges]")
        design = designs.read_design(table, ranges, scenario, f"{path}: [design]", MAX_RUNS, per_point)
        both = [k for k in design.keys if k in fixed]
        if both:
            raise SweepError(f"{path}: {both[0]} is both fixed ([set] or changes) and in [design.ranges]", both)
    n_runs = sum(math.prod(len(values) for values in product.values()) for _, product in products) * per_point
    if n_runs > MAX_RUNS:
        factors = _factors([product for _, product in products], None if key is None else per_point)
        raise SweepError(f"{path}: {factors} = {n_runs:,} runs; a sweep may hold at most {MAX_RUNS:,} runs: "
                         "split it into several sweeps (another [sweep] name each)")

    try:
        config = scenario.load(base)
    except ConfigError as error:
        raise SweepError(f"{path}: [sweep] base: {error}", error.keys) from None
    try:
        config = scenario.replace(config, fixed)
    except ConfigError as error:
        raise SweepError(f"{path}: [set]: {error}", error.keys) from None
    if seeds is None:
        seeds = () if key is None else (scenario.value(config, key),)
    for seed in seeds:
        try:
            scenario.replace(config, {key: seed})
        except ConfigError as error:
            raise SweepError(f"{path}: [sweep] seeds: {error}", error.keys) from None
    grid_keys = design.keys if design else tuple(sorted({k for _, product in products for k in product}))
    keys = grid_keys if key is None else (*grid_keys, partition_name(scenario, key))
    # each grid cell, or each distinct point of the design (points that round alike share their run)
    points = ([("[design]", changes) for changes in design.distinct()] if design else
              [(label, dict(zip(product, point))) for label, product in products
               for point in itertools.product(*product.values())])
    runs, given = [], {}   # given: each configuration -> the grid point that gave it first
    for label, changes in points:
        where = f"{label} at {', '.join(f'{k} = {_show(v)}' for k, v in changes.items())}"
        try:
            at_point = scenario.replace(config, changes)
        except ConfigError as error:
            raise SweepError(f"{path}: {where}: {error}", error.keys) from None
        if at_point in given:
            raise SweepError(f"{path}: {where} is the configuration of {given[at_point]}: "
                             "a sweep runs each configuration once", list(changes))
        given[at_point] = where
        runs.extend([Run(scenario.replace(at_point, {key: seed}), keys, scenario) for seed in seeds] if seeds
                    else [Run(at_point, keys, scenario)])
    values = {k: tuple(dict.fromkeys(run.value(k) for run in runs)) for k in grid_keys}
    return Sweep(path.absolute(), name, scenario, tuple({k: tuple(v) for k, v in product.items()}
                                                       for _, product in products),
                 values, seeds, runs_per_task, tuple(runs), text, design)


# --------------------------------------------------------------------------- one run


def simulate(scenario: Scenario, config: Any) -> dict[str, pyarrow.Table]:
    """``scenario.simulate(config)`` for ``dronefleet run``, the API and a replay: a built-in's in
    this process, an installed scenario's in a worker process of its own
    (:func:`dronefleet.executors.contained`), so that one that ends its process (``os._exit``), is
    killed or crashes is a HookError (one line), not the silent end of the caller."""
    if scenario.builtin:
        return scenario.simulate(config)
    from . import executors

    try:
        return executors.contained(scenario.simulate, config)
    except executors.WorkerDied as died:
        raise scenario.problem("simulate", f"ended its process ({died.how}) before returning its tables") from None


def execute(run: Run, out: Path) -> str | None:
    """Simulate ``run`` and write its tables into the dataset ``out``.

    A run that raises is recorded in ``_failed/<run id>.json`` (error, traceback, config)
    and its error returned as one line; a run that succeeds removes any such record and
    returns None. Runs in worker processes: the scenario imports its simulator there.
    """
    from .records import write_table

    try:
        tables = run.scenario.simulate(run.config)
        # Files of an interrupted attempt are replaced, not deleted first: two processes that
        # happen to run the same run (a task submitted twice) then write the same bytes safely.
        # The summary last: its file marks the run done.
        for table in sorted(tables, key=lambda name: name == "summary"):
            data, path = tables[table], run.path(out, table)
            path.parent.mkdir(parents=True, exist_ok=True)
            write_table(data.drop_columns([k for k in run.keys if k in data.column_names]), path, run.config)
    except Exception as error:  # recorded, and the sweep goes on with the other runs
        return _record_failure(run, out, f"{type(error).__name__}: {error}", traceback.format_exc())
    failure = run.failure_path(out)
    try:
        failure.unlink(missing_ok=True)
    except OSError as error:  # the run is done (its summary says so); the stale record only misleads
        _report(f"cannot remove the failure record {failure} of run {run.partition}, which is now done: "
                f"{error.strerror or error}")
    return None


def _report(message: str) -> None:
    log.warning(f"dronefleet: warning: {message}")


def _record_failure(run: Run, out: Path, error: str, trace: str) -> str:
    """Write ``_failed/<run id>.json`` (error, traceback, config) for ``run``; return the error's
    first line, as a terminal may show it.

    A record that cannot be written (``_failed`` unwritable, disk full) is reported on
    stderr, one line, and the sweep goes on: the run is not done either way, so ``status``
    lists it as missing and a rerun redoes it, and the command still reports the error.
    """
    from .records import write_atomic

    record = {"run": run.partition, "error": error, "traceback": trace, "config": run.config.to_dict()}
    failure = run.failure_path(out)
    try:
        failure.parent.mkdir(parents=True, exist_ok=True)
        write_atomic(failure, lambda tmp: tmp.write_text(json.dumps(record, indent=2) + "\n"))
    except OSError as problem:
        _report(f"cannot write the failure record {failure} of run {run.partition} "
                f"({problem.strerror or problem}); its error: {_first_line(error)}")
    return _first_line(error)


def _first_line(error: str) -> str:
    """The first line of a recorded error (a plugin's may hold many, or escape sequences), shown as text."""
    return one_line((error.splitlines() or [""])[0])[:500]


def _config_difference(scenario: Scenario, a, b) -> str:
    """``n_uavs 10 vs 11``: the keys whose values differ between configs ``a`` and ``b``."""
    values = [(key, scenario.value(a, key), scenario.value(b, key)) for key in scenario.schema]
    return ", ".join(f"{key} {x!r} vs {y!r}" for key, x, y in values if x != y)


def _part_columns(run: Run, table: str, schemas: Mapping[str, pyarrow.Schema]) -> dict[str, pyarrow.DataType]:
    """The columns (name -> type) of ``run``'s file of ``table``: the scenario's, less the
    partition keys (they come back from the path)."""
    return {field.name: field.type for field in schemas[table] if field.name not in run.keys}


def read_part(run: Run, out: Path, table: str) -> pyarrow.Table:
    """``run``'s file of ``table`` in the dataset ``out`` as the scenario writes the table (the
    run folder's file): the partition keys its schema holds put back as columns (their values
    come from the path, so the file left them out), in the schema's order and types; its metadata
    (config, provenance) kept. DataError naming the file as :func:`damage`."""
    import pyarrow as pa

    schema = run.scenario.table_schemas()[table]
    data = read_parquet(run.path(out, table), _part_columns(run, table, {table: schema}), "part", exact=True)
    columns = [pa.array([run.value(field.name)] * data.num_rows, field.type) if field.name in run.keys
               else data.column(field.name) for field in schema]
    return pa.Table.from_arrays(columns, schema=schema.with_metadata(data.schema.metadata))


def damage(run: Run, out: Path) -> str | None:
    """Why the files of ``run`` (whose summary is there) cannot be used, in one line naming the
    file; None if they can.

    Each table's file must be a regular parquet file of at most
    :data:`~dronefleet.datafiles.MAX_TABLE_BYTES` bytes whose footer reads, holding exactly the
    scenario's columns and types (:meth:`~dronefleet.scenarios.Scenario.table_schemas`, less the
    partition keys) and the run's config in its metadata. The summary must hold one row per
    replicate of the run (delivery: one; replenishment, items: one per trial; lunar: per run) and
    is read whole, so damage inside it is found too; the other tables are checked from their
    footers alone (a truncated file has none), their numbers of rows not at all (a scenario gives
    no bound for them): damage inside one of their pages is found when they are read (:func:`rows`).

    Raises SweepError if the summary was made with another config (the sweep file changed
    since): new results would silently mix with old ones.
    """
    from .records import CONFIG_KEY

    schemas = run.scenario.table_schemas()
    expected = json.loads(run.config.to_json())
    replicates = len(run.scenario.replicates(run.config) or range(1))
    for table in sorted(run.scenario.tables, key=lambda name: name != "summary"):  # the summary first
        path = run.path(out, table)
        columns = _part_columns(run, table, schemas)
        try:
            if table == "summary":
                rows = parquet_rows(path, "part")  # from the footer: a summary of 1e9 rows is not read
                if rows != replicates:
                    raise DataError(f"part {str(path)!r} holds {rows:,} rows; the summary of run {run.partition} "
                                    f"holds {replicates} (one per replicate)")
                schema = read_parquet(path, columns, "part", exact=True).schema
            else:
                schema = parquet_schema(path, "part")
                check_columns(schema, columns, path, "part", exact=True)
            text = (schema.metadata or {}).get(CONFIG_KEY)
            if text is None:
                raise DataError(f"part {str(path)!r} has no config in its metadata")
            if parse_json(text, f"the config in part {str(path)!r}") == expected:
                continue
            found = run.scenario.read_config(path)  # the same config, maybe spelled by another version
        except DataError as error:
            return str(error)
        except ConfigError as error:
            return f"the config in part {str(path)!r} is not a {run.scenario.name} config ({error})"
        if found == run.config:
            continue
        difference = _config_difference(run.scenario, found, run.config)
        if table == "summary":
            raise SweepError(f"{path} was made with another config ({difference}); "
                             f"write to another --results root, or remove {out} to start again")
        return f"part {str(path)!r} was made with another config than its run's summary ({difference})"
    return None


def _check_part_files(run: Run, out: Path) -> None:
    """Refuse (SweepError, one line naming it) a folder where a file of ``run`` goes: the run's
    write renames its file over it, which fails for a folder only (a special file or a link is
    replaced, as a damaged part), so every run would be redone to fail the same way. The
    user's folder is not removed."""
    for table in run.scenario.tables:
        path = run.path(out, table)
        try:
            folder = stat.S_ISDIR(os.lstat(path).st_mode)
        except OSError:  # absent (or its folder is): the run writes it
            continue
        if folder:
            raise SweepError(f"the dataset {out} is damaged: {str(path)!r}, the {table} file of run {run.partition}, "
                             "is a folder, which the run cannot replace: move or remove it")


def inspect(run: Run, out: Path) -> tuple[str, str | None]:
    """``(state, why)``: :func:`state`, with :func:`damage`'s line for a damaged run (else None)."""
    summary = run.path(out, "summary")
    if os.path.lexists(summary):
        problem = damage(run, out)
        if problem is not None:
            return "damaged", problem
        if not run.scenario.outdated(run.config, summary):
            return "done", None
    return "failed" if os.path.lexists(run.failure_path(out)) else "missing", None


def state(run: Run, out: Path) -> str:
    """``done``, ``damaged``, ``failed`` or ``missing``: where ``run`` stands in the dataset ``out``.

    A run whose summary is there is ``damaged`` if one of its files cannot be used (see
    :func:`damage`: truncated, garbled, other columns, no config): it is not done, and a
    rerun replaces its files (each atomically). It is not done either if its scenario finds
    it outdated (delivery: it starts from a saved fleet written again after the run, see
    :func:`dronefleet.delivery.scenario.outdated`).

    Raises SweepError if the run's summary was made with another config (the sweep file
    changed since): new results would silently mix with old ones.
    """
    return inspect(run, out)[0]


# --------------------------------------------------------------------------- one partition layout per dataset

#: In a dataset folder, the partition keys of its runs and their scenario, written when its first runs start.
LAYOUT_FILE = "_layout.json"
#: In a dataset folder, the summary rows of its done runs (``sweep collect``).
COLLECTED_FILE = "collected.parquet"
#: The metadata key of a collected table that holds its sweep: only such a file is replaced.
SWEEP_KEY = b"dronefleet.sweep"
#: In a dataset folder, the folder of its runs' replay pages (``dronefleet replay DATASET --run ...``).
PAGES_FOLDER = "_replay"
#: Folders dronefleet makes in a dataset beside its tables: failure records, job logs, replay pages.
SIDE_FOLDERS = ("_failed", "_logs", PAGES_FOLDER)


def _found_layout(out: Path, tables: tuple[str, ...]) -> tuple[tuple[str, ...], str | None] | None:
    """The partition keys of the dataset ``out`` and its scenario: from its :data:`LAYOUT_FILE` (the
    scenario None if written before the file held it) or, in a dataset written before that file
    existed, the keys from the partition directories of its ``tables`` (and the scenario None);
    None if it holds none."""
    record = out / LAYOUT_FILE
    if os.path.lexists(record):
        return _read_layout(record, out)
    try:
        for table in tables:
            keys, folder = [], out / table
            while folder.is_dir():  # down the first partition directory of each level
                folder = next((path for path in sorted(folder.iterdir()) if path.is_dir() and "=" in path.name
                               and not path.name.startswith((".", "_"))), None)
                if folder is None:
                    break
                keys.append(folder.name.split("=", 1)[0])
            if keys:
                return tuple(keys), None
    except OSError as error:
        raise SweepError(f"cannot read the partition layout of the dataset {out} ({error.strerror or error})") from None
    return None


def dataset_holding(path: str | os.PathLike) -> Path | None:
    """The sweep dataset a folder ``path`` would lie in (the nearest folder above it holding a
    :data:`LAYOUT_FILE`, or the summary partitions of a dataset written before that file), or
    None: readers take a dataset's folders whole, so a run folder in one adds rows to it."""
    for folder in Path(os.path.abspath(path)).parents:
        if os.path.lexists(folder / LAYOUT_FILE) or _found_layout(folder, ("summary",)) is not None:
            return folder
    return None


def _read_layout(record: Path, out: Path) -> tuple[tuple[str, ...], str | None]:
    """The partition keys and the scenario (None in a record written before it held one) of the
    layout file ``record``: ``{"keys": [names], "scenario": name}``, read as data (a regular file
    of at most :data:`~dronefleet.datafiles.MAX_JSON_BYTES` bytes, nested at most
    :data:`~dronefleet.datafiles.MAX_JSON_DEPTH` deep); SweepError naming it otherwise."""
    fix = f'its {LAYOUT_FILE} holds {{"keys": [...], "scenario": "..."}}: fix or remove it'
    try:
        document = read_json(record, LAYOUT_FILE)
    except DataError as error:
        raise SweepError(f"cannot read the partition layout of the dataset {out}: {error}; {fix}") from None
    keys = document.get("keys") if isinstance(document, dict) else None
    scenario = document.get(SCENARIO_KEY) if isinstance(document, dict) else None
    if not (isinstance(keys, list) and keys and set(document) <= {"keys", SCENARIO_KEY}
            and all(isinstance(key, str) and key.isidentifier() for key in keys)
            and (scenario is None or isinstance(scenario, str))):
        raise SweepError(f"cannot read the partition layout of the dataset {out}: {str(record)!r} is not "
                         f"{{\"keys\": [names of config keys], \"scenario\": name}}; {fix}")
    return tuple(keys), scenario


def _part_scenario(part: Path) -> str:
    """The name of the scenario whose config the summary part ``part`` holds; DataError if it holds none."""
    from .records import read_config_dict

    return read_config_dict(part, "part").get(SCENARIO_KEY, "delivery")


def _found_scenario(out: Path, keys: tuple[str, ...]) -> str | None:
    """The scenario of the dataset ``out`` (partitioned by ``keys``) written before its layout file
    recorded it: that of its first summary part whose config reads; None if it holds no summary
    part. SweepError (one line) if none can be read: a sweep could then replace another scenario's
    runs as damaged ones."""
    unreadable = None
    for part in (out / "summary").glob("/".join(f"{key}=*" for key in keys) + "/part-0.parquet"):
        try:
            return _part_scenario(part)
        except DataError as error:  # a damaged part: another one tells
            unreadable = error
    if unreadable is not None:
        raise SweepError(f"cannot tell the scenario of the dataset {out}, written before {LAYOUT_FILE} recorded it: "
                         f"no summary part holds a readable config ({unreadable}); remove the dataset or use "
                         "another [sweep] name or --results")
    return None


def _check_owned(sweep: Sweep, out: Path) -> None:
    """Refuse a folder ``out`` that is not absent, empty, a dataset (its :data:`LAYOUT_FILE`, or the
    partitions of one written before it: its tables' folders hold nothing else) or a folder of only
    what dronefleet writes there (the script and logs of ``sweep plan``): a sweep would write among
    the user's files and replace them."""
    if not out.is_dir() or os.path.lexists(out / LAYOUT_FILE):
        return
    ours = {*sweep.scenario.tables, LAYOUT_FILE, COLLECTED_FILE, f"{sweep.name}.sbatch", *SIDE_FOLDERS}
    try:
        foreign = sorted(name for name in os.listdir(out) if name not in ours and not name.startswith(PROBE_PREFIX))
    except OSError as error:
        raise SweepError(f"cannot read the folder {out} ({error.strerror or error})") from None
    if foreign and _found_layout(out, sweep.scenario.tables) is None:
        more = f" and {len(foreign) - 1} more" if len(foreign) > 1 else ""
        raise SweepError(f"{out} is not a sweep dataset and holds files dronefleet did not write "
                         f"({_shown(foreign[0], 40)}{more}), which a sweep could replace: give an absent or empty "
                         "folder, or a dataset dronefleet wrote (another --results or [sweep] name, or out=)")
    stray = next(filter(None, (_not_a_part(out / table) for table in sweep.scenario.tables)), None)
    if stray is not None:  # e.g. the user's own summary/ folder: a sweep would write among its files
        raise SweepError(f"{out} is not a sweep dataset: its {_shown(os.path.relpath(stray, out), 80)} is not a "
                         "run's part, and a table's "
                         "folder holds only <key>=<value>/.../part-0.parquet: give an absent or empty folder, or a "
                         "dataset dronefleet wrote (another --results or [sweep] name, or out=)")


#: What a table's folder of a dataset holds: partition folders (``<key>=<value>``), then the
#: runs' parts and the temporary files of their atomic writes (:func:`dronefleet.records.write_atomic`).
_PARTITION_FOLDER = re.compile(r"[A-Za-z_][A-Za-z0-9_]*=.*", re.S)
_PART_FILE = re.compile(r"part-0\.parquet|\.part-0\.parquet\..*\.tmp", re.S)


def _not_a_part(top: Path) -> str | None:
    """The first path in the table's folder ``top`` of a dataset that a dataset does not hold
    there (see :data:`_PARTITION_FOLDER`), or None (also if it is absent, or no folder)."""
    if not top.is_dir():
        return None
    try:
        for root, folders, files in os.walk(top, onerror=_raise):
            for name in folders:
                if not _PARTITION_FOLDER.fullmatch(name):
                    return os.path.join(root, name)
            for name in files:
                if root == str(top) or not _PART_FILE.fullmatch(name):
                    return os.path.join(root, name)
    except OSError as error:
        raise SweepError(f"cannot read the folder {top} ({error.strerror or error})") from None
    return None


def _raise(error: OSError) -> None:
    raise error


def check_layout(sweep: Sweep, out: Path) -> None:
    """Refuse a folder ``out`` that is not the sweep's dataset: a folder of other files (see
    :func:`_check_owned`), a dataset of other partition keys or of another scenario, or one that
    has something else than a folder where a table's files go.

    The grid decides the layout: a sweep of the same name with a grid key moved to [set]
    would write a second layout beside the first, and readers of the folder would then see
    runs twice (DuckDB refuses it: "Hive partition mismatch"). Two scenarios may share a layout
    (items and replenishment, both ``trials/first_trial``): a sweep of one would take the runs of
    the other for damaged ones and replace them.
    """
    _check_owned(sweep, out)
    for table in sweep.scenario.tables:  # every run of the table would fail at it: said once, before any
        folder = out / table
        if os.path.lexists(folder) and not folder.is_dir():
            raise SweepError(f"the dataset {out} is damaged: {str(folder)!r}, the folder of its {table} files, "
                             "is not a folder: move or remove it")
    keys = sweep.runs[0].keys
    found = _found_layout(out, sweep.scenario.tables)
    if found is None:
        return
    if found[0] != keys:
        raise SweepError(f"{out} holds a dataset partitioned by {'/'.join(found[0])}; this sweep partitions by "
                         f"{'/'.join(keys)}: use another [sweep] name or --results")
    scenario = found[1] or _found_scenario(out, keys)
    if scenario is not None and scenario != sweep.scenario.name:
        raise SweepError(f"{out} holds a dataset of the {_shown(scenario, 40)} scenario; this sweep is of "
                         f"{sweep.scenario.name}: use another [sweep] name or --results")


def check_collected(out: Path) -> None:
    """Refuse (OutputError, one line) a :data:`COLLECTED_FILE` in the dataset ``out`` that ``collect``
    must not replace: a folder, a special file, or a file that it did not write (without :data:`SWEEP_KEY`)."""
    def collected(path: Path) -> bool:
        try:
            return SWEEP_KEY in (parquet_schema(path).metadata or {})
        except DataError:
            return False

    check_output_file(out / COLLECTED_FILE, "the summary table", "give the sweep another folder (another --results "
                      "or [sweep] name, or out=)", replaceable=collected,
                      kind="a summary table that dronefleet sweep collect wrote")


def _record_layout(sweep: Sweep, out: Path) -> None:
    """Write ``out``/:data:`LAYOUT_FILE` (atomically) if it is not there yet or does not name the
    scenario (:func:`check_layout` found it from the parts)."""
    from .records import write_atomic

    record = out / LAYOUT_FILE
    if not record.exists() or _read_layout(record, out)[1] is None:
        text = json.dumps({"keys": list(sweep.runs[0].keys), SCENARIO_KEY: sweep.scenario.name}) + "\n"
        write_atomic(record, lambda tmp: tmp.write_text(text, encoding="utf-8"))


def _probe(folders, allowed: str, keep: bool = True) -> None:
    """Refuse, before any run, folders that cannot be made or written (a file in the way, read-only),
    leaving none made; ``allowed`` says what the flags must be. Without ``keep``, the folders
    made to probe are removed again (a refusal that comes later then leaves nothing either)."""
    made = [path for folder in folders for path in (folder, *folder.parents) if not path.exists()]  # deepest first
    try:
        probe_folders(folders)
    except OutputError as error:
        raise SweepError(f"{error}: {allowed}") from None
    for path in [] if keep else made:
        with suppress(OSError):
            path.rmdir()


# --------------------------------------------------------------------------- running a sweep


def _shown(value: str, limit: int = 80) -> str:
    """``value`` as a message shows it: repr (one line, control characters escaped), cut to ``limit``."""
    return repr(value) if len(value) <= limit else f"{value[:limit]!r}... ({len(value)} characters)"


def check_scheduler(address: str) -> str:
    """``address`` if it is a Dask scheduler address ``[protocol://]host:port``; SweepError otherwise.

    Checked before anything runs: Dask's own parser fails with a traceback, or only after a
    connection attempt.
    """
    match = _SCHEDULER.fullmatch(address)
    if match is None or len(match["host"]) > 253 or not 1 <= int(match["port"]) <= 65535:
        raise SweepError(f"--scheduler {_shown(address)} is not a Dask scheduler address: expected "
                         "[protocol://]host:port, protocol tcp (the default), tls, ucx, ws or wss, host a name "
                         "(at most 253 characters) or an IP address, port 1-65535 (e.g. tcp://10.0.0.1:8786)")
    return address


#: Values a scheduler sets outside job arrays: the variable then gives no task.
#: (SGE sets ``SGE_TASK_ID=undefined`` in a job that is not an array, LSF ``LSB_JOBINDEX=0``.)
_NOT_AN_ARRAY = {"SGE_TASK_ID": "undefined", "LSB_JOBINDEX": "0"}


def task_from_environment(environ: Mapping[str, str] = os.environ, n_tasks: int | None = None) -> int | None:
    """The 0-based job-array task given by the scheduler's variables (:data:`TASK_VARIABLES`), if any.

    Every variable that is set is checked, and all that give a task must give the same one.
    A variable that is unset or holds its scheduler's "not an array" value
    (``SGE_TASK_ID=undefined``, ``LSB_JOBINDEX=0``) gives none. Any other value must be ASCII
    digits naming one of the ``n_tasks`` tasks (``0..n_tasks - 1``, or ``1..n_tasks`` for SGE
    and LSF, whose arrays start at 1).

    Raises
    ------
    SweepError
        A value that is not such an index (``abc``, ``-1``, ``²``, beyond the array, or empty:
        a job script whose variable lost its value), or two variables that give different
        tasks: running the whole sweep, or the wrong task, in its place would be silently wrong.
    """
    tasks = {}   # variable -> the 0-based task it gives
    for variable, first in TASK_VARIABLES:
        value = environ.get(variable)
        if value is None or value == _NOT_AN_ARRAY.get(variable):
            continue
        last = None if n_tasks is None else first + n_tasks - 1
        allowed = f"an integer {first}-{last}" if last is not None else f"an integer >= {first}"
        if value == "":
            raise SweepError(f"{variable} is set but empty: expected {allowed}"
                             + (f" ({n_tasks} tasks)" if n_tasks is not None else "")
                             + f", or {variable} unset outside job arrays", [variable])
        # isdigit() alone takes '²' and other Unicode digits, which int() refuses; 19 digits and
        # more are beyond any array (and int() refuses thousands of them)
        index = int(value) if value.isascii() and value.isdigit() and len(value) < 19 else -1
        if index < first or (last is not None and index > last):
            raise SweepError(f"{variable}={_shown(value, 40)} is not a job-array task of this sweep: expected {allowed}"
                             + (f" ({n_tasks} tasks)" if n_tasks is not None else ""), [variable])
        tasks[variable] = index - first
    if len(set(tasks.values())) > 1:
        shown = " and ".join(f"{variable}={environ[variable]!r} (task {task})" for variable, task in tasks.items())
        raise SweepError(f"{shown} give different job-array tasks: set only one scheduler's variable", list(tasks))
    return next(iter(tasks.values()), None)


def available_cpus() -> int:
    """CPUs this process may run on: a batch job's allocation, not the whole node."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # macOS, Windows
        return os.cpu_count() or 1


class Progress:
    """``run_sweep``'s ``progress``: what its finished runs hold (lunar runs, items or replenishment
    trials: a sweep of 3 configurations of 50 lunar runs counts to 150, not to 3) as a tqdm bar with
    the failed runs counted, drawn as :func:`dronefleet.console.progress` says (on a terminal,
    without ``-q``). ``noun`` names what is counted (:attr:`Scenario.replicate_noun`)."""

    def __init__(self, noun: str = "run") -> None:
        self.noun = noun
        self.bar = None  # made at the first call, which tells the number of runs

    def __call__(self, finished: float, total: float, failed: int) -> None:
        if self.bar is None:
            self.bar = console.progress(total, self.noun, f"  {self.noun}s")
        self.bar.set_postfix_str(f"{console.counted(failed, 'sweep run')} failed", refresh=False)
        self.bar.update(finished - self.bar.n)
        if finished == total:
            self.bar.close()


def _duration(seconds: float) -> str:
    minutes, rest = divmod(seconds, 60.0)
    return f"{int(minutes)} min {rest:04.1f} s" if minutes else f"{rest:.1f} s"


def run_sweep(sweep: Sweep, out: Path, runs: Sequence[Run], jobs: int = 1, scheduler: str | None = None,
              progress: Callable[[int, int, int], object] | None = None) -> tuple[int, dict[Run, str]]:
    """Execute those of ``runs`` (of ``sweep``) that are not done, into the dataset ``out``.

    Locally on ``jobs`` processes, or, with ``scheduler`` (a Dask scheduler address), one
    Dask task per run (the workers write the files: ``out`` must be on a filesystem they
    share). ``progress(finished, to_run, failed)`` is called after every run, the first two counted
in what the runs hold (:meth:`Scenario.replicates`; a run of none counts 1). Returns the
    number of runs executed and the failed ones with their errors.

    A run whose worker process dies (killed, out of memory, segfault) or that the executor
    otherwise loses is failed like a run that raises: recorded in ``_failed/<run id>.json``,
    while the other runs go on (see :mod:`dronefleet.executors`).
    """
    from functools import partial

    from . import executors

    check_layout(sweep, out)
    todo = []
    for run in runs:
        _check_part_files(run, out)
        found, problem = inspect(run, out)
        if found == "damaged":
            _report(f"{problem}: running {run.partition} again")
        if found != "done":
            todo.append(run)
    out = out.absolute()  # workers may have another working directory
    function = partial(execute, out=out)
    if scheduler is None:
        results = executors.local(function, todo, jobs)
    else:  # connects here: an unreachable scheduler is refused before anything is written
        results = executors.dask(function, todo, scheduler, keys=[f"{sweep.name}/{run.id}" for run in todo])
    with writing(out / LAYOUT_FILE):
        out.mkdir(parents=True, exist_ok=True)
        _record_layout(sweep, out)  # before the first run writes: one layout per dataset from now on
        if sweep.design is not None:
            designs.write_samples(sweep.design, out)
    failures = {}
    # what each run holds (its trials or lunar runs; 1 for a delivery run): the progress counts those
    held = {run: len(run.scenario.replicates(run.config) or range(1)) for run in todo}
    total, finished = sum(held.values()), 0
    for run, error, crash in results:
        if crash is not None:
            # one line: loky's message names the worker's exit code on a line of its own
            error = _record_failure(run, out, f"its worker died (killed, out of memory or crashed) while running it: "
                                              f"{type(crash).__name__}: {one_line(crash)}",
                                    "".join(traceback.format_exception(crash)))
        if error is not None:
            failures[run] = error
        log.debug(f"  run {run.partition}: {'done' if error is None else f'failed: {error}'}")
        finished += held[run]
        if progress is not None:
            progress(finished, total, len(failures))
    return len(todo), failures


# --------------------------------------------------------------------------- job arrays, the summary table


def _ranges(numbers) -> str:
    """Sorted integers as job-array ranges: [0, 1, 2, 5, 7, 8] -> '0-2,5,7-8'."""
    groups = itertools.groupby(enumerate(numbers), key=lambda pair: pair[1] - pair[0])
    spans = [[n for _, n in group] for _, group in groups]
    return ",".join(str(s[0]) if len(s) == 1 else f"{s[0]}-{s[-1]}" for s in spans)


#: A job script's header: ``sweep plan`` replaces an existing file at its ``--out`` only if it starts so.
SCRIPT_HEAD = "#!/bin/bash\n# Job array of the dronefleet sweep "
#: What bash, sbatch or a terminal could take for anything but a character of a value: control
#: characters (C0, DEL, C1: newline, CR, NUL, ESC, ...) and the lone surrogates that stand for
#: bytes that are not UTF-8.
_CONTROL = re.compile(r"[\x00-\x1f\x7f-\x9f\ud800-\udfff]")
#: SLURM's time limits: minutes, minutes:seconds, hours:minutes:seconds, days-hours,
#: days-hours:minutes, days-hours:minutes:seconds; or no limit.
_SLURM_TIME = re.compile(r"(?:[0-9]{1,9}-)?[0-9]{1,9}(?::[0-9]{1,9}){0,2}|(?i:unlimited|infinite)")
#: A SLURM partition or account name (``--partition`` takes several, comma-separated).
_SLURM_NAME = r"[A-Za-z0-9_][A-Za-z0-9_.-]{0,127}"
_SLURM_FORMATS = {"time": (_SLURM_TIME, "a SLURM time limit: minutes, MM:SS, HH:MM:SS, D-HH, D-HH:MM or "
                                        "D-HH:MM:SS (e.g. 00:30:00), or UNLIMITED"),
                  "partition": (re.compile(rf"{_SLURM_NAME}(?:,{_SLURM_NAME})*"),
                                "partition names (letters, digits, '_', '.', '-'; at most 128 each), comma-separated"),
                  "account": (re.compile(_SLURM_NAME), "an account name (letters, digits, '_', '.', '-'; at most 128)"),
                  "mem": (re.compile(r"[1-9][0-9]{0,8}[KMGT]?"), "a SLURM memory size: a whole number with a unit "
                                                                 "K, M (the default), G or T, e.g. 4G")}
#: ``#SBATCH --mem`` of a task when ``sweep plan --mem`` is not given: a task runs its runs one after
#: another, each bounded in size by its scenario's run limits (a few hundred MB at most), in a
#: Python with numpy, pyarrow and numba loaded (~0.5 GB).
DEFAULT_MEM = "2G"


def _script_value(value: str | os.PathLike, what: str, sbatch: bool = False) -> str:
    """``value`` as text for a job script, refused (SweepError) if it holds a control character
    (a newline would start a command of its own) or a byte that is not UTF-8; with ``sbatch``
    (an ``#SBATCH`` line), also a backslash, which sbatch's parser takes as an escape even
    inside quotes."""
    text = os.fspath(value)
    bad = _CONTROL.search(text) or (re.search(r"\\", text) if sbatch else None)
    if bad:
        kind = ("a backslash (an escape to sbatch)" if bad[0] == "\\" else "a byte that is not UTF-8"
                if "\ud800" <= bad[0] <= "\udfff" else f"the control character {bad[0]!r}")
        raise SweepError(f"{what} {_shown(text)} holds {kind}, which a job script cannot carry safely: "
                         "rename it, or give another")
    return text


def job_script(sweep: Sweep, results: Path, time_limit: str | None = None, partition: str | None = None,
               account: str | None = None, mem: str = DEFAULT_MEM) -> str:
    """A SLURM job-array script running every task of ``sweep`` into ``results``/<name>.

    Paths are absolute and the python is this one (``sys.executable``), so the script works
    from any directory; it changes to the current directory, against which config paths
    (``run.fleet_file``) are resolved.

    Every value is quoted (``shlex.quote``: bash and sbatch take it as one literal word), and
    refused (SweepError) before anything is written if it holds a control character or a byte
    that is not UTF-8; ``time_limit``, ``partition``, ``account`` and ``mem`` (per task) must have
    SLURM's formats (see :data:`_SLURM_FORMATS`). Without ``time_limit`` the script says that the
    partition's default time limit applies, in a comment beside the ``#SBATCH`` lines.
    """
    for flag, value in (("time", time_limit), ("partition", partition), ("account", account), ("mem", mem)):
        pattern, allowed = _SLURM_FORMATS[flag]
        if value is not None and not pattern.fullmatch(value):
            raise SweepError(f"--{flag} {_shown(value)} is not {allowed}")
    results = Path(_script_value(results.absolute(), "--results", sbatch=True))
    out = results / sweep.name
    here = _script_value(Path.cwd(), "the working directory")
    words = [_script_value(sys.executable, "the python"), "-m", "dronefleet.cli", "sweep", "run",
             _script_value(sweep.path, "the sweep file"), "--results", str(results)]
    # in --output, % starts SLURM's file name patterns (%A job, %a task): the folder's own is %%
    logs = str(out / "_logs").replace("%", "%%") + "/%A_%a.out"
    options = [f"--job-name=dronefleet-{sweep.name}", f"--array=0-{sweep.n_tasks - 1}", "--cpus-per-task=1",
               f"--mem={mem}", f"--output={shlex.quote(logs)}"]
    options += [f"--{flag}={shlex.quote(value)}" for flag, value in
                (("time", time_limit), ("partition", partition), ("account", account)) if value]
    untimed = [] if time_limit else ["# No --time: the partition's default time limit applies to each task; "
                                     "set one with dronefleet sweep plan --time HH:MM:SS."]
    cache = shlex.quote(str(results / "_numba_cache"))
    return "\n".join([
        f"{SCRIPT_HEAD}{sweep.name} ({shlex.quote(str(sweep.path))}):",
        f"# {sweep.describe()}, {sweep.n_tasks} tasks of up to {sweep.runs_per_task} runs.",
        "# Written by `dronefleet sweep plan`; submit it with `sbatch` (on its own, or with --array=<tasks>",
        "# to rerun some): a task skips its runs that are done and redoes the others.",
        *untimed,
        *(f"#SBATCH {option}" for option in options),
        "set -euo pipefail",
        f"cd {shlex.quote(here)}",
        "# numba caches the compiled engine beside the installed package (or under ~/.cache if that",
        "# is read-only). On a cluster both may be unwritable or not shared, and then every task",
        "# compiles the engine again (~20 s). This cache, on the shared results filesystem, is",
        "# filled by the first tasks and loaded by the others (unless NUMBA_CACHE_DIR is set).",
        f"if [ -z \"${{NUMBA_CACHE_DIR:-}}\" ]; then NUMBA_CACHE_DIR={cache}; fi",
        "export NUMBA_CACHE_DIR",
        f"exec {' '.join(shlex.quote(word) for word in words)} --task-id \"$SLURM_ARRAY_TASK_ID\"",
        "",
    ])


def done_runs(sweep: Sweep, out: Path) -> list[Run]:
    """The runs of ``sweep`` that are done in ``out``, in run order; SweepError if none is.
    A damaged run is left out, saying so in one line (``sweep run`` redoes it)."""
    done = []
    for run in sweep.runs:
        found, problem = inspect(run, out)
        if found == "damaged":
            _report(f"{problem}: run {run.partition} is left out (dronefleet sweep run redoes it)")
        if found == "done":
            done.append(run)
    if not done:
        raise SweepError(f"no run of sweep {sweep.name} is done in {out}")
    return done


def dataset_parts(out: Path) -> tuple[tuple[str, ...], list[tuple[dict[str, str], Path]]]:
    """The partition keys of the dataset folder ``out`` (a sweep's output: no sweep file needed)
    and, for every run whose summary is there, its values as its path spells them (``{"rule":
    "random", "seed": "3"}``, decoded) and its summary part; in path order, at most
    :data:`MAX_RUNS`. Nothing is read but the folders: a damaged run elsewhere does not matter
    (:func:`dataset_run` reads the one chosen).

    SweepError (one line) if ``out`` holds no dataset, or more runs than a sweep may hold.
    """
    found = _found_layout(out, ("summary",)) if out.is_dir() else None
    if found is None:
        raise SweepError(f"{out} holds no sweep dataset: no {LAYOUT_FILE} and no summary/<key>=<value>/... "
                         "folders (give the folder dronefleet sweep run wrote, <results>/<sweep name>)")
    keys = found[0]
    pattern = "/".join(f"{key}=*" for key in keys) + "/part-0.parquet"
    parts = []
    for part in sorted((out / "summary").glob(pattern)):
        if len(parts) == MAX_RUNS:
            raise SweepError(f"{out} holds more than {MAX_RUNS:,} runs; a sweep holds at most {MAX_RUNS:,}")
        folders = part.relative_to(out / "summary").parts[:-1]
        parts.append(({key: unquote(folder.split("=", 1)[1]) for key, folder in zip(keys, folders)}, part))
    return keys, parts


def dataset_run(out: Path, keys: tuple[str, ...], part: Path) -> Run:
    """The run whose summary part in the dataset ``out`` (partitioned by ``keys``) is ``part``,
    from the config the part holds; DataError naming the part if it cannot be read, holds no
    valid config, or that of another run than the folder it lies in (moved, tampered with)."""
    scenario = scenarios.get(_part_scenario(part), f"part {str(part)!r}: ")
    run = Run(scenario.read_config(part), keys, scenario)
    if run.path(out, "summary") != part:
        raise DataError(f"part {str(part)!r} holds the config of run {run.partition}, not of the folder it "
                        "lies in: a part moved or tampered with")
    return run


def _partition_schema(sweep: Sweep):
    """The partition keys of ``sweep`` as a pyarrow schema, each with its config type."""
    import pyarrow as pa

    # bool: a switch such as lunar's los_bodies is a grid key like any other (partition "los_bodies=True")
    types = {float: pa.float64(), int: pa.int64(), str: pa.string(), bool: pa.bool_()}
    scenario = sweep.scenario
    return pa.schema([(key, types[type(scenario.defaults[config_key(scenario, key)])]) for key in sweep.runs[0].keys])


def collect(sweep: Sweep, out: Path) -> tuple[pyarrow.Table, list[Run]]:
    """The summary rows of every done run, in run order: its partition values (grid keys, seed
    key), then its summary (delivery: one row per run; replenishment: one row per trial).
    Damaged runs (see :func:`damage`) are left out like runs not done, each said in one line.

    Written atomically to ``out/collected.parquet``, with the sweep file in the metadata
    (key ``dronefleet.sweep``). Returns ``(table, the runs not done)``. A path there that is
    not a regular file, a file that collect did not write (the user's: :func:`check_collected`),
    or a write that fails (disk full), is an OutputError (one line).
    """
    import pyarrow as pa
    import pyarrow.parquet as pq

    from .provenance import stamp
    from .records import write_atomic

    done = done_runs(sweep, out)
    path = out / COLLECTED_FILE
    check_collected(out)
    schema = _partition_schema(sweep)
    columns = _part_columns(sweep.runs[0], "summary", sweep.scenario.table_schemas())
    rows = []
    for run in done:
        summary = read_parquet(run.path(out, "summary"), columns, "part", exact=True)
        partition = {key: pa.array([run.value(key)] * summary.num_rows, schema.field(key).type) for key in run.keys}
        rows.append(pa.table({**partition, **dict(zip(summary.column_names, summary.columns))}))
    table = stamp(pa.concat_tables(rows).replace_schema_metadata({SWEEP_KEY: sweep.text}))
    with writing(path):
        write_atomic(path, lambda tmp: pq.write_table(table, tmp))
    finished = set(done)
    return table, [run for run in sweep.runs if run not in finished]


def dataset(sweep: Sweep, out: str | os.PathLike, table: str,
            done: Sequence[Run] | None = None) -> pyarrow.dataset.Dataset:
    """``table`` of the sweep's done runs, in the dataset directory ``out`` (``results/<name>``),
    as one ``pyarrow.dataset.Dataset`` whose partition columns have the config's types.

    Only the files of the runs that the sweep file gives and that are done (see
    :func:`state`; a damaged run is left out, said in one line) are read, in run order:
    ``out/table`` may also hold partitions of runs the file no longer has (it was cut to fewer
    seeds, say) and tables of runs killed before their summary, which must not enter a figure.
    Raises SweepError if no run is done.

    (Read without a schema, hive partition values come back as strings or int32:
    ``tau_minutes=15.0`` as the string ``"15.0"``.) :func:`rows` reads it, naming a file
    damaged inside. ``done``: the sweep's done runs (:func:`done_runs`) if the caller found them
    already, so that several tables of one sweep inspect its runs' files once, not once per table.
    """
    import pyarrow.dataset as ds

    out = Path(out)
    done = done_runs(sweep, out) if done is None else done
    return ds.dataset([str(run.path(out, table)) for run in done], format="parquet",
                      partitioning=ds.partitioning(_partition_schema(sweep), flavor="hive"),
                      partition_base_dir=str(out / table))


def rows(sweep: Sweep, out: str | os.PathLike, table: str, data: pyarrow.dataset.Dataset,
         filter: pyarrow.compute.Expression | None = None) -> pyarrow.Table:
    """``data.to_table(filter=filter)``, ``data`` being :func:`dataset` of ``table``.

    A file whose footer reads but a page inside does not (garbled where :func:`damage` does
    not look) is a DataError naming it, found by reading each file whole: remove it, and
    ``sweep run`` redoes its run.
    """
    import pyarrow as pa

    try:
        return data.to_table(filter=filter)
    except (pa.ArrowException, OSError) as error:  # ArrowInvalid, ArrowIOError: a page that does not decode
        out, schemas, files = Path(out), sweep.scenario.table_schemas(), set(data.files)
        for run in sweep.runs:
            if (path := str(run.path(out, table))) not in files:
                continue
            try:
                read_parquet(path, _part_columns(run, table, schemas), "part", exact=True)
            except DataError as damaged:
                raise DataError(f"{damaged}: remove it, and dronefleet sweep run redoes its run {run.partition}") \
                    from None
        first = (str(error).splitlines() or [type(error).__name__])[0][:200]
        raise DataError(f"the {table} files of sweep {sweep.name} in {out} cannot be read ({first})") from None


# --------------------------------------------------------------------------- the commands (see cli.py)


def _open(args) -> tuple[Sweep, Path]:
    sweep = load_sweep(named_file(args.sweep, "sweep"))  # a path, or a shipped sweep file's name
    out = Path(args.results) / sweep.name
    check_layout(sweep, out)
    return sweep, out


def _is_job_script(path: Path) -> bool:
    """Whether the regular file ``path`` starts as the scripts of ``sweep plan`` do (:data:`SCRIPT_HEAD`)."""
    head = SCRIPT_HEAD.encode()
    try:
        # O_NONBLOCK: a file swapped for a pipe since it was found regular does not block the open
        with os.fdopen(os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0)), "rb") as fh:
            return fh.read(len(head)) == head
    except OSError:
        return False


def plan_command(args: argparse.Namespace) -> int:
    """``dronefleet sweep plan``: print the runs and tasks, write the job-array script.

    The script is built (refusing unsafe values) and its path checked before anything is
    made: ``--out`` may not replace a folder, a special file, a file other than an earlier
    job-array script, nor any file of the dataset but its own ``<name>.sbatch``. It is written
    atomically: a failed write leaves nothing.
    """
    from .records import write_atomic

    sweep, out = _open(args)
    own = out / f"{sweep.name}.sbatch"
    script = Path(_script_value(args.out, "--out")) if args.out else own
    text = job_script(sweep, Path(args.results), args.time, args.partition, args.account, args.mem)
    if Path(os.path.abspath(script)).is_relative_to(os.path.abspath(out)) and \
            os.path.abspath(script) != os.path.abspath(own):
        raise SweepError(f"--out {str(script)!r} lies inside the dataset {str(out)!r}, whose files it would "
                         f"replace: give {str(own)!r} (the default) or a file outside it")
    check_output_file(script, "--out", "give the path of the job-array script file",
                      replaceable=_is_job_script, kind="a job-array script that dronefleet sweep plan wrote")
    # SLURM does not create the log directory; on refusal, nothing is left made
    _probe([script.parent, out / "_logs"], "--out must be a file in a writable folder, --results a writable folder")
    with writing(script):
        write_atomic(script, lambda tmp: tmp.write_text(text, encoding="utf-8"))
    print(f"sweep {sweep.name}: {sweep.describe()}, {sweep.n_tasks} tasks of up to {sweep.runs_per_task} runs")
    print(f"  job-array script  {script} (per task: 1 CPU, {args.mem} memory, "
          f"{f'time limit {args.time}' if args.time else 'the partition default time limit'})")
    print(f"  submit it with    sbatch {shlex.quote(str(script))}")
    return 0


def run_command(args: argparse.Namespace) -> int:
    """``dronefleet sweep run``: one task's runs, or all of them (local processes or Dask)."""
    sweep, out = _open(args)
    task = args.task_id if args.task_id is not None else task_from_environment(n_tasks=sweep.n_tasks)
    if args.scheduler is not None and args.executor != "dask":
        raise SweepError("--scheduler is the address of a Dask scheduler: use it with --executor dask")
    if args.executor == "dask" and (args.scheduler is None or task is not None):
        raise SweepError("--executor dask runs every run of the sweep on the cluster at --scheduler ADDRESS "
                         "(e.g. tcp://10.0.0.1:8786), without a task id")
    if args.scheduler is not None:
        check_scheduler(args.scheduler)
    runs = sweep.runs if task is None else sweep.task(task)
    _probe([out], "--results must be a folder where files can be written", keep=False)
    jobs = args.jobs or (1 if task is not None else available_cpus())
    where = (f"on the Dask cluster at {args.scheduler}" if args.executor == "dask"
             else f"on {jobs} process{'es' if jobs > 1 else ''}")
    log.info(f"sweep {sweep.name}: {sweep.describe()}; "
             f"{'all runs' if task is None else f'task {task}: {len(runs)} runs'} {where}")
    log.debug(f"  sweep file {sweep.path}")
    start = time.perf_counter()
    try:
        with console.compile_notice(f"the {sweep.scenario.name} kernel"):  # with --jobs 1 its runs run here
            ran, failures = run_sweep(sweep, out, runs, jobs, args.scheduler, Progress(sweep.scenario.replicate_noun))
    except KeyboardInterrupt:
        log.warning(f"sweep {sweep.name}: interrupted; the runs done are kept: the same command goes on")
        return 130  # the shell's code for a command stopped by Ctrl-C
    wall = time.perf_counter() - start
    log.info(f"sweep {sweep.name}: ran {ran}, skipped {len(runs) - ran} done before, {len(failures)} failed, "
             f"in {_duration(wall)}; dataset {out}")
    for run, error in failures.items():
        log.warning(f"  failed  {run.partition}: {error}")
    return 1 if failures else 0


def _recorded_error(path: Path) -> str:
    """The first line of the error a ``_failed/`` record holds, or why the record cannot be read:
    a damaged record (not a regular file, too large, not ``{"error": "...", ...}``) does not stop
    status, and the run is not done either way (``sweep run`` redoes it, replacing the record)."""
    try:
        record = read_json(path, "record")
    except DataError as error:
        return f"(the record {path.name} cannot be read: {error})"
    error = record.get("error") if isinstance(record, dict) else None
    if not isinstance(error, str):
        return f"(the record {path.name} cannot be read: it holds no \"error\" text)"
    return _first_line(error)


def status_command(args: argparse.Namespace) -> int:
    """``dronefleet sweep status``: done, missing, failed (with their errors) and damaged runs
    (with the file at fault)."""
    sweep, out = _open(args)
    inspected = [inspect(run, out) for run in sweep.runs]
    found = [s for s, _ in inspected]
    print(f"sweep {sweep.name}: {sweep.describe()} in {out}: " +
          ", ".join(f"{found.count(s)} {s}" for s in ("done", "missing", "failed", "damaged")))
    for run, (s, problem) in zip(sweep.runs, inspected):
        if s == "failed":
            print(f"  failed   {run.partition}: {_recorded_error(run.failure_path(out))}")
        elif s == "damaged":
            print(f"  damaged  {run.partition}: {problem} (sweep run redoes it)")
    unfinished = sorted({i // sweep.runs_per_task for i, s in enumerate(found) if s != "done"})
    if unfinished:
        print(f"  tasks with runs not done: {_ranges(unfinished)} (rerun them: sweep run --task-id N, "
              f"or sbatch --array={_ranges(unfinished)} on the plan's script)")
    return 0 if not unfinished else 1


def collect_command(args: argparse.Namespace) -> int:
    """``dronefleet sweep collect``: the summary rows of the done runs, as parquet."""
    sweep, out = _open(args)
    table, not_done = collect(sweep, out)
    print(f"sweep {sweep.name}: {len(sweep.runs) - len(not_done)} of {len(sweep.runs)} runs in "
          f"{out / COLLECTED_FILE} ({table.num_rows} rows, {table.num_columns} columns)")
    if not_done:
        log.warning(f"  {len(not_done)} runs are not done (see sweep status); they have no row")
    return 1 if not_done else 0
