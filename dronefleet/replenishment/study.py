"""``dronefleet reproduce fig09..fig12``: the replenishment figures' tables, drawings and check.

The scenario's ``study()`` hook (:class:`dronefleet.contract.FigureStudy`): ``dronefleet
reproduce`` calls it for the figures of :data:`FIGURES` with its
:class:`~dronefleet.contract.StudyContext`, which reads the sweep files, runs on its
processes and reads and writes the tables (this package sits below the sweeps and
``reproduce``, so it asks rather than imports). Each figure runs its whole grid (its sweep
file; seconds, so nothing is reused) and writes under ``<out>/<figure>/``: ``runs.parquet``
(one row per trial: configuration, trial, seed, metrics) and ``bounds.parquet`` (one row per
configuration), then draws its figure (PNG, PDF, SVG) from those two files alone.
``--quick``: :data:`QUICK_TRIALS` trials of :data:`QUICK_TICKS` ticks.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from ..config import ConfigError, SweepError, _show
from ..contract import StudyContext, check_configurations
from . import experiments
from .experiments import CONFIG_COLUMNS, METRIC_COLUMNS
from .config import config_from_dict, replace

TITLE = "energy replenishment of robot swarms by fixed and mobile chargers, Figures 9-12 (docs/replenishment-model.md)"
FIGURES = experiments.FIGURES
QUICK_TRIALS = 4
QUICK_TICKS = 1500
QUICK = f"{QUICK_TRIALS} trials of {QUICK_TICKS} ticks"
_CONFIG = {**dict.fromkeys(CONFIG_COLUMNS, "key"), "strategy": "text", "n_workers": "integer", "n_chargers": "integer",
           "ticks": "integer"}
#: The columns of the figures' tables and their kinds (:data:`dronefleet.reproduce.KINDS`).
TABLE_COLUMNS = {
    "runs": {**_CONFIG, "trial": "count", "seed": "integer", **dict.fromkeys(METRIC_COLUMNS, "number")},
    "bounds": {**_CONFIG, "bound_work": "number", "bound_efficiency": "number", "bound_duty": "number"},
}
#: The two configurations `--check` re-runs per figure (every trial of each), as column values.
CHECK_CONFIGS = {
    "fig09": ({"strategy": "fixed"},
              {"strategy": "mobile", "n_chargers": 4, "charger_capacity_factor": 2.0}),
    "fig10": ({"strategy": "fixed", "work_ratio": 0.25},
              {"strategy": "mobile", "work_ratio": 4.0}),
    "fig11": ({"strategy": "fixed", "charge_rate": 0.5},
              {"strategy": "mobile", "charge_rate": 0.1}),
    "fig12": ({"strategy": "fixed"},
              {"strategy": "mobile", "transfer_loss": 0.7}),
}
#: Figs 10-12: the varied parameter and how each figure draws it.
CURVES = {
    "fig10": dict(x="work_ratio", xlabel="work ratio r (v_work = 0.1 r per tick; log scale)", log_x=True),
    "fig11": dict(x="charge_rate", xlabel="charge rate k (v_charge = k per tick)"),
    "fig12": dict(x="transfer_loss", xlabel="transfer loss lambda (share of a transfer lost)",
                  efficiency="efficiency_with_loss", fixed_line=True),
}
def grid(study: StudyContext, figure: str) -> Any:
    """The figure's sweep (``configs/sweeps/replenishment-<figure>.toml``), shortened with ``--quick``."""
    changes = {"ticks": QUICK_TICKS, "trials": QUICK_TRIALS} if study.quick else None
    return study.load_sweep(experiments.grid_path(figure), changes)


def run_together(study: StudyContext, figures: list[str]) -> None:
    """Run the grids of ``figures`` as one batch before their tables are tidied.

    One set of worker processes serves them all (each worker loads the kernel once, not
    once per figure), the configurations several figures share (the default fixed and
    MC(6, 2) ones are in every grid) run once, and no worker idles at a figure's end while
    the next one waits. The results stay in ``study.memo``, where :func:`tidy` finds them.
    """
    if len(figures) < 2:
        return
    configs = [run.config for figure in figures for run in grid(study, figure).runs]
    start = time.perf_counter()
    experiments.run_configs(configs, study.map, done=study.memo.setdefault("replenishment", {}))
    study.log(f"replenishment grids of {', '.join(figures)}: {len(set(configs))} distinct configurations "
              f"in {time.perf_counter() - start:.1f} s")


def tidy(study: StudyContext, figure: str) -> None:
    """Run the figure's grid (what :func:`run_together` has not run); write ``runs.parquet`` and
    ``bounds.parquet``."""
    sweep = grid(study, figure)
    configs = [run.config for run in sweep.runs]
    done = study.memo.setdefault("replenishment", {})
    ran_before = sum(config in done for config in configs)
    start = time.perf_counter()
    runs = experiments.run_configs(configs, study.map, done=done)
    first = configs[0].params
    study.log(f"  {sweep.name}: {len(configs)} configurations x {first.trials} trials of {first.ticks} ticks"
              + (f", {ran_before} run with the other figures" if ran_before else "")
              + f"; {time.perf_counter() - start:.1f} s")
    d = study.figure_dir(figure)
    study.write_table(runs, d / "runs.parquet")
    study.write_table(experiments.bounds_table([config.params for config in configs]), d / "bounds.parquet")


def draw(study: StudyContext, figure: str) -> list[Path]:
    """The figure's files (PNG, PDF, SVG) from its tables alone."""
    from . import figures

    runs = _read(study, figure, "runs")
    path = study.root / figure / figure
    if figure == "fig09":
        return figures.heatmaps(runs, path)
    return figures.work_and_efficiency(runs, _read(study, figure, "bounds"), path, **CURVES[figure])


#: The most configurations a figure's table may hold (the largest figure, 9, draws 36).
MAX_CONFIGURATIONS = 1000


def _read(study: StudyContext, figure: str, name: str) -> pd.DataFrame:
    """The table ``name`` of ``figure``, its columns checked (``study.read_table``) and each of its
    configurations held to a config file's rules (a strategy, a number of chargers, a ratio the
    model allows), so a tampered table is one line naming it before anything is drawn or run."""
    table = study.read_table(figure, name)
    check_configurations(table, CONFIG_COLUMNS, study.root / figure / f"{name}.parquet", MAX_CONFIGURATIONS,
                         lambda values: replace(config_from_dict({}), values),
                         lambda values: f"strategy={values['strategy']!r}")
    return table


def _same(a, b):
    return a == b or (a != a and b != b)  # NaN equals NaN


def check(study: StudyContext, figure: str) -> list[str]:
    """Re-run :data:`CHECK_CONFIGS` of ``figure`` (every trial) and compare with its ``runs.parquet``.

    Returns the differences, one line each; logs one line per configuration ending in
    ``identical`` when all its values agree.
    """
    from .simulate import simulate

    path = study.root / figure / "runs.parquet"
    if not path.exists():
        raise SweepError(f"{path} is missing: run dronefleet reproduce {figure}{' --quick' if study.quick else ''} "
                         "first (it writes the table that --check compares with)")
    committed = _read(study, figure, "runs")
    study.log(f"{figure}: re-running {len(CHECK_CONFIGS[figure])} configurations of the "
              f"{len(committed.groupby(list(CONFIG_COLUMNS)))} in {path}")
    differences = []
    for where in CHECK_CONFIGS[figure]:
        mine = committed[np.logical_and.reduce([committed[k] == v for k, v in where.items()])]
        configs = mine[list(CONFIG_COLUMNS)].drop_duplicates()
        label = ",".join(f"{k}={v}" for k, v in where.items())
        if len(configs) != 1:
            raise SweepError(f"{path} holds {len(configs)} configurations with {label}; --check needs exactly one")
        values = {k: v.item() if hasattr(v, "item") else v for k, v in configs.iloc[0].items()}
        mine = mine.sort_values("trial")
        trials = mine["trial"].to_numpy()
        if len(trials) and not np.array_equal(trials, np.arange(trials[0], trials[0] + len(trials))):
            raise SweepError(f"{path} holds the trials {_show(trials.tolist())} for {label}; --check re-runs "
                             "consecutive trials, each once")
        # the table's values are data: validated (ranges, run size) as a config file's before anything runs
        try:
            config = replace(config_from_dict({}), {**values, "trials": len(mine),
                                                    "first_trial": int(mine["trial"].iloc[0])})
        except ConfigError as error:
            raise SweepError(f"{path}: the configuration {label} cannot be re-run: {error}") from None
        result = simulate(config.params, len(mine), first_trial=config.first_trial)
        fresh = pd.DataFrame({c: result[c] for c in ("trial", "seed", *METRIC_COLUMNS)})
        found = [f"{figure} {label} trial {trial}: {column} committed {old!r}, re-run {new!r}"
                 for column in fresh.columns
                 for trial, old, new in zip(fresh["trial"], mine[column].tolist(), fresh[column].tolist())
                 if not _same(old, new)]
        study.log(f"  {label}: {fresh.size} values, {'identical' if not found else f'{len(found)} differ'}")
        differences += found
    return differences
