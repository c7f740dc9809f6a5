"""``dronefleet reproduce items-fig01..items-fig12 items-ttests items-verdicts``: the items study's tables,
drawings and check.

The scenario's ``study()`` hook (:class:`dronefleet.contract.FigureStudy`), run with the
:class:`~dronefleet.contract.StudyContext` of ``dronefleet reproduce`` (it reads the sweep files,
runs on its processes, reads and writes the tables: this package sits below them). Experiments
E1-E5 are the sweep files ``configs/sweeps/items-<experiment>.toml``; E0 (Figs 1-2) is computed
here. Each figure writes under ``<out>/<figure>/``: ``runs.parquet`` (one row per configuration
and trial: :data:`~dronefleet.items.experiments.CONFIG_COLUMNS`, trial, seed, generated, served,
rate; the slices of the experiments it draws), Figs 1-2 ``curve.parquet`` / ``paths.parquet``,
the t-tests ``ttests.parquet``, then draws its files from those tables alone. ``items-verdicts``
reads the other figures' tables (not their experiments) and writes ``extra.parquet`` (the extra
cells it runs) and ``verdicts.parquet`` (:mod:`dronefleet.items.verdicts`).

Options (spec A2, A9): CAS runs under ``cas_variant = "max_expected"`` and ``"rate"``, the
item-delivery figures under ``lam_hat_source = "value"`` (lam_hat = 0.5) and ``"mu"``; every
figure that depends on them is drawn once per option: ``<figure>.png`` under the defaults,
``<figure>-<tag>.png`` under the others (the tag names the keys that differ, e.g. ``cas-rate``),
the option in words in the legend.
"""

from __future__ import annotations

import time
from pathlib import Path
import numpy as np
import pandas as pd

from ..config import SweepError
from ..contract import StudyContext, check_configurations, check_experiments
from . import experiments, verdicts
from .experiments import CONFIG_COLUMNS, RESULT_COLUMNS, USES
from .params import Params

TITLE = ("multi-robot item delivery and foraging (Liemhetcharat et al. 2015), Figs 1-12, the t-tests and a "
         "verdict on each of the paper's statements (docs/items-model.md, docs/items-paper-checklist.md)")
FIGURES = (*(f"items-fig{k:02d}" for k in range(1, 13)), "items-ttests", "items-verdicts")
#: --quick: every sweep with fewer trials and steps, and only these values of the grid's keys.
QUICK_CHANGES = {"trials": 2, "steps": 200}
QUICK_KEEP = {"n_robots": (1, 5), "capacity": (5, 10, 15, 20)}
QUICK = (f"{QUICK_CHANGES['trials']} trials of {QUICK_CHANGES['steps']} steps, n in {QUICK_KEEP['n_robots']}, "
         f"c in {QUICK_KEEP['capacity']}")
#: The capacity panels of the slices and t-tests (Figs 4, 6, 8, 10).
PANELS = (5, 10, 15, 20)
#: What each figure's ``runs`` table holds: experiment -> the column values it keeps (None: all).
SOURCES: dict[str, dict[str, dict | None]] = {
    "items-fig03": {"e1": None}, "items-fig04": {"e1": {"capacity": PANELS}},
    "items-fig05": {"e2": None}, "items-fig06": {"e2": {"capacity": PANELS}},
    "items-fig07": {"e3": {"sigma_e": (0.08, 0.12, 0.16, 0.20)}},
    "items-fig08": {"e3": {"sigma_e": (0.12,), "capacity": PANELS}},
    "items-fig09": {"e4a": None, "e4b": None}, "items-fig10": {"e4a": {"capacity": PANELS}},
    "items-fig11": {"e4b": {"speed": (0.2, 0.4, 0.6, 0.8)}}, "items-fig12": {"e5": None},
    "items-ttests": {"e1": {"capacity": PANELS}, "e2": {"capacity": PANELS},
                     "e3": {"sigma_e": (0.12,), "capacity": PANELS}},
}
#: The t-tests (spec 9): experiment -> the pairs (a, b) compared per capacity panel.
TTEST_PAIRS = {"e1": (("GR", "CAS"), ("GR", "R")), "e2": (("GR", "CAS"), ("GR", "R")),
               "e3": (("ASTC", "SF"), ("ASTC", "R"))}
_CONFIG = {"experiment": "text", **{c: "text" if c in ("mode", "truth", "algorithm", "cas_variant", "lam_hat_source")
                                    else "key" for c in CONFIG_COLUMNS}}
#: The columns of the figures' tables and their kinds (:data:`dronefleet.reproduce.KINDS`).
TABLE_COLUMNS = {
    "runs": {**_CONFIG, "trial": "count", "seed": "integer", "generated": "integer", "served": "count",
             "rate": "number"},
    "curve": {"step": "count", "x": "number"},
    "paths": {"path": "count", "step": "count", "x": "number"},
    "ttests": {"experiment": "text", "capacity": "key", "option": "text", "a": "text", "b": "text",
               "pairs": "count", "mean_a": "number", "mean_b": "number", "mean_diff": "number",
               "t_paired": "number", "p_paired": "number", "t_unpaired": "number", "p_unpaired": "number"},
    "verdicts": {"statement": "text", "verdict": "text", "holds_under": "text", "option": "text", "passes": "text",
                 "numbers": "text"},
    "extra": {"experiment": "text", **{c: "text" if c in ("mode", "truth", "algorithm", "cas_variant", "lam_hat_source",
                                                          "cas_targets") else "key"
                                       for c in verdicts.EXTRA_CONFIG},
              **{c: "count" for c in verdicts.MEASURE_COLUMNS if c != "rate"}, "rate": "number"},
}
#: The configurations `--check` re-runs per figure (every trial), as column values; each is in --quick's grid.
CHECK_CONFIGS = {
    "items-fig03": ({"algorithm": "GR", "n_robots": 5, "capacity": 10},
                    {"algorithm": "CAS", "cas_variant": "rate", "n_robots": 1, "capacity": 20}),
    "items-fig04": ({"algorithm": "R", "n_robots": 5, "capacity": 5},),
    "items-fig05": ({"algorithm": "CAS", "cas_variant": "max_expected", "n_robots": 5, "capacity": 15},),
    "items-fig06": ({"algorithm": "GR", "n_robots": 1, "capacity": 10},),
    "items-fig07": ({"algorithm": "ASTC", "n_robots": 5, "capacity": 10, "sigma_e": 0.12},
                    {"algorithm": "SF", "n_robots": 1, "capacity": 20, "sigma_e": 0.2}),
    "items-fig08": ({"algorithm": "AS", "n_robots": 5, "capacity": 15},),
    "items-fig09": ({"algorithm": "GRIC", "lam_hat_source": "mu", "n_robots": 5, "speed": 0.6},
                    {"algorithm": "CAS", "cas_variant": "rate", "lam_hat_source": "value", "n_robots": 1,
                     "capacity": 20}),
    "items-fig10": ({"algorithm": "GR", "lam_hat_source": "value", "n_robots": 5, "capacity": 20},),
    "items-fig11": ({"algorithm": "R", "n_robots": 5, "speed": 0.8},),
    "items-fig12": ({"algorithm": "CAS", "cas_variant": "max_expected", "lam_hat_source": "mu", "n_robots": 5,
                     "mu_l": 0.15},),
    "items-ttests": ({"experiment": "e2", "algorithm": "GR", "n_robots": 5, "capacity": 10},),
}


def grid(study: StudyContext, experiment: str) -> list:
    """The configurations of ``configs/sweeps/items-<experiment>.toml`` (with --quick: :data:`QUICK_CHANGES`
    and only the :data:`QUICK_KEEP` values)."""
    sweep = study.load_sweep(experiments.grid_path(experiment), QUICK_CHANGES if study.quick else None)
    configs = [run.config for run in sweep.runs]
    if study.quick:
        configs = [c for c in configs if all(getattr(c, k) in values for k, values in QUICK_KEEP.items())]
    return configs


def _memo(study: StudyContext) -> dict:
    return study.memo.setdefault("items", {"done": {}, "tables": {}})


def run_together(study: StudyContext, figures: list[str]) -> None:
    """Run every configuration of the experiments ``figures`` need as one batch (one set of worker
    processes, each experiment once: Figs 3, 4 and the t-tests share E1, say)."""
    needed = list(dict.fromkeys(e for figure in figures for e in SOURCES.get(figure, {})))
    if not needed:
        return
    configs = [config for experiment in needed for config in grid(study, experiment)]
    start = time.perf_counter()
    experiments.run_configs(configs, "+".join(needed), study.map, done=_memo(study)["done"])
    study.log(f"items experiments {', '.join(needed)}: {len(configs)} configurations in "
              f"{time.perf_counter() - start:.1f} s")


def experiment_table(study: StudyContext, experiment: str) -> pd.DataFrame:
    """Every trial of every configuration of ``experiment`` (run once per reproduce call)."""
    memo = _memo(study)
    if experiment not in memo["tables"]:
        configs = grid(study, experiment)
        start = time.perf_counter()
        memo["tables"][experiment] = experiments.run_configs(configs, experiment, study.map, done=memo["done"])
        study.log(f"  {experiment}: {len(configs)} configurations; {time.perf_counter() - start:.1f} s")
    return memo["tables"][experiment]


def keep(table: pd.DataFrame, where: dict | None) -> pd.DataFrame:
    """The rows of ``table`` whose columns take one of the values ``where`` lists (None: every row)."""
    mask = np.ones(len(table), dtype=bool)
    for column, values in (where or {}).items():
        mask &= table[column].isin(values).to_numpy()
    return table[mask].reset_index(drop=True)


def options(runs: pd.DataFrame) -> list[dict]:
    """The options a figure is drawn under: the distinct (cas_variant, lam_hat_source) of its CAS rows,
    or, without CAS, of the GR/GRIC rows' lam_hat_source; [{}] when no algorithm reads one."""
    for algorithm in ("CAS", "GR", "GRIC"):
        mine = runs[runs["algorithm"] == algorithm]
        if len(mine):
            keys = list(USES[algorithm])
            return [dict(zip(keys, values)) for values in mine[keys].drop_duplicates().itertuples(index=False)]
    return [{}]


def select(runs: pd.DataFrame, option: dict) -> pd.DataFrame:
    """The rows of ``runs`` drawn under ``option``: each algorithm's rows whose option keys it reads match."""
    mask = np.zeros(len(runs), dtype=bool)
    for algorithm, keys in USES.items():
        mine = (runs["algorithm"] == algorithm).to_numpy().copy()
        for key in keys:
            if key in option:
                mine &= (runs[key] == option[key]).to_numpy()
        mask |= mine
    return runs[mask].reset_index(drop=True)


#: The options in words, for a figure's legend: key -> value -> words.
OPTION_WORDS = {
    "cas_variant": {"max_expected": "CAS scores the items expected", "rate": "CAS scores items per step travelled",
                    "gr_no_earmark": "CAS as GRIC without ear-marking"},
    "lam_hat_source": {"value": "robots assume 0.5 demands per step", "mu": "robots know the mean rate"},
}


def option_label(option: dict, delivery: bool) -> tuple[str, str]:
    """(the option in words, for a legend; a tag for a file name: the keys whose value is not the
    default, "" for the defaults) of ``option``. lam_hat_source counts in item delivery only."""
    default = Params()
    keys = [key for key in ("cas_variant", "lam_hat_source") if key in option
            and (delivery or key != "lam_hat_source")]
    words = ", ".join(OPTION_WORDS[key].get(option[key], f"{key} {option[key]}") for key in keys)
    tag = "-".join(f"{key.split('_')[0]}-{option[key]}" for key in keys if option[key] != getattr(default, key))
    return words, tag


def ttest_table(runs: pd.DataFrame) -> pd.DataFrame:
    """Section 9's tests per capacity panel: for each experiment of ``runs`` (E1-E3), each CAS option
    and each pair of :data:`TTEST_PAIRS`, the runs of a and b paired by (n, trial).

    Returns one row per (experiment, option, capacity, pair): the columns of TABLE_COLUMNS["ttests"]
    (``option``: the CAS rule, "-" for E3).
    """
    rows = []
    for experiment, mine in runs.groupby("experiment", sort=True):
        for option in options(mine):
            chosen = select(mine, option)
            for capacity in sorted(chosen["capacity"].unique()):
                panel = chosen[chosen["capacity"] == capacity]
                for a, b in TTEST_PAIRS[experiment]:
                    left, right = (panel[panel["algorithm"] == name].set_index(["n_robots", "trial"])["rate"]
                                   for name in (a, b))
                    pairs = left.to_frame("a").join(right.to_frame("b"), how="inner").sort_index()
                    if pairs.empty:
                        continue
                    rows.append({"experiment": experiment, "capacity": capacity,
                                 "option": option.get("cas_variant", "-"), "a": a, "b": b,
                                 **experiments.paired_ttest(pairs["a"], pairs["b"])})
    return pd.DataFrame(rows, columns=list(TABLE_COLUMNS["ttests"]))


def verdict_data(study: StudyContext, extra: pd.DataFrame) -> verdicts.Data:
    """The committed tables the verdicts read (:data:`verdicts.FIGURE_TABLES`, the t-tests) and ``extra``."""
    runs = {experiment: study.read_table(figure, "runs") for experiment, figure in verdicts.FIGURE_TABLES.items()}
    return verdicts.Data(runs, study.read_table("items-ttests", "ttests"), extra)


def tidy(study: StudyContext, figure: str) -> None:
    """Run (or take from this call's memo) the figure's experiments; write its tables."""
    d = study.figure_dir(figure)
    if figure == "items-verdicts":
        start = time.perf_counter()
        extra = verdicts.extra_rows(verdicts.extra_configs(study.quick), study.map)
        study.log(f"  items-verdicts: {extra['experiment'].nunique()} extra sets, {len(extra)} trials in "
                  f"{time.perf_counter() - start:.1f} s")
        study.write_table(extra, d / "extra.parquet")
        study.write_table(verdicts.verdict_table(verdict_data(study, extra)), d / "verdicts.parquet")
        return
    if figure in ("items-fig01", "items-fig02"):
        curve = experiments.logistic_curve()
        study.write_table(pd.DataFrame({"step": np.arange(len(curve)), "x": curve}), d / "curve.parquet")
        if figure == "items-fig02":
            x = experiments.logistic_paths()
            paths, steps = np.indices(x.shape)
            study.write_table(pd.DataFrame({"path": paths.ravel(), "step": steps.ravel(), "x": x.ravel()}),
                              d / "paths.parquet")
        return
    runs = pd.concat([keep(experiment_table(study, e), where) for e, where in SOURCES[figure].items()],
                     ignore_index=True)
    study.write_table(runs, d / "runs.parquet")
    if figure == "items-ttests":
        study.write_table(ttest_table(runs), d / "ttests.parquet")


#: The 3-D figures: figure -> its rows (experiment or None: all, x, y); Fig 7 has a row per sigma_e.
SURFACES = {"items-fig03": [(None, "n_robots", "capacity")], "items-fig05": [(None, "n_robots", "capacity")],
            "items-fig07": [(None, "n_robots", "capacity")],
            "items-fig09": [("e4a", "n_robots", "capacity"), ("e4b", "n_robots", "speed")]}
#: The slices: figure -> (x, the column of its panels).
SLICES = {"items-fig04": ("n_robots", "capacity"), "items-fig06": ("n_robots", "capacity"),
          "items-fig08": ("n_robots", "capacity"), "items-fig10": ("n_robots", "capacity"),
          "items-fig11": ("n_robots", "speed"), "items-fig12": ("mu_l", "n_robots")}


#: The most configurations a figure's table may hold (items-fig07 holds 3,200).
MAX_CONFIGURATIONS = 10_000


def read_runs(study: StudyContext, figure: str) -> pd.DataFrame:
    """The figure's ``runs`` table, its columns checked (``study.read_table``), its experiments
    the figure's (:data:`SOURCES`) and each of its configurations held to a config file's rules,
    so that a tampered table is one line naming the file and the configuration before anything
    is drawn or run."""
    runs = study.read_table(figure, "runs")
    check_experiments(runs, study.root / figure / "runs.parquet", SOURCES[figure])
    check_configurations(
        runs, CONFIG_COLUMNS, study.root / figure / "runs.parquet", MAX_CONFIGURATIONS,
        lambda values: Params(**{k: v.item() if hasattr(v, "item") else v for k, v in values.items()}).validate(),
        lambda values: f"algorithm={values['algorithm']!r}, n_robots={values['n_robots']!r}")
    return runs


def draw(study: StudyContext, figure: str) -> list[Path]:
    """The figure's files (PNG, PDF, SVG; the t-tests: CSV and markdown) from its tables alone."""
    from . import figures

    d = study.root / figure
    if figure == "items-fig01":
        return figures.logistic(study.read_table(figure, "curve"), d / figure)
    if figure == "items-fig02":
        return figures.logistic_paths(study.read_table(figure, "paths"), study.read_table(figure, "curve"),
                                      d / figure)
    if figure in ("items-ttests", "items-verdicts"):
        return figures.write_ttests(study.read_table(figure, figure[6:]), d / figure)
    runs = read_runs(study, figure)
    delivery = bool((runs["mode"] == "delivery").any())
    files = []
    for option in options(runs):
        words, tag = option_label(option, delivery)
        name = d / "-".join(part for part in (figure, tag) if part)
        chosen = select(runs, option)
        if figure in SLICES:
            files += figures.slices(chosen, name, *SLICES[figure], words)
            continue
        blocks = []
        for experiment, x, y in SURFACES[figure]:
            mine = chosen if experiment is None else chosen[chosen["experiment"] == experiment]
            if figure == "items-fig07":
                blocks += [figures.Block(mine[mine["sigma_e"] == value], x, y, figures.panel_title("sigma_e", value))
                           for value in sorted(mine["sigma_e"].unique())]
            else:
                blocks.append(figures.Block(mine, x, y))
        files += figures.surfaces(blocks, name, words)
    return files


def _where(table: pd.DataFrame, where: dict) -> pd.DataFrame:
    return table[np.logical_and.reduce([(table[k] == v).to_numpy() for k, v in where.items()])]


def _same(a, b):
    return a == b or (a != a and b != b)  # NaN equals NaN


def _differ(figure: str, label: str, column: str, old: np.ndarray, new: np.ndarray, rows=None) -> list[str]:
    """One line per value of ``old`` that is not ``new``'s, naming its row (``rows``: a name per value)."""
    rows = [f"row {i}" for i in range(len(old))] if rows is None else rows
    return [f"{figure} {label} {row}: {column} committed {o!r}, re-derived {n!r}"
            for row, o, n in zip(rows, np.asarray(old).tolist(), np.asarray(new).tolist()) if not _same(o, n)]


def check(study: StudyContext, figure: str) -> list[str]:
    """Re-derive part of the figure's tables and compare them value for value.

    Figs 1-2: the whole curve and paths. Others: re-run :data:`CHECK_CONFIGS` (every trial, the
    configuration found in its sweep file by the table's config columns) and compare trial, seed,
    generated, served, rate; the t-tests also recompute every p-value from their runs table.
    Returns the differences, one line each.
    """
    d = study.root / figure
    main = {"items-fig01": "curve", "items-fig02": "paths", "items-ttests": "ttests",
            "items-verdicts": "verdicts"}.get(figure, "runs")
    if not (d / f"{main}.parquet").exists():
        raise SweepError(f"{d / f'{main}.parquet'} is missing: run dronefleet reproduce {figure}"
                         f"{' --quick' if study.quick else ''} first (it writes the table that --check compares with)")
    differences = []
    if figure == "items-verdicts":
        return _check_verdicts(study, figure)
    if figure in ("items-fig01", "items-fig02"):
        differences += _differ(figure, "curve", "x", study.read_table(figure, "curve")["x"],
                               experiments.logistic_curve())
        if figure == "items-fig02":
            paths = study.read_table(figure, "paths").sort_values(["path", "step"])
            differences += _differ(figure, "paths", "x", paths["x"], experiments.logistic_paths().ravel())
        study.log(f"{figure}: {'identical' if not differences else f'{len(differences)} values differ'}")
        return differences
    runs = read_runs(study, figure)
    study.log(f"{figure}: re-running {len(CHECK_CONFIGS[figure])} configurations of {d / 'runs.parquet'}")
    for where in CHECK_CONFIGS[figure]:
        label = ",".join(f"{k}={v}" for k, v in where.items())
        mine = _where(runs, where)
        keys = ["experiment", *CONFIG_COLUMNS]
        configs = mine[keys].drop_duplicates()
        if len(configs) != 1:
            raise SweepError(f"{d / 'runs.parquet'} holds {len(configs)} configurations with {label}; "
                             "--check needs exactly one")
        values = configs.iloc[0].to_dict()
        config = next((c for c in grid(study, values["experiment"])
                       if all(_same(getattr(c, k), values[k]) for k in CONFIG_COLUMNS)), None)
        if config is None:
            raise SweepError(f"{d / 'runs.parquet'}: the configuration {label} is not in "
                             f"{experiments.grid_path(values['experiment'])}{' (--quick)' if study.quick else ''}")
        fresh = experiments._trials_of(config)
        mine = mine.sort_values("trial")
        trials = [f"trial {t}" for t in mine["trial"]]
        found = [line for column in RESULT_COLUMNS
                 for line in _differ(figure, label, column, mine[column].to_numpy(), fresh[column], trials)]
        if len(mine) != len(fresh["trial"]):
            found.append(f"{figure} {label}: {len(mine)} trials committed, {len(fresh['trial'])} re-run")
        study.log(f"  {label}: {len(mine) * len(RESULT_COLUMNS)} values, "
                  f"{'identical' if not found else f'{len(found)} differ'}")
        differences += found
    if figure == "items-ttests":
        table = study.read_table(figure, "ttests")
        again = ttest_table(runs)
        if len(again) != len(table):
            differences.append(f"{figure}: {len(table)} tests committed, {len(again)} recomputed from runs")
        else:
            for column in TABLE_COLUMNS["ttests"]:
                differences += _differ(figure, "ttests", column, table[column].to_numpy(), again[column].to_numpy())
    return differences



#: The extra cells `--check` re-runs (every trial), as (extra set, {config key: value}).
CHECK_EXTRA = (("e3-measures", {"algorithm": "SF", "n_robots": 5, "capacity": 10}),
               ("e4a-shared", {"n_robots": 5, "capacity": 20}))


def _check_verdicts(study: StudyContext, figure: str) -> list[str]:
    """Re-run :data:`CHECK_EXTRA` against ``extra.parquet``, then re-derive every verdict from the
    committed tables and compare ``verdicts.parquet`` value for value."""
    extra = study.read_table(figure, "extra")
    differences = []
    configs = verdicts.extra_configs(study.quick)
    for name, where in CHECK_EXTRA:
        config = next((c for n, c in configs if n == name and all(getattr(c, k) == v for k, v in where.items())),
                      None)
        label = ",".join([name, *(f"{k}={v}" for k, v in where.items())])
        if config is None:
            raise SweepError(f"items-verdicts: the extra cell {label} is not among its cells"
                             f"{' (--quick)' if study.quick else ''}")
        fresh = verdicts.extra_rows([(name, config)])
        mine = _where(extra, {"experiment": name, **where}).sort_values("trial")
        if len(mine) != len(fresh):
            differences.append(f"{figure} {label}: {len(mine)} trials committed, {len(fresh)} re-run")
            continue
        for column in verdicts.MEASURE_COLUMNS:
            differences += _differ(figure, label, column, mine[column].to_numpy(), fresh[column].to_numpy(),
                                   [f"trial {t}" for t in mine["trial"]])
        study.log(f"  {label}: {len(mine) * len(verdicts.MEASURE_COLUMNS)} values re-run")
    table = study.read_table(figure, "verdicts")
    again = verdicts.verdict_table(verdict_data(study, extra))
    if len(again) != len(table):
        differences.append(f"{figure}: {len(table)} rows committed, {len(again)} re-derived")
    else:
        for column in TABLE_COLUMNS["verdicts"]:
            differences += _differ(figure, "verdicts", column, table[column].to_numpy(), again[column].to_numpy())
    study.log(f"{figure}: {'identical' if not differences else f'{len(differences)} values differ'}")
    return differences
