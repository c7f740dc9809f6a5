"""The lunar study's experiments (spec LUNAR-FORAGING.md sections 12, 14) and their per-condition statistics.

E1-E3 and the eps = 1 control are the sweep files ``configs/sweeps/lunar-<experiment>.toml``
(the one source of truth; ``dronefleet sweep run`` runs them too): each configuration is one
condition (layout, battery, eps) holding its runs (``first_run`` .. ``first_run + runs - 1``).
:func:`run_configs` splits each configuration into chunks of :data:`CHUNK_RUNS` runs (run j
draws the same per-robot streams whatever runs are beside it, section 13, so a chunk's rows are
the whole configuration's), spreads them over the processes the caller passes (this package
sits below the sweeps and their executors) and returns the tables the figures read (:data:`TABLES`),
each with the condition columns :data:`CONDITION_COLUMNS`.

The statistics are pure functions of those tables (section 12, A35): per condition the runs
with the largest resources returned F(T_run) (:func:`selected`: 30 of 50), the mean and sd at
every recorded time over them and over all runs (:func:`curves`), the R-T trips of both
directions binned by entry time (:func:`trip_bins`), the run with the median F(T_run) among
the selected (:func:`median_runs`) and per-run diagnostics (:func:`run_stats`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from ..config import SweepError, shipped_config

__all__ = ["EXPERIMENTS", "CONDITION_COLUMNS", "RECORDS", "TABLES", "CURVE_METRICS", "TRIP_METRICS", "RUN_STATS",
           "BIN_S", "SELECTED", "OUT_OF", "CHUNK_RUNS", "grid_path", "condition_of", "condition_row", "selected_count",
           "selected", "curves", "rt_trips", "trip_bins", "median_runs", "run_stats", "HIGHLIGHTED_ROLES", "drives",
           "highlighted", "chunks", "run_chunks", "run_configs"]

#: The experiments with a sweep file, ``configs/sweeps/lunar-<name>.toml`` (section 14).
EXPERIMENTS = ("e1", "e2", "e3", "e4", "e5", "eps1")
#: The columns that say which condition a row belongs to (``condition``: their words).
CONDITION_COLUMNS = ("experiment", "condition", "layout", "layout_scale", "battery_wh", "eps")
#: The simulator's records of what decides the E2 claims (spec sections 19, 21; A36, A42), kept whole:
#: per-robot totals, deaths, recharging interruptions (row 2) and the stored costs near T and R.
RECORDS = ("robots", "deaths", "recharge_triggers", "beacon_costs")
#: The tables :func:`run_configs` returns.
TABLES = ("summary", "timeseries", "trips", "snapshots", *RECORDS)
#: The time-series columns the figures draw (Figs 6-7, 6-11, the control and the alignment).
CURVE_METRICS = ("resources", "interruptions", "rate", "n_mobile", "soc_sum", "n_beacons", "n_dead",
                 "alignment_T", "alignment_N", "alignment_R")
#: The R-T trip columns of Fig 6-8 a-d: measured SOC cost, energy [Wh], length [m], duration [s] (A36).
TRIP_METRICS = ("soc_cost", "energy_wh", "length_m", "duration_s")
#: The per-run diagnostics summarised per condition (section 12).
RUN_STATS = ("resources", "trips", "interruptions", "sessions", "deaths", "deaths_per_session", "beacons", "mobile",
             "alignment_T", "alignment_N", "alignment_R")
#: Width of the time bins of the R-T trip curves [s] (A34).
BIN_S = 300.0
#: Section 12 / A35: the SELECTED runs with the largest F(T_run) out of OUT_OF.
SELECTED, OUT_OF = 30, 50
#: Runs per simulate call of :func:`run_configs` (a configuration's 50 runs spread over processes).
CHUNK_RUNS = 10


def grid_path(experiment: str) -> Path:
    """``configs/sweeps/lunar-<experiment>.toml``."""
    return shipped_config("sweeps", f"lunar-{experiment}.toml")


def condition_of(layout: str, battery_wh: float, eps: float, model: str = "full") -> str:
    """The words of a condition, as the figures' legends name it: the layout, then the battery,
    eps and the model where they are not the defaults (``SOFT-RT``, ``SOFT-RT 7.5 Wh``, ``OPEN eps=1``,
    ``OPEN baseline``)."""
    from .params import LunarParams

    default = LunarParams()
    words = [layout]
    if battery_wh != default.battery_wh:
        words.append(f"{battery_wh:g} Wh")
    if eps != default.eps:
        words.append(f"eps={eps:g}")
    if model != default.model:
        words.append(model)
    return " ".join(words)


def condition_row(config: Any, experiment: str) -> dict[str, Any]:
    """The :data:`CONDITION_COLUMNS` of ``config`` (a :class:`~dronefleet.lunar.params.LunarParams`)."""
    return {"experiment": experiment,
            "condition": condition_of(config.layout, config.battery_wh, config.eps, config.model),
            "layout": config.layout, "layout_scale": config.layout_scale, "battery_wh": config.battery_wh,
            "eps": config.eps}


def selected_count(runs: int) -> int:
    """How many of ``runs`` runs are kept: SELECTED of OUT_OF, rounded half up (30 of 50; 3 of 5)."""
    return max(1, int(runs * SELECTED / OUT_OF + 0.5))


def selected(summary: pd.DataFrame) -> pd.Series:
    """Whether each row of ``summary`` (one per run: ``condition``, ``run``, ``resources``) is one of
    its condition's :func:`selected_count` runs with the largest ``resources`` (ties: the lower run
    index first). A boolean Series on ``summary``'s index."""
    keep = pd.Series(False, index=summary.index)
    for _, mine in summary.groupby("condition", sort=False):
        order = mine.sort_values(["resources", "run"], ascending=[False, True], kind="mergesort")
        keep[order.index[:selected_count(len(mine))]] = True
    return keep


def _selections(table: pd.DataFrame, summary: pd.DataFrame) -> Iterable[tuple[str, pd.DataFrame]]:
    """("selected", the rows of ``table`` of the selected runs), ("all", every row)."""
    chosen = summary.loc[selected(summary), ["condition", "run"]]
    mine = table.merge(chosen, on=["condition", "run"], how="inner")
    return (("selected", mine), ("all", table))


def _stats(groups, value: str, count: str) -> pd.DataFrame:
    """mean, sd (ddof 1; NaN for one value) and the count of non-NaN ``value``s of each group."""
    out = groups[value].agg(["mean", "std", "count"]).rename(columns={"std": "sd", "count": count})
    out[count] = out[count].astype(np.int64)
    return out.reset_index()


def curves(timeseries: pd.DataFrame, summary: pd.DataFrame, metrics: Iterable[str] = CURVE_METRICS) -> pd.DataFrame:
    """Section 12 per condition: the mean and sd of each of ``metrics`` at every recorded time over
    the selected runs (:func:`selected`) and over all runs.

    Returns one row per (condition, selection, metric, t): ``condition``, ``selection``
    ("selected" | "all"), ``metric``, ``t`` [s], ``mean``, ``sd``, ``runs`` (runs with a value
    there: NaN alignments are left out).
    """
    frames = []
    for selection, rows in _selections(timeseries, summary):
        long = rows.melt(id_vars=["condition", "run", "t"], value_vars=list(metrics), var_name="metric")
        long["value"] = long["value"].astype(np.float64)
        stats = _stats(long.groupby(["condition", "metric", "t"], sort=True), "value", "runs")
        stats.insert(1, "selection", selection)
        frames.append(stats)
    return pd.concat(frames, ignore_index=True)[["condition", "selection", "metric", "t", "mean", "sd", "runs"]]


def rt_trips(trips: pd.DataFrame, tau: float) -> pd.DataFrame:
    """The R-T trips of both directions (section 12, Fig 6-8) of a ``trips`` table, with their entry
    time ``t_entered`` = tick_entered * ``tau`` [s]."""
    rt = trips[trips["origin"].isin(("R", "T")) & trips["dest"].isin(("R", "T"))
               & (trips["origin"] != trips["dest"])].copy()
    rt["t_entered"] = rt["tick_entered"].to_numpy(dtype=np.float64) * tau
    return rt.reset_index(drop=True)


def trip_bins(trips: pd.DataFrame, summary: pd.DataFrame, bin_s: float = BIN_S) -> pd.DataFrame:
    """Fig 6-8: the mean and sd of each of :data:`TRIP_METRICS` over the R-T trips (:func:`rt_trips`)
    pooled over the selected runs (and over all runs) per ``bin_s`` bin of their entry time.

    Returns one row per (condition, selection, metric, bin): ``condition``, ``selection``,
    ``metric``, ``bin_start_s`` [s] (entry times in (bin_start_s, bin_start_s + bin_s]: closed on
    the right, so that a trip entering at T_run falls in the bin that ends there, not a bin of its
    own after the run; entries are at tick 1 or later, never at 0), ``mean``, ``sd``, ``trips``.
    """
    frames = []
    for selection, rows in _selections(trips, summary):
        # 1e-9: an entry at a bin's end (tick * tau rounded up by a few ulps) stays in that bin
        ends = np.maximum(np.ceil(rows["t_entered"].to_numpy() / bin_s - 1e-9), 1.0)
        rows = rows.assign(bin_start_s=(ends - 1.0) * bin_s)
        long = rows.melt(id_vars=["condition", "bin_start_s"], value_vars=list(TRIP_METRICS), var_name="metric")
        long["value"] = long["value"].astype(np.float64)
        stats = _stats(long.groupby(["condition", "metric", "bin_start_s"], sort=True), "value", "trips")
        stats.insert(1, "selection", selection)
        frames.append(stats)
    return pd.concat(frames, ignore_index=True)[["condition", "selection", "metric", "bin_start_s", "mean", "sd",
                                                 "trips"]]


def median_runs(summary: pd.DataFrame) -> pd.DataFrame:
    """Fig 6-9: per condition, the selected run with the median F(T_run): of the k selected runs
    ordered by (resources, run), the ((k - 1) // 2)-th (for an even k the lower of the two middle
    ones, so that it is a run). One row per condition: ``condition``, ``run``, ``resources``."""
    chosen = summary[selected(summary)]
    rows = []
    for condition, mine in chosen.groupby("condition", sort=True):
        order = mine.sort_values(["resources", "run"], kind="mergesort")
        row = order.iloc[(len(order) - 1) // 2]
        rows.append({"condition": condition, "run": int(row["run"]), "resources": int(row["resources"])})
    return pd.DataFrame(rows, columns=["condition", "run", "resources"])


def run_stats(summary: pd.DataFrame, columns: Iterable[str] = RUN_STATS) -> pd.DataFrame:
    """Per condition, the mean and sd over the selected runs and over all runs of each per-run
    column (deaths per session and the alignments among them; NaN values left out).

    One row per (condition, selection, column): ``condition``, ``selection``, ``column``,
    ``mean``, ``sd``, ``runs``.
    """
    frames = []
    for selection, rows in _selections(summary, summary):
        long = rows.melt(id_vars=["condition"], value_vars=list(columns), var_name="column")
        long["value"] = long["value"].astype(np.float64)
        stats = _stats(long.groupby(["condition", "column"], sort=True), "value", "runs")
        stats.insert(1, "selection", selection)
        frames.append(stats)
    return pd.concat(frames, ignore_index=True)[["condition", "selection", "column", "mean", "sd", "runs"]]


#: The roles Figs 6-5 and 6-6 highlight one robot of, in order: the thesis's three robots are an
#: outbound one, an inbound one and one on its way to recharge (L1061).
HIGHLIGHTED_ROLES = ("F_OUT", "F_IN", "R")


def drives(frames: pd.DataFrame) -> pd.DataFrame:
    """The steps between consecutive frames of each robot (``frames``: the snapshot rows labelled
    "frame" of one run) in which it is alive and in one role at both ends and moved: ``robot``,
    ``role``, ``t_from``, ``t_to`` [s], ``length`` [m] (straight)."""
    rows = frames.sort_values(["robot", "t"], kind="mergesort")
    alive = (rows["status"] == "alive").to_numpy()
    robot, role, t, x, y = (rows[c].to_numpy() for c in ("robot", "role", "t", "x", "y"))
    length = np.hypot(np.diff(x), np.diff(y))
    keep = (robot[1:] == robot[:-1]) & alive[1:] & alive[:-1] & (role[1:] == role[:-1]) & (length > 0)
    return pd.DataFrame({"robot": robot[1:][keep], "role": role[1:][keep], "t_from": t[:-1][keep],
                         "t_to": t[1:][keep], "length": length[keep]})


def highlighted(frames: pd.DataFrame, t_end: float, window_s: float) -> pd.DataFrame:
    """Figs 6-5, 6-6: per role of :data:`HIGHLIGHTED_ROLES`, the robot that drove farthest in
    that role over the frames of (t_end - window_s, t_end] (:func:`drives` within it; ties: the
    lower id; a robot is highlighted once, for the first role it leads; a role no robot drove in
    is left out). ``frames``: the snapshot rows labelled "frame" of one run. Returns ``robot``,
    ``role`` rows in role order."""
    steps = drives(frames)
    steps = steps[(steps["t_from"] > t_end - window_s - 1e-9) & (steps["t_to"] <= t_end + 1e-9)]
    rows = []
    for role in HIGHLIGHTED_ROLES:
        moved = steps[steps["role"] == role].groupby("robot")["length"].sum()
        moved = moved[~moved.index.isin([row["robot"] for row in rows])]
        if len(moved):
            rows.append({"robot": int(min(moved.index, key=lambda r: (-moved[r], r))), "role": role})
    return pd.DataFrame(rows, columns=["robot", "role"]).astype({"robot": np.int64, "role": object})


def chunks(config: Any, size: int = CHUNK_RUNS) -> list[Any]:
    """``config``'s runs as configurations of at most ``size`` runs each (first_run, runs replaced)."""
    return [dataclasses.replace(config, first_run=first, runs=min(size, config.first_run + config.runs - first))
            for first in range(config.first_run, config.first_run + config.runs, size)]


#: Snapshot labels kept of runs without frames: the end of the run (Fig 6-9).
KEPT_LABELS = ("end",)


def _tables_of(config: Any) -> dict[str, pd.DataFrame]:
    """The tables of one chunk the figures read (module level: it runs in worker processes):
    summary, timeseries and :data:`RECORDS` whole, the R-T trips (:func:`rt_trips`), and the
    snapshots (all of them with frames, else only :data:`KEPT_LABELS`)."""
    from .simulate import simulate

    tables = {name: table.to_pandas() for name, table in simulate(config).items()}
    snapshots = tables["snapshots"]
    if not config.frames:
        snapshots = snapshots[snapshots["label"].isin(KEPT_LABELS)].reset_index(drop=True)
    return {**tables, "trips": rt_trips(tables["trips"], config.tau), "snapshots": snapshots}


def run_chunks(configs: Iterable[Any], label: str, outcomes: Callable | None = None,
               done: dict | None = None) -> dict:
    """Simulate every chunk (:func:`chunks`) of ``configs`` not yet in ``done`` into ``done``
    (chunk -> its tables, :func:`_tables_of`); ``outcomes`` as :func:`run_configs` takes it;
    ``label`` names the batch in the progress line and in a failure (SweepError, one line)."""
    from ..console import progress

    done = {} if done is None else done
    todo = list(dict.fromkeys(chunk for config in configs for chunk in chunks(config) if chunk not in done))
    each = outcomes or (lambda function, items: ((item, function(item), None) for item in items))
    with progress(len(todo), "chunk", f"  lunar {label} chunks") as bar:
        for chunk, result, error in each(_tables_of, todo):
            if error is not None:
                raise SweepError(f"lunar {label}: layout {chunk.layout}, battery {chunk.battery_wh:g} Wh, "
                                 f"runs {chunk.first_run}..{chunk.first_run + chunk.runs - 1}: {error}")
            done[chunk] = result
            bar.update()
    return done


def run_configs(configs: Iterable[Any], experiment: str, outcomes: Callable | None = None,
                done: dict | None = None) -> dict[str, pd.DataFrame]:
    """Every run of every configuration of ``experiment`` as the tables :data:`TABLES`.

    Parameters
    ----------
    configs : sequence of LunarParams (the runs of a sweep: ``run.config``)
        Each one a condition; its runs are simulated in chunks of :data:`CHUNK_RUNS`.
    experiment : str
        Its name, the tables' ``experiment`` column.
    outcomes : callable, optional
        ``outcomes(function, items)`` yields ``(item, result, error)`` as each is done
        (:meth:`dronefleet.contract.StudyContext.map`); None: one after the other here.
    done : dict, optional
        Tables by chunk already simulated (not run again), filled with those run here.

    Returns
    -------
    dict of pandas.DataFrame
        ``summary``, ``timeseries``, ``trips`` (R-T only), ``snapshots`` and :data:`RECORDS`: the
        simulator's columns after :data:`CONDITION_COLUMNS`, in the order of ``configs`` then run.
        SweepError (one line) if a chunk fails or two configurations of one condition hold
        the same run index.
    """
    configs = list(configs)
    done = run_chunks(configs, experiment, outcomes, done)
    out = {}
    for name in TABLES:
        frames = []
        for config in configs:
            head = condition_row(config, experiment)
            for chunk in chunks(config):
                table = done[chunk][name]
                frames.append(pd.concat([pd.DataFrame({k: np.repeat(v, len(table)) for k, v in head.items()}),
                                         table.drop(columns=[c for c in head if c in table.columns])], axis=1))
        out[name] = pd.concat(frames, ignore_index=True)
    twice = out["summary"].duplicated(["condition", "run"])
    if twice.any():
        row = out["summary"][twice].iloc[0]
        raise SweepError(f"lunar {experiment}: condition {row['condition']!r} holds run {row['run']} twice: "
                         "its configurations must hold distinct runs (first_run, runs)")
    return out
