"""Reproduce the study's figures (EXPERIMENTS.md, Figures 16-20): run what is missing, tidy, draw.

``dronefleet reproduce FIGURE [--quick] [--jobs J] [--results DIR] [--redraw]``, FIGURE one
of fig16..fig20 or ``all``. Each figure needs one or more sweeps of ``configs/sweeps/``:

==========  ==================================================================
sweep       runs (``--quick``: seeds 0-1, 2 weeks)
==========  ==================================================================
rules       least_confident, most_confident, random x 6 tau x 20 seeds (16-19)
thresholds  threshold(theta), 6 theta x 6 tau x 20 seeds (19)
reservations  from the rules sweep's least_confident fleets at tau 15: without and
            with reservation bids, 20 seeds, 8 more weeks (20)
==========  ==================================================================

Sweeps run through :mod:`dronefleet.sweep` into ``<results>/<sweep>/`` (runs already
there are reused, so figures sharing a sweep run it once, and ``dronefleet sweep run``
or a SLURM job array can fill it beforehand). Each figure then writes its tidy tables
to ``<results>/<figure>/*.parquet`` and draws its PNGs from those files alone, so
``--redraw`` redraws without simulating or reading a sweep. ``--quick`` writes under
``<results>/quick/``.
"""

import os
import sys
import tempfile
import time
from pathlib import Path

import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

from . import analysis
from .provenance import stamp
from .records import write_atomic
from .sweep import Progress, SweepError, available_cpus, dataset, load_sweep, run_sweep

FIGURES = ("fig16", "fig17", "fig18", "fig19", "fig20")
#: The sweeps each figure reads.
NEEDS = {"fig16": ("rules",), "fig17": ("rules",), "fig18": ("rules",), "fig19": ("rules", "thresholds"),
         "fig20": ("rules", "reservations")}
#: What --quick changes in every sweep: few seeds, a short horizon.
QUICK_SEEDS = (0, 1)
QUICK_CHANGES = {"horizon_weeks": 2.0}
#: Where Figures 17, 18 and 20 take the least_confident fleets from.
LEARNING_TAU = 15.0


def sweeps_dir():
    """``configs/sweeps`` of the source tree this package runs from."""
    path = Path(__file__).resolve().parent.parent / "configs" / "sweeps"
    if not path.is_dir():
        raise SweepError(f"reproduce needs the sweep files of the source tree ({path} is missing): "
                         "run it from a clone of the repository (pip install -e .)")
    return path


class Study:
    """The study's sweeps under one results root: loaded (validated) once, run on demand."""

    def __init__(self, results, quick=False, jobs=None, log=print):
        self.root = Path(results) / "quick" if quick else Path(results)
        self.quick = quick
        self.jobs = jobs or available_cpus()
        self.log = log
        self._sweeps = {}
        self._ensured = set()   # sweeps checked (and completed) by this study: figures share them
        self._datasets = {}     # (sweep, table) -> its dataset of done runs, opened once

    def sweep(self, name):
        """The sweep ``name``, with --quick's changes; the reservation sweep reads the rules sweep's fleets."""
        if name not in self._sweeps:
            changes = dict(QUICK_CHANGES) if self.quick else {}
            if name == "reservations":
                changes["fleet_file"] = str(self.fleet_template())
            self._sweeps[name] = load_sweep(sweeps_dir() / f"{name}.toml", changes=changes,
                                            seeds=QUICK_SEEDS if self.quick else None)
        return self._sweeps[name]

    def out(self, name):
        return self.root / self.sweep(name).name

    def fleet_template(self):
        """The fleet files of the rules sweep's least_confident runs at tau 15, with ``{seed}``.

        Relative to the working directory, like the results root (and, for the default
        root, the very path of ``reservations.toml``, so both name the same runs).
        """
        rules = self.sweep("rules")
        run = next((r for r in rules.runs if r.config.rule == "least_confident"
                    and r.config.tau_minutes == LEARNING_TAU), None)
        if run is None:
            raise SweepError(f"{rules.path} has no least_confident runs at tau = {LEARNING_TAU:g} min, "
                             "whose learned fleets Figure 20 starts from")
        path = run.path(self.out("rules"), "fleet")
        return path.parent.parent / "seed={seed}" / path.name

    def ensure(self, name):
        """Run what is missing of sweep ``name`` (once per study); raise if any run failed."""
        if name in self._ensured:
            return
        sweep = self.sweep(name)
        out = self.out(name)
        start = time.perf_counter()
        ran, failures = run_sweep(sweep, out, sweep.runs, self.jobs, progress=Progress())
        self.log(f"  sweep {sweep.name}: {sweep.describe()}; ran {ran} in {time.perf_counter() - start:.1f} s, "
                 f"{len(sweep.runs) - ran} reused", flush=True)
        if failures:
            lines = "\n".join(f"    {run.partition}: {error}" for run, error in failures.items())
            raise SweepError(f"sweep {sweep.name}: {len(failures)} runs failed (dronefleet sweep status "
                             f"{sweep.path} --results {self.root}):\n{lines}")
        self._ensured.add(name)

    def table(self, name, table, **where):
        """Table ``table`` of sweep ``name`` as pandas, with typed grid columns, filtered on ``where``."""
        import pyarrow.compute as pc

        if (name, table) not in self._datasets:  # finding the done runs reads every run's summary
            self._datasets[name, table] = dataset(self.sweep(name), self.out(name), table)
        data = self._datasets[name, table]
        condition = None
        for key, value in where.items():
            term = pc.field(key) == value
            condition = term if condition is None else condition & term
        return data.to_table(filter=condition).to_pandas()

    def horizon_s(self, name):
        return self.sweep(name).runs[0].config.horizon_s

    def figure_dir(self, figure):
        path = self.root / figure
        path.mkdir(parents=True, exist_ok=True)
        return path


def _write_parquet(frame, path):
    table = stamp(pa.Table.from_pandas(frame, preserve_index=False))
    write_atomic(path, lambda tmp: pq.write_table(table, tmp))
    return path


def _read(study, figure, name):
    path = study.root / figure / f"{name}.parquet"
    if not path.exists():
        raise SweepError(f"{path} is missing: run dronefleet reproduce {figure} without --redraw first")
    return pd.read_parquet(path)


def _draw(draw, table, path, title):
    """One PNG, written atomically."""
    write_atomic(path, lambda tmp: draw(table, tmp, title))
    return path


# ---------------------------------------------------------------------------- the figures: tidy, then draw
# tidy_<figure>(study) writes the figure's parquet tables from the sweeps;
# draw_<figure>(study) draws its PNGs from those tables alone.


def tidy_fig16(study):
    d = study.figure_dir("fig16")
    _write_parquet(analysis.run_outcomes(study.table("rules", "summary")), d / "outcomes.parquet")
    orders = study.table("rules", "orders")
    _write_parquet(analysis.backlog_by_arrival_week(orders, study.horizon_s("rules")), d / "backlog.parquet")


def draw_fig16(study, label="Figure 16", figure="fig16"):
    from . import figures

    d = study.root / figure
    outcomes, backlog = _read(study, figure, "outcomes"), _read(study, figure, "backlog")
    runs = outcomes.groupby(["rule", "tau_minutes"]).size().max()
    weeks = int(backlog.arrival_week.max())
    return [
        _draw(figures.delivered_vs_delivery_time, outcomes, d / f"{figure}a.png",
              f"{label}a: delivered parcels vs delivery time ({runs} runs each)"),
        _draw(figures.aborted_by_tau, outcomes, d / f"{figure}b.png", f"{label}b: aborted delivery attempts"),
        _draw(figures.backlog_bars, backlog, d / f"{figure}c.png",
              f"{label}c: backlog age at the end of week {weeks}, by arrival week"),
    ]


def tidy_fig17(study):
    fleet = study.table("rules", "fleet", tau_minutes=LEARNING_TAU)
    _write_parquet(analysis.weekly_accuracy(fleet), study.figure_dir("fig17") / "accuracy.parquet")


def draw_fig17(study):
    from . import figures

    accuracy = _read(study, "fig17", "accuracy")
    return [_draw(figures.accuracy_over_weeks, accuracy, study.root / "fig17" / "fig17.png",
                  f"Figure 17: decision accuracy by week, tau = {LEARNING_TAU:g} min")]


def tidy_fig18(study):
    fleet = study.table("rules", "fleet", rule="least_confident", tau_minutes=LEARNING_TAU)
    final = fleet[fleet.week == fleet.week.max()]
    config = study.sweep("rules").runs[0].config
    _write_parquet(analysis.winner_soh_grid(final, config), study.figure_dir("fig18") / "winner_soh.parquet")


def draw_fig18(study):
    from . import figures

    grid = _read(study, "fig18", "winner_soh")
    return [_draw(figures.winner_soh_heatmaps, grid, study.root / "fig18" / "fig18.png",
                  f"Figure 18: mean SoH of the least_confident winner (final policies, tau = {LEARNING_TAU:g} min)")]


def tidy_fig19(study):
    d = study.figure_dir("fig19")
    by = ("theta", "tau_minutes")
    thresholds = analysis.run_outcomes(study.table("thresholds", "summary"), by=by)
    table, best = analysis.threshold_table(thresholds)
    _write_parquet(table, d / "thresholds.parquet")
    horizon = study.horizon_s("thresholds")
    learning = analysis.run_outcomes(study.table("rules", "summary", rule="least_confident"))
    backlog = analysis.backlog_by_arrival_week(study.table("thresholds", "orders", theta=best), horizon, by=by)
    learning_backlog = analysis.backlog_by_arrival_week(
        study.table("rules", "orders", rule="least_confident"), study.horizon_s("rules"))
    _write_parquet(pd.concat([learning, analysis.best_threshold_runs(thresholds.assign(rule="threshold"), best)],
                             ignore_index=True), d / "outcomes.parquet")
    _write_parquet(pd.concat([learning_backlog, analysis.best_threshold_runs(backlog, best)], ignore_index=True),
                   d / "backlog.parquet")


def draw_fig19(study):
    from . import figures

    table = _read(study, "fig19", "thresholds")
    d = study.root / "fig19"
    with tempfile.TemporaryDirectory(dir=d, prefix=".") as tmp:  # renamed into place: never half-written
        paths = [d / p.name for p in figures.write_threshold_table(table, Path(tmp) / "thresholds")]
        for path in paths:
            os.replace(Path(tmp) / path.name, path)
    return paths + draw_fig16(study, label="Figure 19", figure="fig19")


def tidy_fig20(study):
    orders = study.table("reservations", "orders")
    pending = analysis.backlog_by_arrival_week(orders, study.horizon_s("reservations"), by=("rule",))
    _write_parquet(pending, study.figure_dir("fig20") / "pending.parquet")


def draw_fig20(study):
    from . import figures

    pending = _read(study, "fig20", "pending")
    weeks = int(pending.arrival_week.max())
    return [_draw(figures.pending_bars, pending, study.root / "fig20" / "fig20.png",
                  f"Figure 20: pending orders after {weeks} more weeks from learned fleets, by arrival week")]


TIDY = {"fig16": tidy_fig16, "fig17": tidy_fig17, "fig18": tidy_fig18, "fig19": tidy_fig19, "fig20": tidy_fig20}
DRAW = {"fig16": draw_fig16, "fig17": draw_fig17, "fig18": draw_fig18, "fig19": draw_fig19, "fig20": draw_fig20}


def reproduce(figures, results="results", quick=False, jobs=None, redraw=False, log=print):
    """Reproduce ``figures`` (names of :data:`FIGURES`): run missing sweeps, tidy, draw.

    With ``redraw``, only draw, from the tidy parquet tables already written. Returns the
    paths of the figure files, by figure.
    """
    from .figures import require_matplotlib

    try:
        require_matplotlib()  # refuse before hours of runs, not after
    except ImportError as error:
        raise SweepError(str(error)) from None
    study = Study(results, quick, jobs, log)
    drawn = {}
    for figure in figures:
        start = time.perf_counter()
        log(f"{figure}{' (quick)' if quick else ''}:", flush=True)
        if not redraw:
            for name in NEEDS[figure]:
                study.ensure(name)
            TIDY[figure](study)
        drawn[figure] = DRAW[figure](study)
        log(f"  {figure}: {', '.join(str(p) for p in drawn[figure])} ({time.perf_counter() - start:.1f} s)",
            flush=True)
    return drawn


def command(args):
    """``dronefleet reproduce``."""
    figures = FIGURES if args.figure == "all" else (args.figure,)
    start = time.perf_counter()
    reproduce(figures, args.results, args.quick, args.jobs, args.redraw)
    print(f"reproduce {args.figure}: done in {time.perf_counter() - start:.1f} s")
    return 0


if __name__ == "__main__":
    from .cli import main

    sys.exit(main(["reproduce", *sys.argv[1:]]))
