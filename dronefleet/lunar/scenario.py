"""The lunar foraging-with-recharging scenario behind the :mod:`dronefleet.scenarios` contract (issue 22).

Config files are TOML naming the scenario and grouping keys in seven sections (run, world,
robots, guidance, energy, records, options; ``configs/lunar.toml`` spells out and documents
every key)::

    scenario = "lunar"
    [run]
    runs = 50
    [world]
    layout = "HARD-RT"
    [energy]
    battery_wh = 7.5

:data:`KEYS` declares each key's section, unit, kind, range and meaning (the spec's A-number for
the options of its section 17); the defaults are :class:`dronefleet.lunar.params.LunarParams`'s
fields (one source). Types are strict as for the other scenarios (``bool`` is not an ``int`` and
``"true"`` is not a ``bool``, ``7.0`` is not an ``int``, an ``int`` is taken for a float); every
value, every rule between values and the size of the run (:data:`RUN_LIMITS`) are checked here,
once, when a config is built (:func:`load`, :func:`replace`, :func:`config_from_dict`): the
kernel never re-checks. ``--set key=value`` takes ``section.key`` or the bare key; ``--seed`` sets
``run.seed``.

A run holds all its runs ``first_run .. first_run + runs - 1`` (one kernel call); in a sweep its
seed key is ``first_run`` (blocks of ``runs`` runs). Run j of every layout and capacity draws the
same per-robot streams (spec section 13: common random numbers).

Tables (:func:`simulate`, columns in :func:`table_schemas`): ``summary`` (one row per run),
``timeseries`` (one row per run and update interval), ``trips`` (one row per trip record) and
``snapshots`` (network snapshots), as docs/guide/lunar.md lists them. Each carries the config in
its metadata.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, fields
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..config import SCENARIO_KEY, ConfigError, Sections, _show, _suggest, with_sources
from ..console import counted
from ..contract import Field
from .layout import build
from .params import LAYOUTS, OPTIONS, LunarParams

if TYPE_CHECKING:
    import pyarrow

__all__ = ["NAME", "KEYS", "SCHEMA", "DEFAULTS", "TABLES", "FIGURES", "SEED_KEY", "SEEDS_REQUIRED", "RUN_LIMITS",
           "Config", "load", "resolve_key", "replace", "value", "replicates", "config_from_dict", "read_config",
           "run_size", "table_schemas", "simulate", "format_summary", "describe", "label", "replay_data",
           "check_replayable", "study"]

NAME = "lunar"
TABLES = ("summary", "timeseries", "trips", "snapshots")
#: The study's figures in ``dronefleet reproduce`` (:mod:`dronefleet.lunar.study`).
FIGURES: tuple[str, ...] = (*(f"lunar-fig{k:02d}" for k in (3, 4, 5, 6, 7, 8, 9, 11)), "lunar-control")
SEED_KEY = "first_run"
SEEDS_REQUIRED = False

#: Largest root seed and largest run index (run j's streams are drawn from (seed, j, robot)).
MAX_SEED, MAX_RUN = 2**31 - 1, 10**9


@dataclass(frozen=True)
class Key:
    """One key: section, unit, kind (``int``, ``float``, ``bool`` or the tuple of allowed words),
    range [low, high] (numbers only), meaning (with the spec's A-number where it is an option)."""

    section: str
    unit: str
    kind: Any
    low: float | None
    high: float | None
    doc: str


def _word(section: str, doc: str, name: str) -> Key:
    return Key(section, "-", OPTIONS[name], None, None, doc)


KEYS: dict[str, Key] = {
    # run
    "runs": Key("run", "runs", int, 1, 10_000, "runs of the configuration, all in one kernel call"),
    "first_run": Key("run", "index", int, 0, MAX_RUN, "index j of the first run (run j: the same streams in "
                     "every layout and capacity)"),
    "seed": Key("run", "-", int, 0, MAX_SEED, "root seed of the experiment (section 13)"),
    "duration_s": Key("run", "s", float, 1.0, 86_400.0, "T_run, run length (A10); K = floor(T_run / tau) ticks"),
    "tau": Key("run", "s", float, 0.001, 1.0, "control step, one tick"),
    # world
    "layout": Key("world", "-", LAYOUTS, None, None, "scenario: no obstacle, or a hard or soft obstacle between "
                  "R-T, N-T or N-R (section 2)"),
    "layout_scale": Key("world", "-", float, 0.5, 2.0, "scale of field, region centres and obstacle corners about "
                        "the origin (A5; 1.0 = the earlier 16.8 x 14.4 m draft)"),
    "kappa_soft": Key("world", "-", float, 1.0, 100.0, "locomotion power multiplier inside the soft obstacle (A7)"),
    # robots
    "n_robots": Key("robots", "robots", int, 1, 500, "N_a"),
    "v0": Key("robots", "m/s", float, 0.001, 20.0, "ground speed (A1); v0 * tau at most r_body"),
    "r_body": Key("robots", "m", float, 0.01, 1.0, "robot disc radius (A29)"),
    "ir_range": Key("robots", "m", float, 0.0, 5.0, "d_IR, reach of the 7 IR rays beyond the body (7.4)"),
    "blocked_ticks": Key("robots", "ticks", int, 1, 100_000, "consecutive blocked ticks before a random turn (7.5)"),
    "comm_radius": Key("robots", "m", float, 0.1, 20.0, "delta_comm, communication radius (strict <)"),
    "r_max": Key("robots", "units", int, 1, 1_000_000, "resource units loaded per visit to T (A11)"),
    # guidance
    "update_interval_s": Key("guidance", "s", float, 0.001, 3600.0, "T, heading-decision and beacon-window "
                             "interval; n_T = floor(T / tau) ticks, at least 1 (A2)"),
    "rho_w": Key("guidance", "-", float, 0.0, 1.0, "potential-weight evaporation rate per window (Eq 5-11)"),
    "rho_v": Key("guidance", "-", float, 0.0, 1.0, "guidance-vector update weight (Eq 5-12)"),
    "rho_p": Key("guidance", "-", float, 0.0, 1.0, "SOC-cost learning weight (Eq 5-13)"),
    "rho_f": Key("guidance", "-", float, 0.0, 10.0, "exponent of omega in the guidance weight (Eq 5-14, A12)"),
    "rho_c": Key("guidance", "-", float, 0.0, 10.0, "exponent of (1 - SOC_b) in the guidance weight (Eq 5-14, A12)"),
    "eta_w": Key("guidance", "-", float, 0.0, 100.0, "beacon decay threshold on the summed potential weights"),
    "phi_soc": Key("guidance", "-", float, 0.0, 10.0, "phi_SOC, safety factor on the learned SOC cost"),
    "eps": Key("guidance", "probability", float, 0.0, 1.0, "exploration probability per heading decision "
               "(1: no guidance, the control of section 14)"),
    "reward": Key("guidance", "-", float, 0.0, 1000.0, "r, reward for being inside the region just completed"),
    "diffusion": Key("guidance", "-", float, 0.0, 1.0, "lambda, diffusion rate of the state potential"),
    # energy
    "battery_wh": Key("energy", "Wh", float, 0.01, 10_000.0, "E_cap, battery capacity (1 Wh = 3600 J)"),
    "soc0": Key("energy", "-", float, 0.001, 1.0, "initial state of charge (A39)"),
    "p_move": Key("energy", "W", float, 0.0, 100_000.0, "locomotion power on normal ground while translating (A8)"),
    "p_comp": Key("energy", "W", float, 0.0, 100_000.0, "computation power, every alive robot (A8)"),
    "p_comm": Key("energy", "W", float, 0.0, 100_000.0, "power per active communication link (A8)"),
    "p_scan": Key("energy", "W", float, 0.0, 100_000.0, "scanning power, mobile roles only (A8)"),
    "p_avoid": Key("energy", "W", float, 0.0, 100_000.0, "extra power while obstacle avoidance is active (A8)"),
    "e_exploit": Key("energy", "J", float, 0.0, 1e9, "energy per load at T (A8)"),
    "p_solar": Key("energy", "W", float, 0.0, 1e6, "solar input inside R, 0 outside (A9: 0.30 * 1361 * 0.25)"),
    # records
    "rate_window_s": Key("records", "s", float, 0.001, 86_400.0, "W_rate, window of the rate of return (A34)"),
    "snapshot_every_s": Key("records", "s", float, 0.001, 86_400.0, "interval of the periodic network snapshots "
                            "(section 19)"),
    "frames": Key("records", "-", bool, None, None, "also a snapshot (\"frame\") every n_T ticks, for the replay page"),
    # options of section 17
    "avoidance": _word("options", "A28: offset from the plan while an obstacle is sensed, or the earlier "
                       "reading (the turn becomes the plan)", "avoidance"),
    "broadcast_velocity": _word("options", "A28: robots broadcast their planned velocity v_m, or this tick's "
                                "motion", "broadcast_velocity"),
    "broadcast": _word("options", "A4: mobile robots broadcast every tick, or once per update", "broadcast"),
    "weight_form": _word("options", "A12: w = omega^rho_f (1 - S)^rho_c; bracket: omega max(0, 1 - rho_c S); "
                         "literal: omega (1 - S)", "weight_form"),
    "fallback": _word("options", "A18: R -> nest fallback only once R was visited, or always (Eq 5-16 as printed)",
                      "fallback"),
    "turn_on": _word("options", "A26: turn around on role changes inside a region and at decay, or on every "
                     "change", "turn_on"),
    "los_bodies": Key("options", "-", bool, None, None, "A30: robot bodies occlude communication"),
    "redecide": _word("options", "A41: extra heading decisions: none, when avoidance clears, or when the nearest "
                      "beacon changes", "redecide"),
    "completion": _word("options", "A17: completion by role (and rows 9, 11), or by the last region visited",
                        "completion"),
}

#: Limits on a run's work and memory, checked before any work (:func:`run_size`). ``robot_ticks``:
#: runs x ticks x robots (motion, energy, roles: the defaults make 1.4e8); ``pair_ticks``: runs x
#: ticks x robots^2 (sensing and communication between robots: 7e9 at the defaults);
#: ``records``: rows of the time series (runs x (ticks / n_T + 1)); ``snapshot_rows``: rows of the
#: snapshots table (runs x robots x snapshots per run; the defaults with ``frames = true`` make
#: 9.4e5, about 250 MB while built); ``trip_rows``: the most trip records the runs can hold, each
#: robot driving the shortest gap between two regions for every trip (runs x robots x (v0 T_run /
#: gap + 1); 3.4e6 at the defaults, ~400 MB, where a run of 50 records a few hundred per run).
RUN_LIMITS = {"robot_ticks": 2e9, "pair_ticks": 1e11, "records": 5e6, "snapshot_rows": 1e6, "trip_rows": 1e7}
#: Milestone snapshots of a run besides the periodic ones: first_T, first_R, first_row5, end.
MILESTONES = 4


def _allowed(key: Key) -> str:
    if key.kind is bool:
        return "true, false"
    if isinstance(key.kind, tuple):
        return ", ".join(repr(word) for word in key.kind)
    low, high = (f"{v:g}" if key.kind is float else f"{v:,}" for v in (key.low, key.high))
    return f"[{low}, {high}]"


SCHEMA: dict[str, Field] = {name: Field(key.section, key.unit, _allowed(key), key.doc) for name, key in KEYS.items()}
DEFAULTS: dict = {f.name: f.default for f in fields(LunarParams)}
_SECTIONS = Sections(NAME, SCHEMA)
SECTIONS: dict[str, tuple[str, ...]] = _SECTIONS.keys


def check(name: str, value: Any) -> Any:
    """``value`` of key ``name``, typed as its kind (an int is taken for a float), or ConfigError
    naming the key, the value and what is allowed."""
    key = KEYS[name]
    where = f"{key.section}.{name}"
    if key.kind is bool:
        if not isinstance(value, bool):
            raise ConfigError(f"{where} must be true or false (a TOML boolean, unquoted), got "
                              f"{type(value).__name__} {_show(value)}", (name,))
        return value
    if isinstance(key.kind, tuple):
        if not isinstance(value, str):
            raise ConfigError(f"{where} must be a string, got {type(value).__name__} {_show(value)}", (name,))
        if value not in key.kind:
            # the nearest word, also for a word in the wrong case ('soft-rt')
            near = _suggest(value.upper() if value.upper() in key.kind else value, key.kind)
            raise ConfigError(f"{where} = {_show(value)} is not allowed{near}. "
                              f"Allowed: {_allowed(key)}", (name,))
        return value
    if key.kind is int:
        if not isinstance(value, int) or isinstance(value, bool):
            hint = f" (write {int(value)})" if isinstance(value, float) and value.is_integer() else ""
            raise ConfigError(f"{where} must be an integer, got {type(value).__name__} {_show(value)}{hint}", (name,))
    elif not isinstance(value, (int, float)) or isinstance(value, bool):
        raise ConfigError(f"{where} must be a number, got {type(value).__name__} {_show(value)}", (name,))
    elif isinstance(value, int):
        value = float(value) if abs(value) < 2**1000 else math.inf
    if not (key.low <= value <= key.high):  # nan fails too
        raise ConfigError(f"{where} = {_show(value)} is out of range: allowed {_allowed(key)}", (name,))
    return value


def snapshots_per_run(params: LunarParams) -> int:
    """Most snapshots a run records: the milestones, one every ``snapshot_every_s`` and, with
    ``frames``, one every n_T ticks."""
    count = MILESTONES + params.ticks // params.snapshot_every_ticks
    return count + (params.ticks // params.n_T + 1 if params.frames else 0)


def region_gap(params: LunarParams) -> float:
    """The shortest distance between the edges of two regions [m]: what a trip's robot drives at least."""
    layout = build(params)
    centres, radii = layout.centres, layout.radii
    return min(math.dist(centres[a], centres[b]) - radii[a] - radii[b] for a in centres for b in centres if a < b)


def trips_per_robot(params: LunarParams) -> int:
    """Most trip records one robot of a run can make: one per shortest gap it can drive, and its first."""
    return math.floor(params.ticks * params.v0 * params.tau / region_gap(params)) + 1


def run_size(params: LunarParams) -> dict[str, float]:
    """The work and memory of a run as :data:`RUN_LIMITS` counts them."""
    run_ticks = params.runs * params.ticks
    return {"robot_ticks": run_ticks * params.n_robots, "pair_ticks": run_ticks * params.n_robots ** 2,
            "records": params.runs * (params.ticks // params.n_T + 1),
            "snapshot_rows": params.runs * params.n_robots * snapshots_per_run(params),
            "trip_rows": params.runs * params.n_robots * trips_per_robot(params)}


#: Each limit of :data:`RUN_LIMITS`: the keys it depends on, and what brings it down.
_LIMIT_FIXES = {"robot_ticks": (("runs", "duration_s", "tau", "n_robots"), "lower runs, duration_s or n_robots"),
                "pair_ticks": (("runs", "duration_s", "tau", "n_robots"), "lower runs, duration_s or n_robots"),
                "records": (("runs", "duration_s", "tau", "update_interval_s"),
                            "lower runs or duration_s, or raise update_interval_s"),
                "snapshot_rows": (("runs", "n_robots", "snapshot_every_s", "frames"),
                                  "lower runs or n_robots, raise snapshot_every_s, or set frames = false"),
                "trip_rows": (("runs", "n_robots", "duration_s", "v0", "layout_scale"),
                              "lower runs, n_robots, duration_s or v0")}


def _factors(p: LunarParams) -> dict[str, str]:
    """What each of :data:`RUN_LIMITS` counts, in ``p``'s numbers."""
    return {"robot_ticks": f"runs {p.runs} x {p.ticks:,} ticks x {p.n_robots} robots",
            "pair_ticks": f"runs {p.runs} x {p.ticks:,} ticks x {p.n_robots}^2 robot pairs",
            "records": f"runs {p.runs} x {p.ticks // p.n_T + 1:,} records per run",
            "snapshot_rows": f"runs {p.runs} x {p.n_robots} robots x {snapshots_per_run(p):,} snapshots per run",
            "trip_rows": f"runs {p.runs} x {p.n_robots} robots x {trips_per_robot(p):,} trips a robot can make, "
                         f"driving {p.v0:g} m/s for {p.duration_s:g} s with {region_gap(p):.3g} m between regions"}


def validate(params: LunarParams) -> None:
    """The rules between values and the size of the run; ConfigError (one line) naming the keys."""
    p = params
    for name, interval in (("duration_s", p.duration_s), ("update_interval_s", p.update_interval_s),
                           ("rate_window_s", p.rate_window_s), ("snapshot_every_s", p.snapshot_every_s)):
        if math.floor(interval / p.tau + 1e-9) < 1:
            raise ConfigError(f"{KEYS[name].section}.{name} = {interval:g} s is shorter than one tick "
                              f"(run.tau = {p.tau:g} s): it must hold at least one", (name, "tau"))
    if p.v0 * p.tau > p.r_body:
        raise ConfigError(f"a tick's step v0 * tau = {p.v0:g} * {p.tau:g} = {p.v0 * p.tau:g} m is longer than "
                          f"robots.r_body = {p.r_body:g} m: robots would jump through each other and obstacle "
                          "edges; lower v0 or tau", ("v0", "tau", "r_body"))
    if p.first_run + p.runs - 1 > MAX_RUN:
        raise ConfigError(f"runs {p.first_run}-{p.first_run + p.runs - 1} go beyond run index {MAX_RUN:,}",
                          ("first_run", "runs"))
    size = run_size(p)
    for limit, most in RUN_LIMITS.items():
        if size[limit] > most:
            keys, fix = _LIMIT_FIXES[limit]
            holds = "could hold up to" if limit == "trip_rows" else "would hold"  # a bound, not an estimate
            raise ConfigError(f"the run {holds} ~{size[limit]:.3g} {limit.replace('_', '-')} "
                              f"({_factors(p)[limit]}); at most {most:g}: {fix}", keys)


class Config(LunarParams):
    """A validated configuration: :class:`LunarParams` with the contract's JSON forms."""

    def value(self, name: str) -> Any:
        return getattr(self, name)

    def to_dict(self) -> dict:
        """``{"scenario": "lunar", section: {key: value}}``, as a config file writes it."""
        return {SCENARIO_KEY: NAME, **{section: {key: getattr(self, key) for key in keys}
                                       for section, keys in SECTIONS.items()}}

    def to_json(self) -> str:
        """Deterministic JSON text of :meth:`to_dict` (sorted keys)."""
        return json.dumps(self.to_dict(), sort_keys=True)


def _build(values: Mapping[str, Any], origin: Mapping[str, str]) -> Config:
    """Defaults updated by ``values`` -> Config, validated once; errors say where a value came from."""
    try:
        config = Config(**{name: check(name, v) for name, v in values.items()})
        validate(config)
    except ConfigError as e:
        raise with_sources(e, origin) from None
    return config


resolve_key = _SECTIONS.resolve_key


def load(path: str | os.PathLike | None = None, overrides: Iterable[str] = (), seed: int | None = None) -> Config:
    """Read a lunar config: defaults < file < ``overrides`` (``"key=value"``, in order) < ``seed``.

    Raises
    ------
    ConfigError
        For any problem, before any work: the file (unreadable, not TOML, unknown section or
        key), a malformed ``--set``, a wrong type, a value out of range, a combination the model
        does not define or a run too large (:data:`RUN_LIMITS`).
    """
    return _build(*_SECTIONS.read(DEFAULTS, path, overrides, seed))


def value(config: Config, name: str) -> Any:
    return config.value(name)


def replace(config: Config, changes: Mapping[str, Any]) -> Config:
    """A validated copy of ``config`` with ``changes`` (``{key: value}``) applied, typed as in :func:`load`."""
    return _build(_SECTIONS.changed({name: getattr(config, name) for name in SCHEMA}, changes), {})


def replicates(config: Config) -> range:
    """The runs a run of ``config`` holds."""
    return range(config.first_run, config.first_run + config.runs)


def config_from_dict(document: Mapping[str, Any]) -> Config:
    """:meth:`Config.to_dict`'s form (any subset of keys) -> Config."""
    return _build({**DEFAULTS, **_SECTIONS.flatten(document)}, {})


def read_config(path: str | os.PathLike) -> Config:
    """The config embedded in a lunar parquet file; DataError naming the file if it holds no valid config."""
    from ..records import read_config as read

    return read(path, config_from_dict)


# ---------------------------------------------------------------- running


def table_schemas() -> dict[str, pyarrow.Schema]:
    """Columns and types of the tables :func:`simulate` writes (:mod:`dronefleet.lunar.simulate`)."""
    from .simulate import table_schemas as schemas

    return schemas()


def simulate(config: Config) -> dict[str, pyarrow.Table]:
    """Every run of ``config`` in one kernel call -> ``{"summary", "timeseries", "trips", "snapshots"}``
    pyarrow tables, each carrying the config in its metadata."""
    from ..records import CONFIG_KEY
    from .simulate import simulate as run

    tables = run(config)
    metadata = {CONFIG_KEY: config.to_json()}
    return {name: tables[name].replace_schema_metadata(metadata) for name in TABLES}


def _options(config: Config) -> str:
    """The section-17 options that differ from the defaults, ``", options: avoidance=turn"``; or ''."""
    changed = [f"{name}={getattr(config, name)}".lower() for name in SECTIONS["options"]
               if getattr(config, name) != DEFAULTS[name]]
    return f", options: {' '.join(changed)}" if changed else ""


def describe(config: Config) -> str:
    """One line naming the configuration (the head of ``run``)."""
    p = config
    runs = f"run {p.first_run}" if p.runs == 1 else f"runs {p.first_run}-{p.first_run + p.runs - 1}"
    return (f"{p.layout} (scale {p.layout_scale:g}), {counted(p.n_robots, 'robot')}, {p.battery_wh:g} Wh, "
            f"v0 {p.v0:g} m/s, eps {p.eps:g}{_options(p)}; {runs} (seed {p.seed}) x {p.duration_s:g} s "
            f"({p.ticks:,} ticks)")


def label(config: Config) -> str:
    """Short tag of the run's default folder."""
    return f"{config.layout}-n{config.n_robots}-{config.battery_wh:g}Wh-runs{config.first_run}-" \
           f"{config.first_run + config.runs - 1}"


_SUMMARY_ROWS = (("resources returned [units]", "resources", ",.1f"), ("trips (unloads)", "trips", ",.1f"),
                 ("recharging interruptions", "interruptions", ",.1f"), ("charging sessions", "sessions", ",.1f"),
                 ("deaths", "deaths", ",.2f"), ("beacons at the end", "beacons", ",.1f"),
                 ("alignment T (to target)", "alignment_T", ".3f"), ("alignment N (to nest)", "alignment_N", ".3f"),
                 ("alignment R (to recharge)", "alignment_R", ".3f"))


def format_summary(tables: Mapping[str, pyarrow.Table]) -> str:
    """Mean, sd and min-max over the runs of each per-run metric (a run without a value, an
    alignment with no beacon holding a vector, is left out and counted)."""
    summary = tables["summary"]
    lines = [f"  {'over ' + counted(summary.num_rows, 'run'):<28}{'mean':>11}{'sd':>10}{'min':>11}{'max':>11}"]
    for text, column, fmt in _SUMMARY_ROWS:
        x = np.array(summary.column(column).to_pylist(), dtype=np.float64)  # to_numpy imports pandas
        x = x[~np.isnan(x)]
        missing = summary.num_rows - x.size
        note = f"   ({counted(missing, 'run')} without a value)" if missing else ""
        if x.size == 0:
            lines.append(f"  {text:<28}{'-':>11}{note}")
            continue
        sd = f"{x.std(ddof=1):{fmt}}" if x.size > 1 else "-"
        lines.append(f"  {text:<28}{x.mean():>11{fmt}}{sd:>10}{x.min():>11{fmt}}{x.max():>11{fmt}}{note}")
    return "\n".join(lines)


def replay_data(run_dir: Path, trial: int | None = None) -> dict[str, Any]:
    """The replay page's data of a run folder (its config read from ``summary.parquet``), of its
    run ``trial`` (None: its first): :func:`dronefleet.lunar.replay.replay_data`."""
    from .replay import chosen_run
    from .replay import replay_data as data

    config = read_config(run_dir / "summary.parquet")
    return data(run_dir, config, describe(config), chosen_run(run_dir, config, trial))


def check_replayable(config: Config) -> None:
    """Refuse ``run --replay`` of a run whose page would be too large (:mod:`dronefleet.lunar.replay`)."""
    from .replay import check_replayable as check

    check(config)


def study() -> Any:
    """Figs 6-3 to 6-11 and the eps = 1 control in ``dronefleet reproduce``: :mod:`dronefleet.lunar.study`."""
    from . import study as figures

    return figures
