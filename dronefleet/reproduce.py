"""Reproduce the studies' figures (Figures 16-20: docs/delivery-experiments.md; 9-12: docs/replenishment-model.md).

``dronefleet reproduce FIGURE... [--quick] [--jobs J] [--out DIR | --update-results] [--redraw | --check]
[--theta N]``, FIGURE one or more of fig09..fig12, fig16..fig20 (and any other study's: ``dronefleet
reproduce --list``), or ``all``. A study is the delivery deliverable's, here (:data:`DELIVERABLE`),
or the ``study()`` hook of a registered scenario (:class:`dronefleet.contract.FigureStudy`), run
with a :class:`Study` as its :class:`~dronefleet.contract.StudyContext`: see :func:`studies`.
Figures 9-12 (energy replenishment) run their grid ``configs/sweeps/replenishment-figNN.toml``
whole (seconds) into ``runs.parquet`` (one row per trial) and ``bounds.parquet``: see
:mod:`dronefleet.replenishment.study`. Each delivery figure needs one or more sweeps of ``configs/sweeps/``:

==========  ==================================================================
sweep       runs (``--quick``: seeds 0-1, 2 weeks)
==========  ==================================================================
rules       least_confident, most_confident, random x 6 tau x 20 seeds (16-19)
thresholds  threshold(theta), 6 theta x 6 tau x 20 seeds (19)
reservations  from the rules sweep's least_confident fleets at tau 15: without and
            with reservation bids, 20 seeds, 8 more weeks (20)
==========  ==================================================================

Everything is written under one results root, ``<out>``: ``--out DIR``, by default
:data:`DEFAULT_OUT` (``dronefleet-results/`` in the working directory), never the committed
``results/`` unless ``--update-results`` names it (:data:`COMMITTED_RESULTS`, the
repository's ``results/``: run from the repository's root). Sweeps run through
:mod:`dronefleet.sweeps` into ``<out>/<sweep>/`` (runs already there are reused, so figures
sharing a sweep run it once, and ``dronefleet sweep run --results <out>`` or a SLURM job
array can fill it beforehand). Each figure then writes its tidy tables to
``<out>/<figure>/*.parquet`` and draws its files (PNG, PDF and SVG,
:data:`dronefleet.figstyle.FORMATS`) beside them from those tables alone, so ``--redraw``
redraws ``<out>``'s figures without simulating or reading a sweep (``--update-results
--redraw``: the committed ones). ``--quick`` writes under ``<out>/quick/``. Figure 19 sets
beside learning the threshold(theta) that the study's criterion picks
(:func:`dronefleet.delivery.analysis.threshold_table`), or the one ``--theta`` names.

Every figure also writes ``<out>/<figure>/runs.parquet``: one row per run it is drawn
from, with its sweep, its run id (``rule=random,tau_minutes=25.0,seed=3``), its grid values
and seed and its whole ``summary``. ``--check`` re-runs a few of those runs
(:data:`CHECK_RUNS`) in a temporary directory, in this process, and compares every value
of their summaries with the table: the committed numbers re-derive exactly, or the
command lists what differs (exit 1). It only reads: the committed ``results/`` unless
``--out`` names another root.
"""

import argparse
import logging
import os
import tempfile
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

from . import console, executors, scenarios
from .config import ConfigError, shipped_config
from .contract import FigureStudy, study_problems
from .datafiles import ColumnType, DataError, checked_column, parquet_rows, parquet_schema, read_parquet
from .delivery import analysis
from .outputs import probe_folders, writing
from .replenishment import study as replenishment
from .provenance import stamp
from .records import write_atomic
from .sweeps import (Progress, Run, Sweep, SweepError, available_cpus, dataset, done_runs, load_sweep, rows,
                     run_sweep)

log = logging.getLogger(__name__)

#: Where reproduce writes unless told otherwise: beside, never over, the committed results.
DEFAULT_OUT = Path("dronefleet-results")
#: The committed figures and tables: only --update-results writes there, --check reads them.
COMMITTED_RESULTS = Path("results")
REPLENISHMENT_FIGURES = replenishment.FIGURES
DELIVERY_FIGURES = ("fig16", "fig17", "fig18", "fig19", "fig20")
#: The sweeps each delivery figure reads.
NEEDS = {"fig16": ("rules",), "fig17": ("rules",), "fig18": ("rules",), "fig19": ("rules", "thresholds"),
         "fig20": ("rules", "reservations")}
#: What --quick changes in every sweep: few seeds, a short horizon.
QUICK_SEEDS = (0, 1)
QUICK_CHANGES = {"horizon_weeks": 2.0}
#: Where Figures 17, 18 and 20 take the least_confident fleets from.
LEARNING_TAU = 15.0
#: The runs `--check` re-runs for each figure, as (sweep, run id), spread over the grid and
#: the seeds. Those of seeds 0-1 are in --quick's tables too; the others are skipped there.
CHECK_RUNS = {
    "fig16": (("rules", "rule=least_confident,tau_minutes=15.0,seed=0"),
              ("rules", "rule=random,tau_minutes=25.0,seed=3"),
              ("rules", "rule=most_confident,tau_minutes=40.0,seed=7")),
    "fig17": (("rules", "rule=most_confident,tau_minutes=15.0,seed=1"),
              ("rules", "rule=random,tau_minutes=15.0,seed=12")),
    "fig18": (("rules", "rule=least_confident,tau_minutes=15.0,seed=0"),
              ("rules", "rule=least_confident,tau_minutes=15.0,seed=19")),
    "fig19": (("thresholds", "tau_minutes=15.0,theta=70.0,seed=0"),
              ("thresholds", "tau_minutes=40.0,theta=100.0,seed=5"),
              ("rules", "rule=least_confident,tau_minutes=30.0,seed=1")),
    "fig20": (("reservations", "rule=reservation,seed=0"),
              ("reservations", "rule=least_confident,seed=4")),
    # Figures 9-12 (their study's): two configurations each (their column values), every trial re-run.
    **replenishment.CHECK_CONFIGS,
}


class Study:
    """The studies' sweeps under one results root: loaded (validated) once, run on demand; the
    :class:`~dronefleet.contract.StudyContext` of every study."""

    def __init__(self, results: str | os.PathLike, quick: bool = False, jobs: int | None = None,
                 log: Callable[[str], object] = log.info, theta: float | None = None) -> None:
        self.root = Path(results) / "quick" if quick else Path(results)
        self.quick = quick
        self.theta = theta      # Figure 19's threshold, %; None: the study's criterion picks it
        self.jobs = jobs or available_cpus()
        self.log = log
        self._sweeps = {}
        self._ensured = set()   # sweeps checked (and completed) by this study: figures share them
        self._done = {}         # sweep -> its done runs, found once (every file of every run inspected)
        self._datasets = {}     # (sweep, table) -> its dataset of done runs, opened once
        self.memo = {}          # results figures share within one reproduce call, by scenario

    def sweep(self, name: str) -> Sweep:
        """The sweep ``name``, with --quick's changes; the reservation sweep reads the rules sweep's fleets."""
        if name not in self._sweeps:
            changes = dict(QUICK_CHANGES) if self.quick else {}
            if name == "reservations":
                changes["fleet_file"] = str(self.fleet_template())
            path = shipped_config("sweeps", f"{name}.toml")
            log.debug(f"  sweep {name}: {path}")
            self._sweeps[name] = load_sweep(path, changes=changes, seeds=QUICK_SEEDS if self.quick else None)
        return self._sweeps[name]

    def out(self, name: str) -> Path:
        return self.root / self.sweep(name).name

    def fleet_template(self) -> Path:
        """The fleet files of the rules sweep's least_confident runs at tau 15, with ``{seed}``.

        Relative to the working directory, like the results root (and, for the committed
        root ``results/``, the very path of ``reservations.toml``, so both name the same runs).
        """
        rules = self.sweep("rules")
        run = next((r for r in rules.runs if r.config.rule == "least_confident"
                    and r.config.tau_minutes == LEARNING_TAU), None)
        if run is None:
            raise SweepError(f"{rules.path} has no least_confident runs at tau = {LEARNING_TAU:g} min, "
                             "whose learned fleets Figure 20 starts from")
        path = run.path(self.out("rules"), "fleet")
        return path.parent.parent / "seed={seed}" / path.name

    def ensure(self, name: str) -> None:
        """Run what is missing of sweep ``name`` (once per study); raise if any run failed."""
        if name in self._ensured:
            return
        sweep = self.sweep(name)
        out = self.out(name)
        start = time.perf_counter()
        ran, failures = run_sweep(sweep, out, sweep.runs, self.jobs, progress=Progress(sweep.scenario.replicate_noun))
        self.log(f"  sweep {sweep.name}: {sweep.describe()}; ran {ran} in {time.perf_counter() - start:.1f} s, "
                 f"{len(sweep.runs) - ran} reused")
        if failures:
            lines = "\n".join(f"    {run.partition}: {error}" for run, error in failures.items())
            raise SweepError(f"sweep {sweep.name}: {len(failures)} runs failed (dronefleet sweep status "
                             f"{sweep.path} --results {self.root}):\n{lines}")
        self._ensured.add(name)

    def ensure_runs(self, name: str, runs: Sequence[Run]) -> None:
        """Run those of ``runs`` (of sweep ``name``) that are not done; raise if any failed."""
        _, failures = run_sweep(self.sweep(name), self.out(name), runs, self.jobs)
        if failures:
            lines = "; ".join(f"{run.partition}: {error}" for run, error in failures.items())
            raise SweepError(f"sweep {name}: {len(failures)} runs failed: {lines}")

    def table(self, name: str, table: str, **where: Any) -> pd.DataFrame:
        """Table ``table`` of sweep ``name`` as pandas, with typed grid columns, filtered on ``where``."""
        import pyarrow.compute as pc

        if name not in self._done:  # reads every run's summary and the footers of its other files
            self._done[name] = done_runs(self.sweep(name), self.out(name))
        if (name, table) not in self._datasets:
            self._datasets[name, table] = dataset(self.sweep(name), self.out(name), table, self._done[name])
        data = self._datasets[name, table]
        condition = None
        for key, value in where.items():
            term = pc.field(key) == value
            condition = term if condition is None else condition & term
        return rows(self.sweep(name), self.out(name), table, data, condition).to_pandas()

    def horizon_s(self, name: str) -> float:
        return self.sweep(name).runs[0].config.horizon_s

    def figure_dir(self, figure: str) -> Path:
        path = self.root / figure
        with writing(path):
            path.mkdir(parents=True, exist_ok=True)
        return path

    def load_sweep(self, path: Path, changes: Mapping[str, Any] | None = None) -> Sweep:
        return load_sweep(path, changes=changes)

    def map(self, function: Callable, items: Iterable) -> executors.Outcomes:
        """``function`` over ``items`` on :attr:`jobs` local processes (:func:`dronefleet.executors.local`)."""
        return executors.local(function, items, self.jobs)

    def write_table(self, frame: pd.DataFrame, path: Path) -> Path:
        return _write_parquet(frame, path)

    def read_table(self, figure: str, name: str) -> pd.DataFrame:
        return _read(self, figure, name)


def _write_parquet(frame, path):
    table = stamp(pa.Table.from_pandas(frame, preserve_index=False))
    with writing(path):
        write_atomic(path, lambda tmp: pq.write_table(table, tmp))
    return path


def _write_runs(study, figure, *selections):
    """``<figure>/runs.parquet``: one row per run the figure is drawn from, for `--check`.

    ``selections`` are ``(sweep, {grid key: value})``: the runs of the sweep that match.
    Columns ``sweep``, ``run`` (the run id), then the runs' ``summary`` table with its
    partition columns (grid keys, seed; a key of another sweep is null).
    """
    frames = []
    for name, where in selections:
        runs = study.sweep(name).runs
        keys = list(runs[0].keys)
        run_id = {tuple(run.value(key) for key in keys): run.id for run in runs}
        summary = study.table(name, "summary", **where)
        ids = [run_id[point] for point in summary[keys].itertuples(index=False, name=None)]
        frames.append(pd.concat([pd.DataFrame({"sweep": name, "run": ids}), summary], axis=1))
    _write_parquet(pd.concat(frames, ignore_index=True), study.figure_dir(figure) / "runs.parquet")


def _read(study, figure, name):
    path = study.root / figure / f"{name}.parquet"
    if not path.exists():
        raise SweepError(f"{path} is missing: run dronefleet reproduce {figure} without --redraw first, "
                         "or redraw where its tables are (--out DIR; the committed ones: --update-results)")
    return _read_parquet(path, figure, name)


_TEXT = ColumnType("text", lambda arrow_type: pa.types.is_string(arrow_type) or pa.types.is_large_string(arrow_type))
_INTEGER = ColumnType("an integer", pa.types.is_integer)
_NUMBER = ColumnType("a number", lambda arrow_type: pa.types.is_integer(arrow_type) or pa.types.is_floating(arrow_type))
#: Any column type but a nested one (a list, struct or map): every value compares as one value.
flat = ColumnType("one value a row (not a list, struct or map)", lambda arrow_type: not pa.types.is_nested(arrow_type))


def _any(values):
    return np.full(len(values), True)


#: What the drawings and --check rely on in a column of the figures' tables: (its arrow type,
#: what each value must be, in words, and whether nulls are allowed).
KINDS = {
    "text": (_TEXT, _any, "text", False),
    "text_or_null": (_TEXT, _any, "text or null", True),
    "integer": (_INTEGER, _any, "an integer", False),
    "count": (_INTEGER, lambda x: x >= 0, "an integer >= 0", False),
    # a week of a run: runs are at most 1000 weeks long (delivery's horizon_weeks)
    "week": (_INTEGER, lambda x: (x >= 0) & (x <= 1000), "an integer in [0, 1000]", False),
    "key": (_NUMBER, np.isfinite, "a finite number", False),
    "number": (_NUMBER, lambda x: ~np.isinf(x), "a number, NaN or null (not infinite)", True),
    "flag": (ColumnType("true or false", pa.types.is_boolean), _any, "true or false", False),
}
#: The columns each delivery figure table must hold, and their kinds (:data:`KINDS`); other columns
#: are kept if they are not nested. ``runs`` is read by --check only. Other studies: their TABLE_COLUMNS.
TABLE_COLUMNS = {
    "outcomes": {"rule": "text", "tau_minutes": "key", "delivered": "count", "median_delivery_time_s": "number",
                 "aborted_pct": "number"},
    "backlog": {"rule": "text", "tau_minutes": "key", "arrival_week": "week", "backlog_age_s": "number"},
    "accuracy": {"rule": "text", "week": "week", "mean_accuracy": "number", "ci_low": "number",
                 "ci_high": "number", "confidence": "key"},
    "winner_soh": {"soc": "key", "distance_m": "key", "mass_kg": "key", "mean_winner_soh": "number"},
    "thresholds": {"theta": "key", "runs": "count", "delivered_mean": "number", "delivered_median": "number",
                   "median_delivery_time_s": "number", "aborted_pct_mean": "number", "pending_mean": "number",
                   "backlog_age_s_mean": "number", "best": "flag"},
    "pending": {"rule": "text", "seed": "integer", "arrival_week": "week", "pending": "count"},
    "runs": {"sweep": "text", "run": "text"},
}


#: The most rows a figure's table may hold, checked from its footer before it is read: ~10 times
#: the largest a built-in study writes (108,000: lunar-fig11's time series), and still read whole
#: in well under 4 GiB of address space.
MAX_TABLE_ROWS = 1_000_000
#: Columns whose values name at most one row of a table (a heatmap cell: its SoC, mass and distance).
UNIQUE_KEYS = {"winner_soh": ("soc", "mass_kg", "distance_m")}


def _read_parquet(path, figure, name):
    """The table ``name`` of ``figure`` at ``path``, every column of :data:`TABLE_COLUMNS` checked
    value by value; a file that is not parquet (corrupt, cut short), lacks a column or holds a value
    the figure cannot use is one line naming the file and the column."""
    study = owner(figure)
    columns = study.TABLE_COLUMNS[name]
    again = f"run dronefleet reproduce {figure} without --check or --redraw to write it again"
    try:
        schema = parquet_schema(path)
        rows = parquet_rows(path)
        # every figure draws at least one run, and --check compares one: no rows is a broken run's table,
        # unless the study records there events a run need not have (contract.STUDY_OPTIONAL)
        if rows == 0 and name not in getattr(study, "MAY_BE_EMPTY", ()):
            raise DataError(f"table {str(path)!r} holds no rows")
        if rows > MAX_TABLE_ROWS:
            raise DataError(f"table {str(path)!r} holds {rows:,} rows; a figure's table holds at most "
                            f"{MAX_TABLE_ROWS:,}")
        kinds = {column: KINDS[columns[column]] if column in columns else (flat, _any, "", True)
                 for column in [*columns, *(c for c in schema.names if c not in columns)]}
        table = read_parquet(path, {column: kind[0] for column, kind in kinds.items()})
        frame = pd.DataFrame({column: checked_column(table, column, path, ok, allowed, nullable=nullable)
                              for column, (_, ok, allowed, nullable) in kinds.items()})[schema.names]
        keys = list(UNIQUE_KEYS.get(name, ()))
        repeated = frame.duplicated(keys) if keys else None
        if repeated is not None and repeated.any():
            row = int(repeated.to_numpy().argmax())
            raise DataError(f"table {str(path)!r}: row {row} repeats {', '.join(keys)} = "
                            f"{', '.join(f'{value:g}' for value in frame.loc[row, keys])} of an earlier row")
        return frame
    except DataError as error:
        raise SweepError(f"{error}: {again}") from None


# ---------------------------------------------------------------------------- the figures: tidy, then draw
# tidy_<figure>(study) writes the figure's parquet tables from the sweeps;
# draw_<figure>(study) draws its files (PNG, PDF, SVG each) from those tables alone.


def tidy_fig16(study: Study) -> None:
    d = study.figure_dir("fig16")
    _write_runs(study, "fig16", ("rules", {}))
    _write_parquet(analysis.run_outcomes(study.table("rules", "summary")), d / "outcomes.parquet")
    orders = study.table("rules", "orders")
    _write_parquet(analysis.backlog_by_arrival_week(orders, study.horizon_s("rules")), d / "backlog.parquet")


def draw_fig16(study: Study, figure: str = "fig16") -> list[Path]:
    from .delivery import figures

    d = study.root / figure
    outcomes, backlog = _read(study, figure, "outcomes"), _read(study, figure, "backlog")
    return figures.rule_outcomes(outcomes, backlog, d / figure)


def tidy_fig17(study: Study) -> None:
    _write_runs(study, "fig17", ("rules", {"tau_minutes": LEARNING_TAU}))
    fleet = study.table("rules", "fleet", tau_minutes=LEARNING_TAU)
    _write_parquet(analysis.weekly_accuracy(fleet), study.figure_dir("fig17") / "accuracy.parquet")


def draw_fig17(study: Study) -> list[Path]:
    from .delivery import figures

    accuracy = _read(study, "fig17", "accuracy")
    return figures.accuracy_over_weeks(accuracy, study.root / "fig17" / "fig17")


def tidy_fig18(study: Study) -> None:
    _write_runs(study, "fig18", ("rules", {"rule": "least_confident", "tau_minutes": LEARNING_TAU}))
    fleet = study.table("rules", "fleet", rule="least_confident", tau_minutes=LEARNING_TAU)
    final = fleet[fleet.week == fleet.week.max()]
    config = study.sweep("rules").runs[0].config
    _write_parquet(analysis.winner_soh_grid(final, config), study.figure_dir("fig18") / "winner_soh.parquet")


def draw_fig18(study: Study) -> list[Path]:
    from .delivery import figures

    grid = _read(study, "fig18", "winner_soh")
    return figures.winner_soh_heatmaps(grid, study.root / "fig18" / "fig18")


def tidy_fig19(study: Study) -> None:
    d = study.figure_dir("fig19")
    _write_runs(study, "fig19", ("thresholds", {}), ("rules", {"rule": "least_confident"}))
    by = ("theta", "tau_minutes")
    thresholds = analysis.run_outcomes(study.table("thresholds", "summary"), by=by)
    table, best = analysis.threshold_table(thresholds)
    _write_parquet(table, d / "thresholds.parquet")
    chosen_by = "the study's criterion" if study.theta is None else "--theta"
    best = best if study.theta is None else study.theta
    study.log(f"  fig19: threshold(theta = {best:g}) beside learning, chosen by {chosen_by}")
    horizon = study.horizon_s("thresholds")
    learning = analysis.run_outcomes(study.table("rules", "summary", rule="least_confident"))
    backlog = analysis.backlog_by_arrival_week(study.table("thresholds", "orders", theta=best), horizon, by=by)
    learning_backlog = analysis.backlog_by_arrival_week(
        study.table("rules", "orders", rule="least_confident"), study.horizon_s("rules"))
    _write_parquet(pd.concat([learning, analysis.best_threshold_runs(thresholds.assign(rule="threshold"), best)],
                             ignore_index=True), d / "outcomes.parquet")
    _write_parquet(pd.concat([learning_backlog, analysis.best_threshold_runs(backlog, best)], ignore_index=True),
                   d / "backlog.parquet")


def draw_fig19(study: Study) -> list[Path]:
    from .delivery import figures

    table = _read(study, "fig19", "thresholds")
    d = study.root / "fig19"
    with tempfile.TemporaryDirectory(dir=d, prefix=".") as tmp:  # renamed into place: never half-written
        paths = [d / p.name for p in figures.write_threshold_table(table, Path(tmp) / "thresholds")]
        for path in paths:
            os.replace(Path(tmp) / path.name, path)
    return paths + draw_fig16(study, figure="fig19")


def tidy_fig20(study: Study) -> None:
    _write_runs(study, "fig20", ("reservations", {}))
    orders = study.table("reservations", "orders")
    pending = analysis.backlog_by_arrival_week(orders, study.horizon_s("reservations"), by=("rule",))
    _write_parquet(pending, study.figure_dir("fig20") / "pending.parquet")


def draw_fig20(study: Study) -> list[Path]:
    from .delivery import figures

    return figures.pending_bars(_read(study, "fig20", "pending"), study.root / "fig20" / "fig20")


TIDY = {"fig16": tidy_fig16, "fig17": tidy_fig17, "fig18": tidy_fig18, "fig19": tidy_fig19, "fig20": tidy_fig20}
DRAW = {"fig16": draw_fig16, "fig17": draw_fig17, "fig18": draw_fig18, "fig19": draw_fig19, "fig20": draw_fig20}


class _Deliverable:
    """The delivery study (OpenSwarm D4.4, Figures 16-20): here, not in its scenario package, as it
    runs over the sweeps (:class:`Study`), which sit above the scenarios."""

    TITLE = "UAV parcel delivery: OpenSwarm deliverable D4.4, Figures 16-20 (docs/delivery-experiments.md)"
    FIGURES = DELIVERY_FIGURES
    QUICK = f"seeds {QUICK_SEEDS[0]}-{QUICK_SEEDS[-1]} and {QUICK_CHANGES['horizon_weeks']:g} weeks"
    TABLE_COLUMNS = TABLE_COLUMNS

    def run_together(self, study: Study, figures: list[str]) -> None:
        """Nothing: figures that share a sweep share its runs through the results root."""

    def tidy(self, study: Study, figure: str) -> None:
        for name in NEEDS[figure]:
            study.ensure(name)
        TIDY[figure](study)

    def draw(self, study: Study, figure: str) -> list[Path]:
        return DRAW[figure](study)

    def check(self, study: Study, figure: str) -> list[str]:
        return _check_delivery(study, figure)


#: The delivery deliverable's study.
DELIVERABLE = _Deliverable()


def _study(name: str, scenario: scenarios.Scenario) -> FigureStudy | None:
    """The study of scenario ``name``: delivery's is :data:`DELIVERABLE`, any other's its ``study()`` hook, if any."""
    return DELIVERABLE if name == "delivery" else scenario.study


def studies() -> dict[str, FigureStudy]:
    """Every study by its scenario's name, of every scenario that loads (built-in, then installed:
    :func:`dronefleet.scenarios.loading`). An installed scenario's study that fails (its ``study()``
    raises) or names a figure another study has (or ``all``) is left out with a warning: it stops
    no other study."""
    found, owners = {}, {}
    for name, scenario in scenarios.loading().items():
        try:
            study = _study(name, scenario)
            problems = [] if study is None or name in scenarios.SCENARIOS else study_problems(study)
            if problems:
                scenarios.warn_left_out(name, f"its study is no FigureStudy (docs/scenario-contract.md): "
                                              f"{'; '.join(problems)}")
                continue
            figures = () if study is None else tuple(study.FIGURES)
        except Exception as error:  # the installed package's own error, whatever it is: the user must see it
            if name in scenarios.SCENARIOS:
                raise  # a built-in study's is a bug of ours: its traceback
            scenarios.warn_left_out(name, f"its study fails: {type(error).__name__}: {error}".splitlines()[0])
            continue
        taken = next((figure for figure in figures if figure in owners or figure == "all"), None)
        if taken is not None:
            whose = "is the word for every figure" if taken == "all" else f"{owners[taken]!r} has"
            scenarios.warn_left_out(name, f"its study names its figure {taken!r}, which {whose}: "
                                          f"its study's figures need other names")
            continue
        if study is not None:
            found[name] = study
            owners.update(dict.fromkeys(figures, name))
    return found


def all_figures() -> tuple[str, ...]:
    """Every figure of every study (:func:`studies`), study by study."""
    return tuple(figure for study in studies().values() for figure in study.FIGURES)


def owner(figure: str) -> FigureStudy:
    """The study that draws ``figure``; ConfigError listing the figures if none."""
    for study in studies().values():
        if figure in study.FIGURES:
            return study
    raise ConfigError(f"unknown figure {figure!r}; figures: {', '.join(all_figures())} (dronefleet reproduce --list)")


#: The built-in studies' figures (a scenario installed from another package adds its own: :func:`all_figures`).
FIGURES = tuple(figure for name, scenario in scenarios.SCENARIOS.items()
                if (study := _study(name, scenario)) is not None for figure in study.FIGURES)


def _check_theta(study, figures, redraw):
    """Refuse a ``--theta`` that cannot apply, before any run: one SweepError line."""
    theta = study.theta
    if theta is None:
        return
    if "fig19" not in figures:
        raise SweepError(f"--theta {theta:g} chooses Figure 19's threshold: reproduce fig19 (or all) with it")
    if redraw:
        raise SweepError(f"--theta {theta:g} chooses the runs in fig19's tables, which --redraw only draws: "
                         "give one of them")
    sweep = study.sweep("thresholds")
    if theta not in sweep.grid["theta"]:  # every digit: 80.0000001 is not 80
        raise SweepError(f"--theta {theta:.15g} is not a threshold of {sweep.path.name}: one of "
                         f"{', '.join(f'{value:g}' for value in sweep.grid['theta'])}")


def reproduce(figures: Sequence[str], out: str | os.PathLike = DEFAULT_OUT, quick: bool = False,
              jobs: int | None = None, redraw: bool = False, log: Callable[[str], object] = log.info,
              theta: float | None = None) -> dict[str, list[Path]]:
    """Reproduce ``figures`` (names of :func:`all_figures`) under the results root ``out``: run
    what is missing, tidy, draw; each figure by its study (:func:`owner`).

    With ``redraw``, only draw, from the tidy parquet tables already written there. ``theta``
    (%) is Figure 19's threshold, one of its sweep's; None lets the study's criterion pick it.
    Returns the paths of the figure files (every format), by figure.
    """
    from .figstyle import require_matplotlib

    try:
        require_matplotlib()  # refuse before hours of runs, not after
    except ImportError as error:
        raise SweepError(str(error)) from None
    study = Study(out, quick, jobs, log, theta)
    _check_theta(study, figures, redraw)
    probe_folders([study.root])  # a root under a file or not writable: one line, not a traceback at the first run
    owners = {figure: owner(figure) for figure in figures}
    drawn = {}
    with executors.reused_workers():  # every sweep and batch on the same workers: each loads its kernels once
        if not redraw:
            for each in dict.fromkeys(owners.values()):
                each.run_together(study, [figure for figure in figures if owners[figure] is each])
            for figure in figures:
                start = time.perf_counter()
                log(f"{figure}{' (quick)' if quick else ''}:")
                owners[figure].tidy(study, figure)
                log(f"  {figure}: tables written in {study.root / figure} ({time.perf_counter() - start:.1f} s)")
        # Each figure is drawn from its tables alone, so the figures are drawn side by side, one per process.
        tasks = [(out, quick, theta, figure) for figure in figures]
        for (*_, figure), result, error in executors.local(_draw, tasks, study.jobs):
            if error is not None:  # raised in a worker, or the worker died
                raise error if isinstance(error, (ConfigError, KeyboardInterrupt)) else SweepError(
                    f"drawing {figure} failed in a worker process: {type(error).__name__}: {error}")
            drawn[figure], seconds = result
            log(f"  {figure}: {len(drawn[figure])} files drawn in {study.root / figure} ({seconds:.1f} s)")
    return {figure: drawn[figure] for figure in figures}


def _draw(task: tuple[str | os.PathLike, bool, float | None, str]) -> tuple[list[Path], float]:
    """Draw one figure, here or in a worker process: ``task`` is (results root, quick, theta, figure);
    returns the paths of its files and the seconds the drawing took."""
    from .figstyle import marked

    out, quick, theta, figure = task
    study = Study(out, quick, jobs=1, theta=theta)
    start = time.perf_counter()
    drawer = owner(figure)
    # a quick figure says so on its face: it must never pass for the published one
    with writing(study.root / figure), marked(drawer.QUICK if quick else ""):
        paths = drawer.draw(study, figure)
    return paths, time.perf_counter() - start


def _same(a, b):
    """Equal values, NaN equal to NaN (a run's median delivery time is NaN when nothing was delivered)."""
    return a == b or (isinstance(a, float) and isinstance(b, float) and a != a and b != b)


def check(figure: str, results: str | os.PathLike = COMMITTED_RESULTS, quick: bool = False,
          log: Callable[[str], object] = log.info) -> list[str]:
    """Re-run a few runs of ``figure`` (:data:`CHECK_RUNS`) and compare them with its tables, by its
    study's ``check``: the differences, one line each (empty if every value is equal)."""
    return owner(figure).check(Study(results, quick, jobs=1, log=log), figure)


def _check_delivery(study: Study, figure: str) -> list[str]:
    """Re-run :data:`CHECK_RUNS` of the delivery ``figure`` and compare them with its ``runs.parquet``.

    The runs execute one after the other in this process, in a temporary results root
    (a warm-started run first re-runs the run whose fleet it starts from), so nothing under
    ``results`` is written. Runs of the list that the table does not hold (``--quick`` has
    seeds 0-1 only) are skipped. Returns the differences, one line each: empty if every
    value of every re-run summary equals the table's.
    """
    from .delivery.fleet import seeded_path

    quick, log = study.quick, study.log
    path = study.root / figure / "runs.parquet"
    if not path.exists():
        raise SweepError(f"{path} is missing: run dronefleet reproduce {figure}{' --quick' if quick else ''} "
                         "first (it writes the table that --check compares with)")
    committed = _read_parquet(path, figure, "runs")
    rows = {(name, run): row for name, run, row in zip(committed["sweep"], committed["run"],
                                                        committed.to_dict("records"))}
    chosen = [key for key in CHECK_RUNS[figure] if key in rows]
    if not chosen:
        raise SweepError(f"{path} holds none of the runs that --check re-runs for {figure}: "
                         f"{', '.join(f'{name} {run}' for name, run in CHECK_RUNS[figure])}")
    log(f"{figure}: re-running {len(chosen)} of the {len(committed)} runs in {path}")
    differences = []
    with tempfile.TemporaryDirectory(prefix="dronefleet-check-") as tmp:
        fresh = Study(tmp, quick, jobs=1, log=log)
        for name, run_id in chosen:
            run = next((r for r in fresh.sweep(name).runs if r.id == run_id), None)
            if run is None:
                raise SweepError(f"{path}: run {run_id} is not in the sweep {fresh.sweep(name).path} any more")
            if run.config.fleet_file:  # starts from a fleet of the rules sweep: make that first
                fleet = seeded_path(run.config.fleet_file, run.config.seed)
                fresh.ensure_runs("rules", [r for r in fresh.sweep("rules").runs
                                            if r.path(fresh.out("rules"), "fleet") == fleet])
            fresh.ensure_runs(name, [run])
            summary = pq.read_table(run.path(fresh.out(name), "summary")).to_pylist()[0]
            found = [f"{figure} {name} {run_id}: {column} committed {rows[name, run_id].get(column)!r}, "
                     f"re-run {value!r}"
                     for column, value in summary.items() if not _same(rows[name, run_id].get(column), value)]
            log(f"  {name} {run_id}: {len(summary)} values, "
                f"{'identical' if not found else f'{len(found)} differ'}")
            differences += found
    return differences


def list_studies() -> str:
    """``dronefleet reproduce --list``: every study, a line with its title, then its figures."""
    return "\n".join(f"{name}: {study.TITLE}\n  {' '.join(study.FIGURES)}" for name, study in studies().items())


def command(args: argparse.Namespace) -> int:
    """``dronefleet reproduce``."""
    figures = all_figures() if "all" in args.figure else tuple(dict.fromkeys(args.figure))
    named = " ".join(args.figure)
    # --check only reads, so it reads the committed results unless --out names another root.
    root = args.out or (COMMITTED_RESULTS if args.update_results or args.check else DEFAULT_OUT)
    if root.exists() and not root.is_dir():
        raise SweepError(f"--out {str(root)!r} is a file: give the folder to write the results under")
    if args.update_results and not COMMITTED_RESULTS.is_dir():  # it would start a results/ of its own here
        raise SweepError(f"--update-results refreshes the committed {COMMITTED_RESULTS}/, and {str(Path.cwd())!r} "
                         "has none: run it from the repository's root, or write elsewhere with --out DIR")
    if args.out is not None and not args.check and COMMITTED_RESULTS.is_dir() and root.resolve() == \
            COMMITTED_RESULTS.resolve():
        raise SweepError(f"--out {str(root)!r} is the committed {COMMITTED_RESULTS}/: refresh them with "
                         "--update-results, or write elsewhere with another --out")
    start = time.perf_counter()
    if args.check:
        if args.redraw:
            raise SweepError("--check re-runs runs and --redraw only draws: give one of them")
        if args.theta is not None:
            raise SweepError("--check re-runs runs and --theta chooses what fig19 draws: give one of them")
        with console.compile_notice("a simulation kernel"):
            differences = [line for figure in figures for line in check(figure, root, args.quick)]
        for line in differences:
            log.info(f"  differs: {line}")
        log.info(f"reproduce {named} --check: "
                 f"{f'values that differ: {len(differences)}' if differences else 'every value identical'} "
                 f"({time.perf_counter() - start:.1f} s)")
        return 1 if differences else 0
    with console.compile_notice("a simulation kernel"):  # with --jobs 1 the sweeps' runs run here
        reproduce(figures, root, args.quick, args.jobs, args.redraw, theta=args.theta)
    log.info(f"reproduce {named}: done in {time.perf_counter() - start:.1f} s, "
             f"under {Path(root) / 'quick' if args.quick else root}")
    return 0

