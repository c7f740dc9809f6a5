"""``dronefleet reproduce lunar-fig03 .. lunar-fig11 lunar-control lunar-e4 lunar-e5 lunar-verdicts``: the lunar
study's tables, drawings and check.

The scenario's ``study()`` hook (:class:`dronefleet.contract.FigureStudy`), run with the
:class:`~dronefleet.contract.StudyContext` of ``dronefleet reproduce`` (it reads the sweep files,
runs on its processes, reads and writes the tables: this package sits below them). Experiments
(spec LUNAR-FORAGING.md section 14): E1-E3, E5 and the eps = 1 control are the sweep files
``configs/sweeps/lunar-<experiment>.toml`` (:data:`SOURCES`: which conditions each figure draws);
E0 (Figs 6-3 to 6-6) is one SOFT-RT run with frames, :data:`E0`, defined here; E4 (the
sensitivity, ``lunar-e4``: per-run summaries only) is :mod:`dronefleet.lunar.sensitivity`; the
verdicts of the thesis's claims (``lunar-verdicts``: E1-E3 under the defaults and the thesis
reading) are :mod:`dronefleet.lunar.verdicts`.

Each figure writes under ``<out>/<figure>/`` its raw tables, one row per run (``runs``: the
summary, with :data:`~dronefleet.lunar.experiments.CONDITION_COLUMNS` and whether the run is
one of the selected 30), per run and record (``timeseries``), per R-T trip (``trips``) or per
robot of a snapshot (``snapshots``); ``lunar-fig08`` also the simulator's records of E1 and E2,
:data:`~dronefleet.lunar.experiments.RECORDS` (deaths and recharging interruptions may be none:
:data:`MAY_BE_EMPTY`), then what it draws, derived from them alone by
:mod:`dronefleet.lunar.experiments` (``curves``, ``bins``, ``stats``, ``median``,
``highlighted``), then its files (PNG, PDF, SVG). ``--check`` derives the second kind again
from the first and compares every value, and re-runs :data:`CHECK_RUNS` runs of each figure
and compares their rows of the first kind value for value.

``--quick``: every condition with :data:`QUICK_CHANGES` (5 runs of 600 s; the 3 with most
resources kept), E0 600 s.
"""

from __future__ import annotations

import dataclasses
import time
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pyarrow as pa

from ..config import SweepError
from ..contract import StudyContext, check_configurations, check_experiments
from . import experiments, sensitivity, verdicts
from .experiments import CURVE_METRICS, TRIP_METRICS
from .simulate import table_schemas

TITLE = ("beacon-guided foraging with recharging on the Moon (Angyal 2024), Figs 6-3 to 6-11, the eps = 1 "
         "control, the sensitivity E4, the Ch 4 baseline E5 and the verdicts of the thesis's claims "
         "(docs/guide/lunar.md)")
E0_FIGURES = ("lunar-fig03", "lunar-fig04", "lunar-fig05", "lunar-fig06")
FIGURES = (*E0_FIGURES, "lunar-fig07", "lunar-fig08", "lunar-fig09", "lunar-fig11", "lunar-control",
           sensitivity.FIGURE, "lunar-e5", verdicts.FIGURE)
#: --quick: every condition with fewer, shorter runs (E0 shorter).
QUICK_CHANGES = {"runs": 5, "duration_s": 600.0}
QUICK = (f"{QUICK_CHANGES['runs']} runs of {QUICK_CHANGES['duration_s']:g} s per condition "
         f"(the {experiments.selected_count(QUICK_CHANGES['runs'])} with most resources kept)")
#: E0 (section 14): one SOFT-RT run at the defaults with frames (Figs 6-3 to 6-6), one every 10 ticks
#: (0.8 m of driving: the paths of Figs 6-5, 6-6 follow the robots' turns). Every tick would be 2.8e6
#: snapshot rows, beyond the limit (keys.RUN_LIMITS); this is 2.8e5.
E0 = {"layout": "SOFT-RT", "runs": 1, "first_run": 0, "frames": True, "frame_every_s": 0.64}
#: The snapshot labels each E0 figure draws (Fig 6-4's panels in order).
E0_LABELS = {"lunar-fig03": ("end",), "lunar-fig04": ("first_T", "first_R", "first_row5")}
#: Figs 6-5 and 6-6: the time of the snapshot as a fraction of T_run (at most: :func:`_exploitation_time`),
#: and the window of the paths [s]
#: (about 37 m of driving at v0, three times across the field: a longer one is a tangle of paths).
E0_EXPLOITATION = {"lunar-fig05": 0.5, "lunar-fig06": 1.0}
PATH_WINDOW_S = 30.0
#: Per figure: experiment -> the conditions it draws of it (None: all of the sweep's).
SOURCES: dict[str, dict[str, tuple[str, ...] | None]] = {
    "lunar-fig07": {"e1": None},
    "lunar-fig08": {"e1": None, "e2": None},
    "lunar-fig09": {"e1": ("SOFT-RT",), "e2": None},
    "lunar-fig11": {"e1": ("HARD-RT", "SOFT-RT"), "e3": None},
    "lunar-control": {"e1": None, "eps1": None},
    "lunar-e5": {"e1": ("OPEN", "HARD-RT"), "e5": None},
}
#: The experiments each figure's tables may name.
EXPERIMENTS_OF = {**dict.fromkeys(E0_FIGURES, ("e0",)), **SOURCES, sensitivity.FIGURE: ("e4",)}
#: What each figure draws: the conditions in legend order.
ORDER = {
    "lunar-fig07": ("OPEN", "HARD-RT", "SOFT-RT"),
    "lunar-fig08": ("SOFT-RT 7.5 Wh", "SOFT-RT", "SOFT-RT 12.5 Wh", "OPEN", "HARD-RT"),
    "lunar-fig09": ("SOFT-RT 7.5 Wh", "SOFT-RT", "SOFT-RT 12.5 Wh"),
    "lunar-control": ("OPEN", "HARD-RT", "SOFT-RT"),
    "lunar-e5": ("OPEN", "HARD-RT"),
}
#: lunar-e5: the condition word of the Ch 4 baseline and the legends' words for the two models.
BASELINE = ("baseline", ("full model", "Ch 4 baseline"))
#: Fig 6-7's panels (a)-(e) and the alignment diagnostic's.
FIG07_METRICS = ("resources", "interruptions", "rate", "n_mobile", "soc_sum")
ALIGNMENT_METRICS = ("alignment_T", "alignment_N", "alignment_R")
#: The raw tables of each figure (the derived ones are computed from these).
RAW = {**dict.fromkeys(E0_FIGURES, ("runs", "snapshots")), "lunar-fig07": ("runs", "timeseries"),
       "lunar-fig08": ("runs", "trips", *experiments.RECORDS), "lunar-fig09": ("runs", "snapshots"),
       "lunar-fig11": ("runs", "timeseries"), "lunar-control": ("runs", "timeseries"),
       "lunar-e5": ("runs", "timeseries"), sensitivity.FIGURE: ("runs_by_change",),
       verdicts.FIGURE: ()}
#: Runs ``--check`` simulates again per figure (E1-E3: the best and the last of the first condition of
#: the table, and the best of the last; E0: its run).
CHECK_RUNS = 3

_CONDITION = {"experiment": "text", "condition": "text", "layout": "text", "layout_scale": "key",
              "battery_wh": "key", "eps": "key", "v0": "key"}
_SNAPSHOT = {"run": "count", "label": "text", "t": "number", "robot": "count", "status": "text", "role": "text",
             "mode": "text", "x": "number", "y": "number", "heading": "number", "soc": "number", "load": "count",
             **{f"{name}_{key}": "number" for name in ("omega", "vx", "vy", "S") for key in "TNR"}}


def _kinds(schema: pa.Schema) -> dict[str, str]:
    """Each column of the simulator's table ``schema`` by the kind of its type."""
    return {field.name: "text" if pa.types.is_string(field.type) else "integer" if pa.types.is_integer(field.type)
            else "flag" if pa.types.is_boolean(field.type) else "number" for field in schema}


_RUNS = {**_kinds(table_schemas()["summary"]), **_CONDITION, "run": "count", "seed": "integer", "resources": "count",
         "selected": "flag"}
#: The columns of the figures' tables and their kinds (:data:`dronefleet.reproduce.KINDS`): every
#: column, so that each is checked (a runs table holds the simulator's whole summary).
TABLE_COLUMNS = {
    "runs": _RUNS,
    "timeseries": {**_CONDITION, "run": "count", "t": "number", **dict.fromkeys(CURVE_METRICS, "number")},
    "trips": {**_CONDITION, "run": "count", "origin": "text", "dest": "text", "t_entered": "number",
              **dict.fromkeys(TRIP_METRICS, "number")},
    "snapshots": {**_CONDITION, **_SNAPSHOT},
    **{name: {**_CONDITION, **_kinds(table_schemas()[name]), "run": "count",
              **({"region": "text_or_null"} if name == "deaths" else {})}  # null: a death outside every region
       for name in experiments.RECORDS},
    "curves": {"condition": "text", "selection": "text", "metric": "text", "t": "number", "mean": "number",
               "sd": "number", "runs": "count"},
    "bins": {"condition": "text", "selection": "text", "metric": "text", "bin_start_s": "number", "mean": "number",
             "sd": "number", "trips": "count"},
    "stats": {"condition": "text", "selection": "text", "column": "text", "mean": "number", "sd": "number",
              "runs": "count"},
    "median": {"condition": "text", "run": "count", "resources": "count"},
    "highlighted": {"robot": "count", "role": "text"},
    "runs_by_change": {"change": "text", **_RUNS},
    "effects": {"change": "text", "condition": "text", "metric": "text", "default_mean": "number", "mean": "number",
                "effect": "number", "se": "number", "runs": "count"},
    "verdicts": {"claim": "text", **{f"{what}_{reading}": "text" for reading in verdicts.READINGS
                                     for what in ("verdict", "numbers")}},
}
#: The tables that may hold no rows: runs without deaths or recharging interruptions (--quick's short runs).
MAY_BE_EMPTY = ("deaths", "recharge_triggers")
#: The derived tables of each figure.
DERIVED = {"lunar-fig05": ("highlighted",), "lunar-fig06": ("highlighted",), "lunar-fig07": ("curves", "stats"),
           "lunar-fig08": ("bins",), "lunar-fig09": ("median",), "lunar-fig11": ("curves",),
           "lunar-control": ("curves", "stats"), "lunar-e5": ("curves", "stats"), sensitivity.FIGURE: ("effects",),
           verdicts.FIGURE: ("verdicts",)}


def _with_v0(frame: pd.DataFrame, configs: dict) -> pd.DataFrame:
    """``frame`` with the ``v0`` of its condition's config after the condition columns (the
    snapshots' vectors are drawn relative to it)."""
    # float also for a frame without rows (a table of deaths may hold none), whose map has no values to type it
    v0 = frame["condition"].map({condition: config.v0 for condition, config in configs.items()}).astype(np.float64)
    at = list(frame.columns).index("eps") + 1
    return pd.concat([frame.iloc[:, :at], v0.rename("v0"), frame.iloc[:, at:]], axis=1)


def grid(study: StudyContext, experiment: str) -> list:
    """The configurations of ``configs/sweeps/lunar-<experiment>.toml`` (with --quick: :data:`QUICK_CHANGES`)."""
    sweep = study.load_sweep(experiments.grid_path(experiment), QUICK_CHANGES if study.quick else None)
    return [run.config for run in sweep.runs]


def e0_config(quick: bool) -> Any:
    """E0's configuration: the defaults with :data:`E0` (and --quick's duration)."""
    from .params import LunarParams

    changes = {**E0, **({"duration_s": QUICK_CHANGES["duration_s"]} if quick else {})}
    return LunarParams(**changes)


def _memo(study: StudyContext) -> dict:
    return study.memo.setdefault("lunar", {"done": {}, "tables": {}})


def run_together(study: StudyContext, figures: list[str]) -> None:
    """Run every chunk of the experiments ``figures`` need as one batch (one set of worker processes,
    each experiment once: E1 feeds Figs 6-7, 6-8, 6-9, 6-11 and the control)."""
    needed = list(dict.fromkeys(e for figure in figures for e in SOURCES.get(figure, {})))
    configs = [config for experiment in needed for config in grid(study, experiment)]
    if any(figure in E0_FIGURES for figure in figures):
        needed.append("e0")
        configs.append(e0_config(study.quick))
    if not configs:
        return
    start = time.perf_counter()
    experiments.run_chunks(configs, "+".join(needed), study.map, _memo(study)["done"])
    study.log(f"lunar experiments {', '.join(needed)}: {len(configs)} configurations in "
              f"{time.perf_counter() - start:.1f} s")


def experiment_tables(study: StudyContext, experiment: str) -> dict[str, pd.DataFrame]:
    """Every run of ``experiment`` ("e0" or one of the sweeps) as its four tables (run once per call),
    each with the ``v0`` column."""
    memo = _memo(study)
    if experiment not in memo["tables"]:
        configs = [e0_config(study.quick)] if experiment == "e0" else grid(study, experiment)
        start = time.perf_counter()
        tables = experiments.run_configs(configs, experiment, study.map, done=memo["done"])
        by_condition = {experiments.condition_row(c, experiment)["condition"]: c for c in configs}
        memo["tables"][experiment] = {name: _with_v0(table, by_condition) for name, table in tables.items()}
        study.log(f"  {experiment}: {len(configs)} configurations; {time.perf_counter() - start:.1f} s")
    return memo["tables"][experiment]


def _gather(study: StudyContext, figure: str, name: str) -> pd.DataFrame:
    """The ``name`` table of every condition ``figure`` draws (:data:`SOURCES`)."""
    frames = []
    for experiment, conditions in SOURCES[figure].items():
        table = experiment_tables(study, experiment)[name]
        frames.append(table if conditions is None else table[table["condition"].isin(conditions)])
    return pd.concat(frames, ignore_index=True)


def _runs_table(summary: pd.DataFrame) -> pd.DataFrame:
    return summary.assign(selected=experiments.selected(summary).to_numpy())


def _columns(frame: pd.DataFrame, name: str) -> pd.DataFrame:
    """``frame`` with the columns of the figures' table ``name`` (:data:`TABLE_COLUMNS`), in their order."""
    return frame[[*TABLE_COLUMNS[name]]]


def _e0_snapshots(snapshots: pd.DataFrame, figure: str) -> pd.DataFrame:
    """The snapshot rows an E0 figure draws: its labels, or (Figs 6-5, 6-6) the frames of its window."""
    if figure in E0_LABELS:
        return snapshots[snapshots["label"].isin(E0_LABELS[figure])].reset_index(drop=True)
    frames = snapshots[snapshots["label"] == "frame"]
    t_end = _exploitation_time(frames, figure)
    return frames[(frames["t"] > t_end - PATH_WINDOW_S - 1e-9) & (frames["t"] <= t_end + 1e-9)].reset_index(drop=True)


def _exploitation_time(frames: pd.DataFrame, figure: str) -> float:
    """The frame time of Fig 6-5 / 6-6: the last frame at or before the figure's share of the run
    whose window (:data:`PATH_WINDOW_S`) shows a robot driving in each highlighted role, as the
    thesis's does (L1061; robots recharge for minutes, so a window may hold none in role R);
    without one, the last frame at or before the share."""
    times = np.sort(frames["t"].unique())
    ends = times[times <= E0_EXPLOITATION[figure] * times[-1] + 1e-9]
    steps = experiments.drives(frames).sort_values("t_to", kind="mergesort")
    shown = np.ones(len(ends), dtype=bool)
    for role in experiments.HIGHLIGHTED_ROLES:
        mine = steps[steps["role"] == role]
        if not len(mine):
            shown[:] = False
            continue
        # per end: the latest start of a step of this role that ended by then (a running maximum)
        latest = np.maximum.accumulate(mine["t_from"].to_numpy())
        last = np.searchsorted(mine["t_to"].to_numpy(), ends + 1e-9, side="right") - 1
        shown &= (last >= 0) & (latest[np.maximum(last, 0)] > ends - PATH_WINDOW_S - 1e-9)
    return float(ends[shown][-1] if shown.any() else ends[-1])


def derive(figure: str, tables: dict[str, pd.DataFrame]) -> dict[str, pd.DataFrame]:
    """The derived tables of ``figure`` (:data:`DERIVED`) from its raw ``tables``."""
    runs = tables["runs"]
    if figure in ("lunar-fig05", "lunar-fig06"):
        frames = tables["snapshots"]
        t_end = float(frames["t"].max())
        return {"highlighted": experiments.highlighted(frames, t_end, PATH_WINDOW_S)}
    if figure in ("lunar-fig07", "lunar-fig11", "lunar-control", "lunar-e5"):
        out = {"curves": experiments.curves(tables["timeseries"], runs)}
        if figure != "lunar-fig11":
            out["stats"] = experiments.run_stats(runs)
        return out
    if figure == "lunar-fig08":
        return {"bins": experiments.trip_bins(tables["trips"], runs)}
    if figure == "lunar-fig09":
        return {"median": experiments.median_runs(runs)}
    return {}


def tidy(study: StudyContext, figure: str) -> None:
    """Run (or take from this call's memo) the figure's experiments; write its raw and derived tables."""
    if figure == sensitivity.FIGURE:
        return sensitivity.tidy(study, grid(study, "e4"))
    if figure == verdicts.FIGURE:
        return verdicts.tidy(study, _reading_configs(study))
    d = study.figure_dir(figure)
    if figure in E0_FIGURES:
        tables = experiment_tables(study, "e0")
        raw = {"runs": _runs_table(tables["summary"]), "snapshots": _e0_snapshots(tables["snapshots"], figure)}
    else:
        runs = _runs_table(_gather(study, figure, "summary"))
        raw = {"runs": runs}
        if "timeseries" in RAW[figure]:
            raw["timeseries"] = _columns(_gather(study, figure, "timeseries"), "timeseries")
        if figure == "lunar-fig08":
            raw.update({name: _columns(_gather(study, figure, name), name) for name in ("trips", *experiments.RECORDS)})
        if figure == "lunar-fig09":
            medians = experiments.median_runs(runs)
            snapshots = _gather(study, figure, "snapshots")
            chosen = snapshots.merge(medians[["condition", "run"]], on=["condition", "run"], how="inner")
            raw["snapshots"] = chosen[chosen["label"] == "end"].reset_index(drop=True)
    for name, table in {**raw, **derive(figure, raw)}.items():
        study.write_table(table, d / f"{name}.parquet")


#: The most conditions (configurations) a figure's table may hold (lunar-control draws 6).
MAX_CONDITIONS = 100


def read_tables(study: StudyContext, figure: str, names) -> dict[str, pd.DataFrame]:
    """The figure's tables ``names``, their columns checked (``study.read_table``), their
    experiments the figure's (:data:`SOURCES`; E0's figures: ``e0``), and the
    configuration values of each condition (layout, battery, ...) held to a config file's rules,
    so that a tampered table is one line naming the file and the value before anything is drawn or run."""
    from .keys import KEYS, checked

    tables = {name: study.read_table(figure, name) for name in names}
    for name, table in tables.items():
        if "experiment" in table.columns:
            check_experiments(table, study.root / figure / f"{name}.parquet",
                              EXPERIMENTS_OF[figure])
        if "change" in table.columns:
            sensitivity.check_changes(table, study.root / figure / f"{name}.parquet", grid(study, "e4"))
        keys = [column for column in _CONDITION if column in KEYS and column in table.columns]
        if keys:
            check_configurations(table, keys, study.root / figure / f"{name}.parquet", MAX_CONDITIONS, checked,
                                 lambda values: ", ".join(f"{k}={v!r}" for k, v in values.items()))
    return tables


def _geometry(rows: pd.DataFrame) -> Any:
    """The layout of the condition of ``rows`` (its first row's layout and layout_scale)."""
    from .layout import build
    from .params import LunarParams

    first = rows.iloc[0]
    return build(LunarParams(layout=str(first["layout"]), layout_scale=float(first["layout_scale"])))


def draw(study: StudyContext, figure: str) -> list[Path]:
    """The figure's files (PNG, PDF, SVG) from its tables alone."""
    from . import figures

    d = study.root / figure
    tables = read_tables(study, figure, RAW[figure] + DERIVED.get(figure, ()))
    if figure == sensitivity.FIGURE:
        return sensitivity.draw(tables, d / figure)
    if figure == verdicts.FIGURE:
        return verdicts.draw(tables["verdicts"], d / figure)
    if figure in E0_FIGURES:
        snapshots = tables["snapshots"]
        geometry, v0 = _geometry(snapshots if len(snapshots) else tables["runs"]), float(tables["runs"]["v0"].iloc[0])
        if figure == "lunar-fig03":
            return figures.snapshot(snapshots, geometry, v0, d / figure)
        if figure == "lunar-fig04":
            words = {"first_T": "first entry into T", "first_R": "first entry into R",
                     "first_row5": "first recharged robot\nheads to N"}  # row 5: no path to R yet
            found = {words[label]: (snapshots[snapshots["label"] == label] if (snapshots["label"] == label).any()
                                    else None) for label in E0_LABELS[figure]}
            return figures.panels(found, geometry, v0, d / figure)
        highlighted = tables["highlighted"]
        return figures.exploitation(snapshots, dict(zip(highlighted["robot"].tolist(), highlighted["role"].tolist())),
                                    float(snapshots["t"].max()), PATH_WINDOW_S, geometry, v0, d / figure)
    if figure == "lunar-fig07":
        curves = tables["curves"][tables["curves"]["selection"] == "selected"]
        return (figures.time_curves(curves, FIG07_METRICS, ORDER[figure], d / figure)
                + figures.time_curves(curves, ALIGNMENT_METRICS, ORDER[figure], d / f"{figure}-alignment"))
    if figure == "lunar-fig08":
        bins = tables["bins"][tables["bins"]["selection"] == "selected"]
        return figures.trip_curves(bins, [c for c in ORDER[figure] if c in set(bins["condition"])],
                                   experiments.BIN_S, d / figure)
    if figure == "lunar-fig09":
        snapshots = tables["snapshots"]
        found = {}
        for condition in ORDER[figure]:
            mine = snapshots[snapshots["condition"] == condition]
            if len(mine):
                found[f"{condition if ' Wh' in condition else condition + ' 10 Wh'}, run {mine['run'].iloc[0]}"] = mine
        geometry = {name: _geometry(rows) for name, rows in found.items()}
        return figures.panels(found, geometry, float(snapshots["v0"].iloc[0]), d / figure)
    if figure == "lunar-fig11":
        return figures.placement(tables["curves"][tables["curves"]["selection"] == "selected"], d / figure)
    curves = tables["curves"][tables["curves"]["selection"] == "selected"]
    stats = tables["stats"][tables["stats"]["selection"] == "selected"]
    if figure == "lunar-e5":
        return figures.control(curves, stats, ORDER[figure], d / figure, *BASELINE)
    return figures.control(curves, stats, ORDER[figure], d / figure)


def _missing(value) -> bool:
    """NaN or null (a text column's null reads back as None, and a fresh one is NaN in pandas)."""
    return value is None or value != value


def _same(a, b):
    return a == b or (_missing(a) and _missing(b))


def _differ(figure: str, label: str, old: pd.DataFrame, new: pd.DataFrame) -> list[str]:
    """One line per value of ``old`` that is not ``new``'s (the same columns, rows in the same order)."""
    if len(old) != len(new):
        return [f"{figure} {label}: {len(old)} rows committed, {len(new)} re-derived"]
    lines = []
    for column in old.columns:
        if column not in new.columns:
            lines.append(f"{figure} {label}: column {column} committed, not re-derived")
            continue
        lines += [f"{figure} {label} row {i}: {column} committed {o!r}, re-derived {n!r}"
                  for i, (o, n) in enumerate(zip(old[column].tolist(), new[column].tolist())) if not _same(o, n)]
    return lines


def _sorted(table: pd.DataFrame, keys) -> pd.DataFrame:
    return table.sort_values(list(keys), kind="mergesort").reset_index(drop=True)


def _check_runs(runs: pd.DataFrame) -> list[tuple[str, str, int]]:
    """The (experiment, condition, run)s ``--check`` simulates again: the best and the last-ranked
    run of the table's first condition and the best of its last (distinct ones)."""
    order = runs.sort_values(["resources", "run"], ascending=[False, True], kind="mergesort")
    conditions = list(dict.fromkeys(runs["condition"]))
    first = order[order["condition"] == conditions[0]]
    last = order[order["condition"] == conditions[-1]]
    picked = [first.iloc[0], first.iloc[-1], last.iloc[0]]
    found = list(dict.fromkeys((str(r["experiment"]), str(r["condition"]), int(r["run"])) for r in picked))
    return found[:CHECK_RUNS]


def _config_of(study: StudyContext, experiment: str, condition: str, run: int, where: Path) -> Any:
    """The configuration of one run of ``condition`` of ``experiment``: its sweep's (E0: :data:`E0`),
    holding only ``run``."""
    configs = [e0_config(study.quick)] if experiment == "e0" else grid(study, experiment)
    for config in configs:
        if (experiments.condition_row(config, experiment)["condition"] == condition
                and config.first_run <= run < config.first_run + config.runs):
            return dataclasses.replace(config, first_run=run, runs=1)
    raise SweepError(f"{where}: run {run} of {condition!r} is not in "
                     f"{'E0' if experiment == 'e0' else experiments.grid_path(experiment)}"
                     f"{' (--quick)' if study.quick else ''}")


def check(study: StudyContext, figure: str) -> list[str]:
    """Derive the figure's derived tables again from its raw ones, and simulate :data:`CHECK_RUNS`
    of its runs again; compare every value with the committed tables. The differences, one line each."""
    d = study.root / figure
    raw = d / f"{(RAW[figure] or DERIVED[figure])[0]}.parquet"
    if not raw.exists():
        raise SweepError(f"{raw} is missing: run dronefleet reproduce {figure}"
                         f"{' --quick' if study.quick else ''} first (it writes the table that --check compares with)")
    tables = read_tables(study, figure, RAW[figure] + DERIVED.get(figure, ()))
    if figure == sensitivity.FIGURE:
        return _check_e4(study, tables)
    if figure == verdicts.FIGURE:
        return _check_verdicts(study, tables)
    runs = tables["runs"]
    differences = _differ(figure, "runs", runs[["selected"]],
                          pd.DataFrame({"selected": experiments.selected(runs).to_numpy()}))
    for name, table in derive(figure, tables).items():
        differences += _differ(figure, name, tables[name], table)
    study.log(f"{figure}: derived tables {'identical' if not differences else f'{len(differences)} values differ'}")
    for experiment, condition, run in _check_runs(runs):
        label = f"{condition} run {run}"
        config = _config_of(study, experiment, condition, run, d / "runs.parquet")
        fresh = {name: _with_v0(table, {condition: config})
                 for name, table in experiments.run_configs([config], experiment).items()}
        found = []
        mine = runs[(runs["condition"] == condition) & (runs["run"] == run)]
        found += _differ(figure, f"{label} summary", mine.drop(columns=["selected"]).reset_index(drop=True),
                         fresh["summary"])
        if "timeseries" in tables:
            old = tables["timeseries"]
            found += _differ(figure, f"{label} timeseries",
                             _sorted(old[(old["condition"] == condition) & (old["run"] == run)], ["t"]),
                             _sorted(_columns(fresh["timeseries"], "timeseries"), ["t"]))
        for name in ("trips", *experiments.RECORDS):  # in the simulator's order of records
            if name in tables:
                old = tables[name]
                found += _differ(figure, f"{label} {name}", old[(old["condition"] == condition) & (old["run"] == run)]
                                 .reset_index(drop=True), _columns(fresh[name], name))
        study.log(f"  {label}: {'identical' if not found else f'{len(found)} values differ'}")
        differences += found
    if "snapshots" in tables:
        differences += _check_snapshots(study, figure, tables)
    return differences


def _check_e4(study: StudyContext, tables: dict[str, pd.DataFrame]) -> list[str]:
    """lunar-e4's --check: ``effects`` derived again from ``runs``, and the runs of
    :func:`dronefleet.lunar.sensitivity.rerun` simulated again."""
    figure = sensitivity.FIGURE
    runs = tables["runs_by_change"]
    differences = _differ(figure, "effects", tables["effects"], sensitivity.effects(runs))
    study.log(f"{figure}: derived tables {'identical' if not differences else f'{len(differences)} values differ'}")
    for label, old, fresh in sensitivity.rerun(runs, grid(study, "e4")):
        found = _differ(figure, f"{label} summary", old, fresh)
        study.log(f"  {label}: {'identical' if not found else f'{len(found)} values differ'}")
        differences += found
    return differences


def _reading_configs(study: StudyContext) -> dict[str, list]:
    """lunar-verdicts' configurations per reading (with --quick: :data:`QUICK_CHANGES`)."""
    return verdicts.reading_configs(QUICK_CHANGES if study.quick else None)


def _check_verdicts(study: StudyContext, tables: dict[str, pd.DataFrame]) -> list[str]:
    """lunar-verdicts' --check: E1-E3 run again under each reading, their verdicts and numbers
    compared with the committed ones."""
    figure = verdicts.FIGURE
    differences = _differ(figure, "verdicts", tables["verdicts"], verdicts.measure(study, _reading_configs(study)))
    study.log(f"{figure}: verdicts {'identical' if not differences else f'{len(differences)} values differ'}")
    return differences

def _check_snapshots(study: StudyContext, figure: str, tables: dict[str, pd.DataFrame]) -> list[str]:
    """The snapshot rows of each run of the figure's snapshots table, simulated again."""
    old = tables["snapshots"]
    found = []
    for (experiment, condition, run), rows in old.groupby(["experiment", "condition", "run"], sort=True):
        config = _config_of(study, experiment, condition, int(run), study.root / figure / "snapshots.parquet")
        fresh = _with_v0(experiments.run_configs([config], experiment)["snapshots"], {condition: config})
        fresh = (_e0_snapshots(fresh, figure) if figure in E0_FIGURES
                 else fresh[fresh["label"] == "end"].reset_index(drop=True))
        keys = ["label", "t", "robot"]
        found += _differ(figure, f"{condition} run {run} snapshots", _sorted(rows, keys), _sorted(fresh, keys))
    study.log(f"  snapshots: {'identical' if not found else f'{len(found)} values differ'}")
    return found
