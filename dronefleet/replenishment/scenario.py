"""The energy-replenishment scenario behind the :mod:`dronefleet.scenarios` contract.

Config files are TOML naming the scenario and grouping keys in three sections
(``configs/replenishment.toml`` spells out and documents every key)::

    scenario = "replenishment"
    [run]
    trials = 50             # trials of the configuration [count]
    [robots]
    strategy = "mobile"
    [energy]
    transfer_loss = 0.0     # lambda [fraction]

:data:`SCHEMA` declares each key's section, unit, allowed values and meaning;
:data:`DEFAULTS` its default (the spec's, with the mobile strategy: 6 chargers,
phi 2). Types are strict as for delivery (``bool`` is not an ``int``, ``7.0``
is not an ``int``, an ``int`` is taken for a float). Ranges and the rules between
parameters are checked in one place, :meth:`Params.validate`; this module adds
only ``first_trial`` (trial k uses seed 876 k, so any slice of trials can run
alone). ``--set key=value`` takes ``section.key`` or the bare key.

A run holds all its trials, so in a sweep (:mod:`dronefleet.sweeps`) a configuration is one
run: its seed key is ``first_trial``, and ``[sweep] seeds`` are optional first trials of
blocks of ``trials`` trials (``seeds = [1, 51]`` with ``trials = 50``: trials 1-100 in two
runs per configuration, which can be added later without redoing the first 50; blocks that
would share a trial are refused).

Tables (:func:`simulate`): ``summary``, one row per trial (the columns of
:func:`dronefleet.replenishment.simulate.summary_columns`); ``timeseries``, one row
per trial and sampled tick: ``trial``, ``tick``, robots per controller phase
(``workers_charging``, ``workers_to_work``, ``workers_working``,
``workers_to_charge``, ``chargers_charging``, ``chargers_to_transfer``,
``chargers_sharing``, ``chargers_to_base``: phases P0..P3 of docs/replenishment-model.md section 5.1),
``stored_energy`` (sum of batteries) and ``work`` (cumulative points). Both carry
the config (JSON) in their metadata.
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

from ..config import SCENARIO_KEY, ConfigError, _name, _parse_override, _show, _suggest, read_toml
from ..scenarios import Field
from .bounds import COMMUTE_TICKS, BoundUndefinedError, bounds, constant_supply_bounds, fixed_bounds
from .params import BASE_CAPACITY, UPPER_LIMITS, Params
from .simulate import TRIAL_SEED_FACTOR, summary_columns

if TYPE_CHECKING:
    import pyarrow

__all__ = ["NAME", "SCHEMA", "DEFAULTS", "TABLES", "FIGURES", "SEED_KEY", "SEEDS_REQUIRED", "Config", "load",
           "resolve_key", "replace", "value", "replicates", "config_from_dict", "read_config", "table_schemas",
           "simulate", "format_summary", "describe", "label", "format_bounds", "replay_data"]

NAME = "replenishment"
TABLES = ("summary", "timeseries")
#: Figures of ``dronefleet reproduce`` drawn from this scenario (fig09..fig12 come with
#: dronefleet/replenishment/experiments.py).
FIGURES: tuple[str, ...] = ("fig09", "fig10", "fig11", "fig12")

#: Largest first trial index: seeds 876 k stay far inside int64.
MAX_FIRST_TRIAL = 10**15
#: A sweep's seeds are first trials; without them a configuration is one run of the base's trials.
SEED_KEY = "first_trial"
SEEDS_REQUIRED = False


def _most(name: str) -> str:
    """The upper limit of ``name`` as the schema shows it: 1e6, 1000."""
    most = UPPER_LIMITS[name][0]
    return f"{most:.0e}".replace("e+0", "e") if most >= 1e4 else f"{most:g}"


SCHEMA: dict[str, Field] = {
    "trials": Field("run", "trials", f"[1, {_most('trials')}]", "trials of the configuration, advanced together"),
    "first_trial": Field("run", "index", f"[1, {MAX_FIRST_TRIAL:.0e}]",
                         f"index k of the first trial; trial k uses seed {TRIAL_SEED_FACTOR} k"),
    "ticks": Field("run", "ticks of 0.1 s", f"[1, {_most('ticks')}]", "T, length of a trial"),
    "sample_every": Field("run", "ticks", f"[1, {_most('sample_every')}]", "sampling period of the time series"),
    "strategy": Field("robots", "-", '"fixed" | "mobile"',
                      "fixed: workers charge in the base; mobile: chargers bring energy to the transfer area"),
    "n_workers": Field("robots", "robots", f">= 1, n_workers + n_chargers <= {BASE_CAPACITY}", "workers n_w"),
    "n_chargers": Field("robots", "robots", "0 if fixed, >= 1 if mobile", "mobile chargers n_m"),
    "worker_capacity": Field("robots", "energy units", f"(0, {_most('worker_capacity')}]",
                             "worker battery capacity c_w"),
    "charger_capacity_factor": Field("robots", "fraction of c_w", f"(0, {_most('charger_capacity_factor')}]",
                                     "phi: mobile charger capacity c_m = phi c_w (unused if fixed)"),
    "work_ratio": Field("energy", "-", f"(0, {_most('work_ratio')}]",
                        "r: working costs v_work = 0.1 r energy units per tick"),
    "charge_rate": Field("energy", "-", f"(0, {_most('charge_rate')}]",
                         "k: charging (base and charger to worker) at v_charge = 1.0 k energy units per tick"),
    "transfer_loss": Field("energy", "fraction", "[0, 1)",
                           "lambda: a worker receives (1 - lambda) of what a mobile charger gives"),
}
SECTIONS: dict[str, tuple[str, ...]] = {}
for _key, _field in SCHEMA.items():
    SECTIONS[_field.section] = SECTIONS.get(_field.section, ()) + (_key,)
del _key, _field

DEFAULTS: dict = {**{f.name: f.default for f in fields(Params)},
                  "strategy": "mobile", "n_chargers": 6, "first_trial": 1}
assert set(DEFAULTS) == set(SCHEMA), "every Params field is declared once"


@dataclass(frozen=True)
class Config:
    """One validated configuration: the model's :class:`Params` and the first trial index."""

    params: Params
    first_trial: int = 1

    @property
    def last_trial(self) -> int:
        return self.first_trial + self.params.trials - 1

    def value(self, name: str) -> Any:
        return self.first_trial if name == "first_trial" else getattr(self.params, name)

    def to_dict(self) -> dict:
        """``{"scenario": "replenishment", section: {key: value}}``, as a config file writes it."""
        return {SCENARIO_KEY: NAME, **{section: {key: self.value(key) for key in keys}
                                       for section, keys in SECTIONS.items()}}

    def to_json(self) -> str:
        """Deterministic JSON text of :meth:`to_dict` (sorted keys)."""
        return json.dumps(self.to_dict(), sort_keys=True)


# ---------------------------------------------------------------- loading


def _typed(name, value):
    """``value`` of key ``name`` with the type of its default (strict, as for delivery)."""
    default, q = DEFAULTS[name], f"{SCHEMA[name].section}.{name}"
    if isinstance(default, str):
        if not isinstance(value, str):
            raise ConfigError(f"{q} must be a string, got {type(value).__name__} {_show(value)}", [name])
        if name == "strategy" and value not in ("fixed", "mobile"):
            raise ConfigError(f"{q} = {_show(value)} is not a strategy"
                              f"{_suggest(value, ('fixed', 'mobile'))}. Allowed: 'fixed', 'mobile'", [name])
        return value
    if isinstance(default, int):
        if not isinstance(value, int) or isinstance(value, bool):
            hint = f" (write {int(value)})" if isinstance(value, float) and value.is_integer() else ""
            raise ConfigError(f"{q} must be an integer, got {type(value).__name__} {_show(value)}{hint}", [name])
        if abs(value) >= 2**63:
            raise ConfigError(f"{q} = {_show(value)} is out of range: allowed {SCHEMA[name].allowed} "
                              "(and below 2**63)", [name])
        return value
    if not isinstance(value, (int, float)) or isinstance(value, bool):
        raise ConfigError(f"{q} must be a number, got {type(value).__name__} {_show(value)}", [name])
    try:
        return float(value)
    except OverflowError:  # an int beyond any float: Params.validate refuses inf
        return math.inf


def _build(values, origin):
    """Defaults updated by ``values`` -> Config, validated once; errors say where a value came from."""
    try:
        typed = {name: _typed(name, value) for name, value in values.items()}
        first = typed.pop("first_trial")
        params = Params(**typed).validate()
        if not 1 <= first <= MAX_FIRST_TRIAL:
            raise ConfigError(f"run.first_trial = {first} is out of range: allowed {SCHEMA['first_trial'].allowed}",
                              ["first_trial"])
        return Config(params, first)
    except ConfigError as e:
        sources = list(dict.fromkeys(origin[k] for k in e.keys if k in origin))
        if not sources:
            raise
        raise ConfigError(f"{e} (set in {'; '.join(sources)})", e.keys) from None


def _unknown_key(key, where=""):
    return ConfigError(f"{where}unknown key {_show(key)}{_suggest(key.rpartition('.')[2], SCHEMA)}. "
                       f"Allowed keys: {', '.join(f'{SCHEMA[k].section}.{k}' for k in SCHEMA)}")


def resolve_key(key: str) -> str:
    """'section.key' or a bare key -> the key name."""
    section, dot, name = key.rpartition(".")
    if name not in SCHEMA or (dot and section != SCHEMA[name].section):
        raise _unknown_key(key)
    return name


def _flatten(document, where=None, origin=None):
    """``{scenario, section: {key: value}}`` -> flat ``{key: value}``, checking names."""
    pre = f"{where}: " if where else ""
    if not isinstance(document, dict):
        raise ConfigError(f"{pre}expected a table of sections, got {type(document).__name__}")
    flat = {}
    for section, table in document.items():
        if section == SCENARIO_KEY:
            if table != NAME:
                raise ConfigError(f"{pre}scenario = {_show(table)}, expected {NAME!r}")
            continue
        if section in SCHEMA:
            raise ConfigError(f"{pre}key {section!r} is at the top level; put it in section "
                              f"[{SCHEMA[section].section}]", [section])
        if section not in SECTIONS:
            raise ConfigError(f"{pre}unknown section [{_name(section)}]{_suggest(section, SECTIONS)}. "
                              f"Allowed sections: {', '.join(SECTIONS)}")
        if not isinstance(table, dict):
            raise ConfigError(f"{pre}[{section}] must be a table of key = value, got {_show(table)}")
        for key, value in table.items():
            if key not in SECTIONS[section]:
                if key in SCHEMA:
                    raise ConfigError(f"{pre}{section}.{key} belongs in [{SCHEMA[key].section}]", [key])
                raise _unknown_key(f"{section}.{key}", pre)
            flat[key] = value
            if origin is not None and where:
                origin[key] = where
    return flat


def load(path: str | os.PathLike | None = None, overrides: Iterable[str] = (), seed: int | None = None) -> Config:
    """Read a replenishment config: defaults < file < ``overrides`` (``"key=value"``, in order).

    Raises
    ------
    ConfigError
        For any problem, before any work: the file (unreadable, not TOML, unknown
        section or key), a malformed ``--set``, a wrong type, a value out of range
        or a run too large (:meth:`Params.validate`), or a ``seed`` (trials have
        their own seeds: choose them with ``first_trial`` and ``trials``).
    """
    if seed is not None:
        raise ConfigError(f"--seed does not apply to {NAME}: trial k uses seed {TRIAL_SEED_FACTOR} k; "
                          "choose the trials with --set first_trial=K --set trials=N")
    parsed = [(_parse_override(o, resolve_key), o) for o in overrides]
    values, origin = dict(DEFAULTS), {}
    if path is not None:
        values.update(_flatten(read_toml(path)[1], str(path), origin))
    for (name, value), text in parsed:
        values[name] = value
        origin[name] = f"--set {text}"
    return _build(values, origin)


def value(config: Config, name: str) -> Any:
    return config.value(name)


def replace(config: Config, changes: Mapping[str, Any]) -> Config:
    """A validated copy of ``config`` with ``changes`` (``{key: value}``) applied, typed as in :func:`load`."""
    for name in changes:
        if name not in SCHEMA:
            raise _unknown_key(str(name))
    return _build({**{name: config.value(name) for name in SCHEMA}, **changes}, {})


def replicates(config: Config) -> range:
    """The trials a run of ``config`` holds."""
    return range(config.first_trial, config.last_trial + 1)


def config_from_dict(document: Mapping[str, Any]) -> Config:
    """:meth:`Config.to_dict`'s form (any subset of keys) -> Config."""
    return _build({**DEFAULTS, **_flatten(document)}, {})


def read_config(path: str | os.PathLike) -> Config:
    """The config embedded in a replenishment parquet file; DataError naming the file if it holds
    no valid config."""
    from ..records import read_config as read

    return read(path, config_from_dict)


# ---------------------------------------------------------------- running


_PHASES = {"workers": ("charging", "to_work", "working", "to_charge"),
           "chargers": ("charging", "to_transfer", "sharing", "to_base")}


def table_schemas() -> dict[str, pyarrow.Schema]:
    """The columns and types of the tables :func:`simulate` writes (int64 counts, float64 energies)."""
    import pyarrow as pa

    counts = {"trial", "seed", "tick", "work", "depleted_workers", "depleted_chargers"}
    phases = [f"{role}_{phase}" for role, names in _PHASES.items() for phase in names]
    return {table: pa.schema([(name, pa.int64() if name in counts or name in phases else pa.float64())
                              for name in names])
            for table, names in (("summary", summary_columns()),
                                 ("timeseries", ("trial", "tick", *phases, "stored_energy", "work")))}


def simulate(config: Config) -> dict[str, pyarrow.Table]:
    """Every trial of ``config`` in one kernel call -> ``{"summary", "timeseries"}`` pyarrow tables."""
    from ..records import CONFIG_KEY, arrow_table
    from .kernel import TS_CHARGER_PHASE, TS_STORED, TS_WORK, TS_WORKER_PHASE
    from .simulate import simulate as run_trials

    r = run_trials(config.params, first_trial=config.first_trial)
    series = r["series"]                                   # (trials, samples, N_TS)
    trials, samples, _ = series.shape
    timeseries = {"trial": np.repeat(r["trial"], samples), "tick": np.tile(r["series_tick"], trials)}
    for role, first_column in (("workers", TS_WORKER_PHASE), ("chargers", TS_CHARGER_PHASE)):
        for p, phase in enumerate(_PHASES[role]):
            timeseries[f"{role}_{phase}"] = series[:, :, first_column + p].reshape(-1).astype(np.int64)
    timeseries["stored_energy"] = series[:, :, TS_STORED].reshape(-1)
    timeseries["work"] = series[:, :, TS_WORK].reshape(-1).astype(np.int64)  # whole points
    metadata = {CONFIG_KEY: config.to_json()}
    return {"summary": arrow_table({name: r[name] for name in summary_columns()}, metadata),
            "timeseries": arrow_table(timeseries, metadata)}


def describe(config: Config) -> str:
    """One line naming the configuration (the head of ``run`` and ``bounds``)."""
    p = config.params
    chargers = (f"{p.n_chargers} mobile chargers (phi {p.charger_capacity_factor:g})" if p.mobile
                else "fixed chargers")
    return (f"{p.n_workers} workers, {chargers}, r {p.work_ratio:g}, k {p.charge_rate:g}, "
            f"lambda {p.transfer_loss:g}, trials {config.first_trial}-{config.last_trial} "
            f"(seeds {TRIAL_SEED_FACTOR} k) x {p.ticks} ticks")


def label(config: Config) -> str:
    """Short tag of the run's default folder: its trials."""
    return f"trials{config.first_trial}-{config.last_trial}"


# (label, column, format, which bound sits beside it: "work", "efficiency" or None)
_SUMMARY_ROWS = (
    ("work [points]", "work", ",.1f", "work"),
    ("total energy", "energy", ",.1f", None),
    ("work energy", "work_energy", ",.1f", None),
    ("efficiency", "efficiency", ".4f", "efficiency"),
    ("efficiency with loss", "efficiency_with_loss", ".4f", "efficiency"),
    ("depleted workers", "depleted_workers", ".2f", None),
    ("depleted chargers", "depleted_chargers", ".2f", None),
    ("shared [energy]", "shared", ",.1f", None),
    ("lost [energy]", "lost", ",.1f", None),
)


def format_summary(tables: Mapping[str, pyarrow.Table]) -> str:
    """Mean, sd and min-max over the trials of each metric, the section-9 bound beside work and
    efficiency (W_fix and E_fix for fixed chargers; W_cs and E_cs for mobile ones, E_cs beside
    the efficiency that counts the transfer loss, Fig 12's form, and beside the plain one when
    lambda = 0, where both forms agree)."""
    from ..records import CONFIG_KEY

    summary = tables["summary"]
    config = config_from_dict(json.loads(summary.schema.metadata[CONFIG_KEY]))
    p = config.params
    try:
        b = bounds(p)
        names = ("W_cs", "E_cs") if p.mobile else ("W_fix", "E_fix")
        beside = {"work": f"{b.work:,.0f} ({names[0]})", "efficiency": f"{b.efficiency:.4f} ({names[1]})"}
        note = None
    except BoundUndefinedError as error:
        beside, note = {}, f"no bound: {error}"
    lines = [f"  {'over ' + str(summary.num_rows) + ' trials':<22}{'mean':>11}{'sd':>10}{'min':>11}{'max':>11}"
             "   bound"]
    for text, column, fmt, bound in _SUMMARY_ROWS:
        x = np.array(summary.column(column).to_pylist(), dtype=np.float64)  # to_numpy imports pandas
        sd = f"{x.std(ddof=1):{fmt}}" if x.size > 1 else "-"
        shown = beside.get(bound, "")
        if p.mobile and column == "efficiency" and p.transfer_loss != 0:
            shown = ""
        lines.append(f"  {text:<22}{x.mean():>11{fmt}}{sd:>10}{x.min():>11{fmt}}{x.max():>11{fmt}}   {shown}"
                     .rstrip())
    if note:
        lines.append(f"  {note}")
    return "\n".join(lines)


def format_bounds(config: Config) -> str:
    """The section-9 bounds and their durations, both strategies (they depend on n_w, T, c_w, r,
    k and lambda only). Raises :class:`BoundUndefinedError` (one line) where either does not exist."""
    fixed, supply = fixed_bounds(config.params), constant_supply_bounds(config.params)
    rows = [
        "fixed chargers in the base (Eqs 1-3)",
        ("D_c", f"{COMMUTE_TICKS:.2f}", "ticks", "commute one way: 1.0 m at 1.2 cm/tick"),
        ("D_charge", f"{fixed.d_charge:.2f}", "ticks", "c_w / (v_charge - v_min)"),
        ("D_work", f"{fixed.d_work:.2f}", "ticks", "(c_w - 2 (v_min + v_move) D_c) / (v_min + v_work)"),
        ("D_cycle", f"{fixed.d_cycle:.2f}", "ticks", "D_work + 2 D_c + D_charge"),
        ("D", f"{fixed.duty:.5f}", "", "duty D_work / D_cycle"),
        ("W_fix", f"{fixed.work:,.0f}", "points", "n_w D T"),
        ("E_fix", f"{fixed.efficiency:.4f}", "", "1 - D_cycle v_min / c_w - 2 D_c v_move / c_w"),
        "constant supply in the transfer area (the mobile strategy's reference)",
        ("D_charge,cs", f"{supply.d_charge:.2f}", "ticks", "c_w / ((1 - lambda) v_charge - v_min)"),
        ("D_work,cs", f"{supply.d_work:.2f}", "ticks", "c_w / (v_min + v_work)"),
        ("D_cs", f"{supply.duty:.5f}", "", "duty D_work,cs / (D_work,cs + D_charge,cs)"),
        ("W_cs", f"{supply.work:,.0f}", "points", "n_w T D_cs"),
        ("E_cs", f"{supply.efficiency:.4f}", "", "counts the transfer loss, as Fig 12"),
    ]
    return "\n".join(f"  {row}" if isinstance(row, str) else
                     f"    {row[0]:<12}{row[1]:>10} {row[2]:<7} {row[3]}" for row in rows)


def replay_data(run_dir: Path, trial: int | None = None) -> dict[str, Any]:
    """The replay page's data of a run folder: :func:`dronefleet.replenishment.replay.replay_data`."""
    from .replay import replay_data as data

    return data(run_dir, trial)
