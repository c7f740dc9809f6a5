"""Global sensitivity analysis of a ``[design]`` sweep: ``dronefleet analyze sensitivity SWEEP --metric M``;
from Python ``dronefleet.sensitivity(SWEEP, metrics)``.

Each sample point's value of a metric is the mean, over the run's seeds and replicates (trials,
runs), of that summary column in the runs of its configuration; points that share a
configuration share that value (:mod:`dronefleet.designs`). From these values:

- a ``sobol`` design gives Sobol' indices (SALib ``analyze.sobol``; Saltelli 2002, Saltelli et al.
  2010): first order ``S1`` (the share of the metric's variance that one key explains alone),
  total order ``ST`` (alone and with all others) and, if sampled, second order ``S2`` (a pair's
  joint share beyond the two alone);
- a ``morris`` design gives Morris's elementary-effect screening (SALib ``analyze.morris``;
  Morris 1991, Campolongo et al. 2007): ``mu_star``, the mean absolute change of the metric over
  one step of a key (in the metric's units per the key's whole range), its signed mean ``mu`` and
  spread ``sigma`` (large where a key acts non-linearly or together with others).

Intervals are 95 % bootstrap intervals over the sample points (``value +- 1.96`` bootstrap
standard errors, as SALib gives them), from ``resamples`` resamples with a fixed seed, so the same
dataset gives the same table. ``lhs`` and ``sobol-seq`` designs explore; they give no indices here.

Written into the dataset: :data:`INDICES_FILE` (one row per metric, index and key: ``metric,
index, key, other_key, value, ci_low, ci_high``; ``other_key`` is the pair's second key for
``S2``, else empty; ``ci_*`` NaN where SALib gives no interval) and the figure ``sensitivity``
(PNG, PDF, SVG): a panel per metric, a bar per key and index with its interval.
"""

from __future__ import annotations

import logging
import math
import os
from pathlib import Path
from typing import TYPE_CHECKING, NamedTuple

from . import designs, sweeps
from .config import SweepError, named_file
from .figstyle import (DOUBLE_COLUMN, MIN_FONT_SIZE, OKABE_ITO, PRINT_RC, SINGLE_COLUMN, _dodge, _figure, figure_paths,
                       letter_panels)

if TYPE_CHECKING:
    import argparse

    import pandas

log = logging.getLogger(__name__)

#: In a dataset folder, the indices of ``analyze sensitivity``; its figure is ``sensitivity.{png,pdf,svg}``.
INDICES_FILE = "sensitivity.parquet"
#: The confidence level of the intervals.
CONFIDENCE = 0.95
#: Default bootstrap resamples of the intervals.
RESAMPLES = 1000
#: The seed of the bootstrap: the same points give the same intervals. Not 0: SALib's Sobol'
#: analysis takes a seed of 0 for none, and draws its resamples from fresh entropy.
BOOTSTRAP_SEED = 1
#: The methods whose points this analysis takes, and the indices each gives (in table order).
INDICES = {"sobol": ("S1", "ST", "S2"), "morris": ("mu_star", "mu", "sigma")}
#: What each index is, for the printed table and the figure's legend.
INDEX_WORDS = {"S1": "first order S1", "ST": "total order ST", "S2": "second order S2",
               "mu_star": "mu* (mean |effect|)", "mu": "mu (mean effect)", "sigma": "sigma (spread of effects)"}


class Sensitivity(NamedTuple):
    """What :func:`sensitivity` returns: ``indices`` (the table of :data:`INDICES_FILE`) and
    ``samples`` (a row per sample point: ``sample``, the design's keys, each metric's value there)."""

    indices: pandas.DataFrame
    samples: pandas.DataFrame


def metric_columns(scenario) -> tuple[str, ...]:
    """The numeric columns of the scenario's summary table that are metrics (not its counters of
    replicates and seeds): the names ``--metric`` takes."""
    import pyarrow as pa

    skip = {scenario.seed_key, "seed", "trial", "run", "period", *scenario.defaults}
    return tuple(field.name for field in scenario.table_schemas()["summary"]
                 if field.name not in skip and (pa.types.is_integer(field.type) or pa.types.is_floating(field.type)))


def _check(sweep: sweeps.Sweep, metrics) -> tuple[str, ...]:
    """The metrics, checked: SweepError (one line) for a grid sweep, a design this analysis does
    not take, no metric, or a name that is no metric of the scenario's summary."""
    design = sweep.design
    if design is None:
        raise SweepError(f"sweep {sweep.name} is a grid sweep: sensitivity analysis takes a sweep with a [design] "
                         f"of method {' or '.join(INDICES)}")
    if design.method not in INDICES:
        raise SweepError(f"sweep {sweep.name} has a {design.method} design, which gives no indices: sensitivity "
                         f"analysis takes method {' or '.join(INDICES)}")
    metrics = tuple(dict.fromkeys(metrics))
    allowed = metric_columns(sweep.scenario)
    if not metrics:
        raise SweepError(f"give at least one --metric; {sweep.scenario.name} has {', '.join(allowed)}")
    for metric in metrics:
        if metric not in allowed:
            raise SweepError(f"--metric {metric!r} is not a metric of the {sweep.scenario.name} summary. "
                             f"Allowed: {', '.join(allowed)}")
    return metrics


def point_values(sweep: sweeps.Sweep, out: Path, metrics: tuple[str, ...]) -> pandas.DataFrame:
    """A row per sample point, in sample order: ``sample``, the design's keys, and each metric's
    mean over the runs (and their replicates) of that point's configuration. SweepError (one
    line) if a run is not done, or a metric is undefined (NaN) in a run."""
    import pandas as pd

    design = sweep.design
    done = sweeps.done_runs(sweep, out)
    if len(done) != len(sweep.runs):
        raise SweepError(f"{len(sweep.runs) - len(done)} of the {len(sweep.runs)} runs of sweep {sweep.name} are not "
                         f"done in {out}: every point is needed (dronefleet sweep run, then sweep status)")
    data = sweeps.rows(sweep, out, "summary", sweeps.dataset(sweep, out, "summary", done),
                       ).select([*design.keys, *metrics]).to_pandas()
    for metric in metrics:  # a mean would hide a run whose metric is undefined
        if (undefined := int(data[metric].isna().sum())):
            raise SweepError(f"--metric {metric!r} is undefined (NaN) in {undefined} of the {len(data)} summary rows "
                             f"of sweep {sweep.name}: choose a metric every run defines")
    means = data.groupby(list(design.keys), sort=False)[list(metrics)].mean()
    points = pd.DataFrame(design.points, columns=list(design.keys))
    points.insert(0, "sample", range(len(points)))
    index = pd.MultiIndex.from_frame(points[list(design.keys)]) if len(design.keys) > 1 else \
        pd.Index(points[design.keys[0]])
    for metric in metrics:
        points[metric] = means[metric].reindex(index).to_numpy()
    return points


def _rows(metric: str, index: str, keys, values, conf=None, others=None) -> list[dict]:
    """Table rows of one index of one metric: a row per key (or pair)."""
    rows = []
    for k, key in enumerate(keys):
        value = float(values[k])
        half = math.nan if conf is None else float(conf[k])
        rows.append({"metric": metric, "index": index, "key": key, "other_key": "" if others is None else others[k],
                     "value": value, "ci_low": value - half, "ci_high": value + half})
    return rows


def indices(design: designs.Design, points: pandas.DataFrame, metrics: tuple[str, ...],
            resamples: int = RESAMPLES) -> pandas.DataFrame:
    """The indices of each metric from the values of the sobol or morris ``design``'s points
    (``points``, as :func:`point_values` gives them), as the table of :data:`INDICES_FILE`.
    SweepError (one line) for a metric that takes one value at every point."""
    import numpy as np
    import pandas as pd

    rows = []
    problem, keys = design.problem(), list(design.keys)
    for metric in metrics:
        y = points[metric].to_numpy(dtype=float)
        if np.all(y == y[0]):
            raise SweepError(f"--metric {metric!r} is {y[0]:g} at every sample point of the design: "
                             "it has no variance to apportion")
        if design.method == "sobol":
            from SALib.analyze import sobol

            found = sobol.analyze(problem, y, calc_second_order=design.second_order, num_resamples=resamples,
                                  conf_level=CONFIDENCE, seed=BOOTSTRAP_SEED)
            rows += _rows(metric, "S1", keys, found["S1"], found["S1_conf"])
            rows += _rows(metric, "ST", keys, found["ST"], found["ST_conf"])
            if design.second_order:
                pairs = [(i, j) for i in range(len(keys)) for j in range(i + 1, len(keys))]
                rows += _rows(metric, "S2", [keys[i] for i, _ in pairs], [found["S2"][i, j] for i, j in pairs],
                              [found["S2_conf"][i, j] for i, j in pairs], [keys[j] for _, j in pairs])
        else:
            from SALib.analyze import morris

            found = morris.analyze(problem, design.unit, y, num_resamples=resamples, conf_level=CONFIDENCE,
                                   num_levels=design.morris_levels, seed=BOOTSTRAP_SEED)
            rows += _rows(metric, "mu_star", keys, found["mu_star"], found["mu_star_conf"])
            rows += _rows(metric, "mu", keys, found["mu"])
            rows += _rows(metric, "sigma", keys, found["sigma"])
    return pd.DataFrame(rows, columns=["metric", "index", "key", "other_key", "value", "ci_low", "ci_high"])


def sensitivity(sweep: str | os.PathLike | sweeps.Sweep, metrics, results: str | os.PathLike = "results",
                resamples: int = RESAMPLES, write: bool = True) -> Sensitivity:
    """Global sensitivity indices of ``metrics`` (summary column names) over the done runs of
    the ``[design]`` sweep ``sweep`` (a sweep file, a shipped sweep's name, or a loaded
    :class:`~dronefleet.sweeps.Sweep`) in ``<results>/<sweep name>``.

    Returns :class:`Sensitivity` (pandas DataFrames). With ``write``, the indices are also
    written to the dataset (:data:`INDICES_FILE`) and drawn (``sensitivity.{png,pdf,svg}``).
    SweepError (one line) for a grid sweep, an lhs or sobol-seq design, an unknown metric,
    runs not done, or a metric undefined or constant over the points.
    """
    import pyarrow as pa
    import pyarrow.parquet as pq

    from .outputs import writing
    from .provenance import stamp
    from .records import write_atomic

    if isinstance(metrics, str):
        metrics = [metrics]
    if not (isinstance(resamples, int) and not isinstance(resamples, bool) and resamples >= 10):
        raise SweepError(f"resamples must be an integer >= 10, got {resamples!r}")
    if not isinstance(sweep, sweeps.Sweep):
        sweep = sweeps.load_sweep(named_file(os.fspath(sweep), "sweep"))
    metrics = _check(sweep, metrics)
    out = Path(results) / sweep.name
    sweeps.check_layout(sweep, out)
    points = point_values(sweep, out, metrics)
    table = indices(sweep.design, points, metrics, resamples)
    if write:
        data = stamp(pa.Table.from_pandas(table, preserve_index=False))
        path = out / INDICES_FILE
        with writing(path):
            write_atomic(path, lambda tmp: pq.write_table(data, tmp))
        draw(table, sweep.design.method, out / "sensitivity")
    return Sensitivity(table, points)


def draw(table: pandas.DataFrame, method: str, path: str | os.PathLike) -> list[Path]:
    """One panel per metric (lettered when several; three to a row, four as two rows of two): a
    horizontal bar per key and first- or total-order index (Sobol': ``S1``, ``ST``; Morris:
    ``mu_star``, ``sigma``), with its 95 % interval as whiskers where it has one. Print size, no
    text below 7 pt."""
    import numpy as np

    shown = ("S1", "ST") if method == "sobol" else ("mu_star", "sigma")
    colours = {shown[0]: OKABE_ITO["blue"], shown[1]: OKABE_ITO["orange"]}
    hatches = {shown[0]: "", shown[1]: "//"}
    metrics = list(dict.fromkeys(table["metric"]))
    keys = list(dict.fromkeys(table["key"][table["index"] == shown[0]]))
    ncols = 2 if len(metrics) == 4 else min(len(metrics), 3)  # four panels: two rows of two
    nrows = math.ceil(len(metrics) / ncols)
    width = SINGLE_COLUMN if len(metrics) == 1 else DOUBLE_COLUMN
    height = nrows * (0.22 * len(keys) * len(shown) / 2 + 0.9) + 0.35
    with _figure(path, (width, height), PRINT_RC, nrows=nrows, ncols=ncols, sharey=True, squeeze=False) \
            as (mpl, fig, axes):
        for ax, metric in zip(axes.flat, metrics):
            ax.axvline(0.0, color="0.4", lw=0.6)
            for k, index in enumerate(shown):
                rows = table[(table["metric"] == metric) & (table["index"] == index)].set_index("key").loc[keys]
                y = np.arange(len(keys)) + _dodge(k, len(shown), 0.38)
                low, high = rows["ci_low"].to_numpy(), rows["ci_high"].to_numpy()
                whiskers = None if np.isnan(low).all() else \
                    np.vstack([rows["value"] - low, high - rows["value"]])
                ax.barh(y, rows["value"], height=0.38, xerr=whiskers, color=colours[index], hatch=hatches[index],
                        edgecolor="black", linewidth=0.4, error_kw={"elinewidth": 0.7, "capsize": 1.5},
                        label=INDEX_WORDS[index])
            ax.set_xlabel(metric.replace("_", " "))
            ax.grid(alpha=0.3, axis="x")
            ax.tick_params(labelsize=MIN_FONT_SIZE)
        for ax in axes.flat[len(metrics):]:
            ax.set_visible(False)
        axes[0, 0].set_yticks(range(len(keys)), keys)
        axes[0, 0].invert_yaxis()
        if len(metrics) > 1:
            letter_panels(axes.flat[:len(metrics)])
        handles, labels = axes[0, 0].get_legend_handles_labels()
        fig.legend(handles, labels, loc="outside lower center", ncols=len(labels), frameon=False,
                   title="bars: index; whiskers: 95 % bootstrap interval")
    return figure_paths(path)


def format_table(table: pandas.DataFrame) -> str:
    """The indices as text: per metric, a line per key (its indices with their intervals), then
    the second-order pairs."""
    lines = []
    for metric, rows in table.groupby("metric", sort=False):
        lines.append(f"{metric}")
        names = [index for index in dict.fromkeys(rows["index"]) if index != "S2"]
        width = max(len(key) for key in rows["key"])
        lines.append(f"  {'key':<{width}}  " + "  ".join(f"{name:>24}" for name in names))
        for key in dict.fromkeys(rows["key"][rows["index"] == names[0]]):
            cells = [_cell(rows[(rows["index"] == name) & (rows["key"] == key)].iloc[0]) for name in names]
            lines.append(f"  {key:<{width}}  " + "  ".join(f"{cell:>24}" for cell in cells))
        for _, row in rows[rows["index"] == "S2"].iterrows():
            lines.append(f"  S2 {row['key']} x {row['other_key']}: {_cell(row)}")
    return "\n".join(lines)


def _cell(row) -> str:
    """``0.512 [0.431, 0.593]``, or the value alone where it has no interval."""
    if math.isnan(row["ci_low"]):
        return f"{row['value']:.3g}"
    return f"{row['value']:.3f} [{row['ci_low']:.3f}, {row['ci_high']:.3f}]"


def command(args: argparse.Namespace) -> int:
    """``dronefleet analyze sensitivity SWEEP --metric M ...``: print the indices, write and draw them."""
    sweep = sweeps.load_sweep(named_file(args.sweep, "sweep"))
    result = sensitivity(sweep, args.metric, args.results, args.resamples)
    out = Path(args.results) / sweep.name
    interval = f"{CONFIDENCE:.0%} bootstrap intervals of {args.resamples} resamples"
    print(f"sweep {sweep.name}: {sweep.describe()}; {interval}")
    print(format_table(result.indices))
    print(f"  indices  {out / INDICES_FILE}")
    print(f"  figure   {out / 'sensitivity'}.png (.pdf, .svg)")
    return 0
