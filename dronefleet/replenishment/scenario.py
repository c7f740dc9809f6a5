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

A run holds all its trials and has no root seed (``SEED_KEY`` is None): ``--seed``,
``dronefleet.run(seed=...)`` and a sweep's ``seeds`` are refused, naming ``first_trial`` and
``trials``, which choose the trials. In a sweep (:mod:`dronefleet.sweeps`) a configuration is
one run; ``first_trial = [1, 51]`` in the grid with ``trials = 50`` runs trials 1-100 in two runs
per configuration, which can be added later without redoing the first 50.

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
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..console import counted
from ..contract import Column
from .bounds import (COMMUTE_TICKS, BoundUndefinedError, bounds, constant_supply_bounds, fixed_bounds,
                     fixed_work_ceiling)
from .config import (DEFAULTS, NAME, NO_SEED, SCHEMA, Config, config_from_dict, describe, label, load,
                     read_config, replace, replicates, resolve_key, value)
from .kernel import PHASES
from .simulate import summary_columns

if TYPE_CHECKING:
    import pyarrow

__all__ = ["NAME", "SCHEMA", "DEFAULTS", "TABLES", "FIGURES", "SEED_KEY", "SEEDS_REQUIRED", "REPLICATE_NOUN",
           "NO_SEED", "Config", "load", "resolve_key", "replace", "value", "replicates", "config_from_dict",
           "read_config", "table_schemas", "columns", "simulate", "format_summary", "describe", "label",
           "format_bounds", "replay_data", "study"]

TABLES = ("summary", "timeseries")
#: Figures of ``dronefleet reproduce`` drawn from this scenario (fig09..fig12 come with
#: dronefleet/replenishment/experiments.py).
FIGURES: tuple[str, ...] = ("fig09", "fig10", "fig11", "fig12")
#: No root seed: --seed, seed= and a sweep's seeds are refused (:data:`NO_SEED` says why).
SEED_KEY = None
SEEDS_REQUIRED = False
REPLICATE_NOUN = "trial"


# ---------------------------------------------------------------- running


def table_schemas() -> dict[str, pyarrow.Schema]:
    """The columns and types of the tables :func:`simulate` writes (int64 counts, float64 energies)."""
    import pyarrow as pa

    counts = {"trial", "seed", "tick", "work", "depleted_workers", "depleted_chargers"}
    phases = [f"{role}_{phase}" for role, names in PHASES.items() for phase in names]
    return {table: pa.schema([(name, pa.int64() if name in counts or name in phases else pa.float64())
                              for name in names])
            for table, names in (("summary", summary_columns()),
                                 ("timeseries", ("trial", "tick", *phases, "stored_energy", "work")))}


_TRIAL = {"trial": Column("index", "the trial, numbered from 1; trial k draws from seed 876 k")}
_PHASE_DOCS = {"workers": {"charging": "charging in the base or from a mobile charger",
                           "to_work": "driving to the work area", "working": "working in the work area",
                           "to_charge": "driving back to be charged"},
               "chargers": {"charging": "charging in the base", "to_transfer": "driving to the transfer area",
                            "sharing": "handing energy to a worker", "to_base": "driving back to the base"}}
#: What every column of :func:`table_schemas` holds, with its unit (the documentation site's table pages).
COLUMNS = {
    "summary": {
        **_TRIAL,
        "seed": Column("", "the seed of the trial's random streams (876 x trial)"),
        "work": Column("points", "work done: one point per worker and tick spent working in the work area"),
        "energy": Column("energy units", "total energy consumed by all robots, workers and mobile chargers"),
        "work_energy": Column("energy units", "the energy the workers spent working"),
        "efficiency": Column("1", "work_energy / energy"),
        "efficiency_with_loss": Column("1", "work_energy / (energy + lost): the energy lost in transfer counted as "
                                            "spent"),
        "depleted_workers": Column("count", "workers whose battery ran empty during the trial"),
        "depleted_chargers": Column("count", "mobile chargers whose battery ran empty during the trial"),
        "shared": Column("energy units", "energy the mobile chargers handed to workers"),
        "lost": Column("energy units", "energy lost in those transfers (the share transfer_loss of what was drawn)"),
    },
    "timeseries": {
        **_TRIAL,
        "tick": Column("tick", "the tick of the sample (every sample_every ticks)"),
        **{f"{role}_{phase}": Column("count", f"{role} {doc}") for role, phases in _PHASE_DOCS.items()
           for phase, doc in phases.items()},
        "stored_energy": Column("energy units", "energy stored in all robots' batteries"),
        "work": Column("points", "work done so far"),
    },
}


def columns() -> dict[str, dict[str, Column]]:
    return COLUMNS


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
        for p, phase in enumerate(PHASES[role]):
            timeseries[f"{role}_{phase}"] = series[:, :, first_column + p].reshape(-1).astype(np.int64)
    timeseries["stored_energy"] = series[:, :, TS_STORED].reshape(-1)
    timeseries["work"] = series[:, :, TS_WORK].reshape(-1).astype(np.int64)  # whole points
    metadata = {CONFIG_KEY: config.to_json()}
    return {"summary": arrow_table({name: r[name] for name in summary_columns()}, metadata),
            "timeseries": arrow_table(timeseries, metadata)}


# (label, column, format, which bound sits beside it: "work", "efficiency" or None)
_SUMMARY_ROWS = (
    ("work [points]", "work", ",.1f", "work"),
    ("total energy [units]", "energy", ",.1f", None),
    ("work energy [units]", "work_energy", ",.1f", None),
    ("efficiency [fraction]", "efficiency", ".4f", "efficiency"),
    ("  with loss [fraction]", "efficiency_with_loss", ".4f", "efficiency"),
    ("depleted workers [robots]", "depleted_workers", ".2f", None),
    ("depleted chargers [robots]", "depleted_chargers", ".2f", None),
    ("shared [energy units]", "shared", ",.1f", None),
    ("lost [energy units]", "lost", ",.1f", None),
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
    lines = [f"  {'over ' + counted(summary.num_rows, 'trial'):<26}{'mean':>11}{'sd':>10}{'min':>11}{'max':>11}"
             "   bound"]
    for text, column, fmt, bound in _SUMMARY_ROWS:
        x = np.array(summary.column(column).to_pylist(), dtype=np.float64)  # to_numpy imports pandas
        sd = f"{x.std(ddof=1):{fmt}}" if x.size > 1 else "-"
        shown = beside.get(bound, "")
        if p.mobile and column == "efficiency" and p.transfer_loss != 0:
            shown = ""
        lines.append(f"  {text:<26}{x.mean():>11{fmt}}{sd:>10}{x.min():>11{fmt}}{x.max():>11{fmt}}   {shown}"
                     .rstrip())
    work = np.array(summary.column("work").to_pylist(), dtype=np.float64)
    if note is None and not p.mobile and work.max() > b.work:  # docs/replenishment-model.md section 9
        note = (f"work above W_fix, a per-cycle bound that a trial of {p.ticks} ticks may exceed by part of "
                f"a cycle; the strict ceiling within them is {fixed_work_ceiling(p):,.0f}")
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
        ("W_fix", f"{fixed.work:,.0f}", "points", "n_w D T (per cycle: a trial may exceed it by part of a cycle)"),
        ("W_fix,T", f"{fixed_work_ceiling(config.params):,.0f}", "points",
         "strict ceiling within T ticks (workers start full)"),
        ("E_fix", f"{fixed.efficiency:.4f}", "", "1 - D_cycle v_min / c_w - 2 D_c v_move / c_w"),
        "constant supply in the transfer area (the mobile strategy's reference)",
        ("D_charge,cs", f"{supply.d_charge:.2f}", "ticks", "c_w / ((1 - lambda) v_charge - v_min)"),
        ("D_work,cs", f"{supply.d_work:.2f}", "ticks", "c_w / (v_min + v_work)"),
        ("D_cs", f"{supply.duty:.5f}", "", "duty D_work,cs / (D_work,cs + D_charge,cs)"),
        ("W_cs", f"{supply.work:,.0f}", "points", "n_w T D_cs"),
        ("E_cs", f"{supply.efficiency:.4f}", "",
         "(c_w - v_min (D_work,cs + D_charge,cs)) / (c_w + lambda v_charge D_charge,cs): the loss"),
        ("", "", "", "counted in the denominator, as Fig 12's efficiency counts it"),
    ]
    return "\n".join(f"  {row}" if isinstance(row, str) else
                     f"    {row[0]:<12}{row[1]:>10} {row[2]:<7} {row[3]}" for row in rows)


def replay_data(run_dir: Path, trial: int | None = None) -> dict[str, Any]:
    """The replay page's data of a run folder (its config read from ``summary.parquet``), of its
    trial ``trial`` (None: its first): :func:`dronefleet.replenishment.replay.replay_data`."""
    from ..records import chosen_trial
    from .replay import replay_data as data

    config = read_config(run_dir / "summary.parquet")
    return data(config, describe(config), chosen_trial(run_dir, replicates(config), trial))


def study() -> Any:
    """Figures 9-12 in ``dronefleet reproduce``: :mod:`dronefleet.replenishment.study`."""
    from . import study as figures

    return figures
