"""The replenishment study's figures (docs/replenishment-model.md section 10, Figs 9-12) from tidy tables alone.

Each function reads the tables :mod:`dronefleet.replenishment.experiments` writes (one
row per trial; one row of bounds per configuration) and draws one figure, as PNG, PDF and
SVG, with the style of :mod:`dronefleet.figstyle` (Agg canvas, no titles, no dates or
versions in the files: the same tables give the same bytes) at print size, a page wide
(:data:`~dronefleet.figstyle.DOUBLE_COLUMN`, 7.2 in), no text below 7 pt, its panels
lettered (a), (b), ... as the captions in ``results/README.md`` letter them. Nothing here
imports the simulator.

Each strategy has its colour and marker of :data:`dronefleet.figstyle.STRATEGY_STYLES` in
every figure (fixed chargers blue squares, mobile chargers vermillion circles): means are
solid lines with filled markers, bounds dashed with hollow ones.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..figstyle import DOUBLE_COLUMN, MIN_FONT_SIZE, PRINT_RC, STRATEGY_STYLES, _dodge, _figure, figure_paths, \
    letter_panels, styles

if TYPE_CHECKING:
    import pandas

LABELS = {"fixed": "fixed chargers", "mobile": "mobile chargers"}
#: Fig 9's panels (a)-(d): (per-trial column, what it is (the colour bar's label), its unit in
#: the cells (the column's values are divided by it), number format).
HEATMAP_PANELS = (("work", "work W (1000 points)", 1000.0, "{:.1f}"),
                  ("energy", "total energy consumed", 1.0, "{:.0f}"),
                  ("efficiency", "efficiency (work energy / total)", 1.0, "{:.2f}"),
                  ("depleted_workers", "depleted workers (of n_w)", 1.0, "{:.2f}"))
#: Width of a configuration's column of per-trial points, as a fraction of the x axis.
_SPREAD = 0.012


def heatmaps(runs: pandas.DataFrame, path: str | os.PathLike) -> list[Path]:
    """Fig 9: mean W, total energy, efficiency and depleted workers over (n_m, phi), four panels.

    Rows phi, columns n_m; the fixed strategy (no mobile chargers) in the "0 chargers / 0x"
    cell, cells without a configuration blank. Each cell is written with its mean (work in
    thousands of points); each panel has its own colour scale, whose label says what the
    panel shows. A page wide, panels (a)-(d) in the order of :data:`HEATMAP_PANELS`.

    Parameters
    ----------
    runs : pandas.DataFrame
        Per-trial rows: ``strategy, n_chargers, charger_capacity_factor`` and the panel columns.
    path : str or Path
        Figure file name (its suffix is replaced by each format's).

    Returns
    -------
    list of Path
        The figure's files, one per format.
    """
    cells = runs.assign(phi=np.where(runs["strategy"] == "fixed", 0.0, runs["charger_capacity_factor"]))
    means = cells.groupby(["phi", "n_chargers"])[[c for c, *_ in HEATMAP_PANELS]].mean()
    with _figure(path, (DOUBLE_COLUMN, 5.0), PRINT_RC, nrows=2, ncols=2) as (mpl, fig, axes):
        for ax, (column, label, unit, fmt) in zip(axes.flat, HEATMAP_PANELS):
            grid = means[column].unstack("n_chargers") / unit
            values = grid.to_numpy()
            image = ax.imshow(np.ma.masked_invalid(values), origin="lower", cmap="viridis", aspect="auto")
            low, high = np.nanmin(values), np.nanmax(values)
            for (i, j), value in np.ndenumerate(values):
                if np.isfinite(value):
                    bright = high > low and (value - low) / (high - low) > 0.6
                    ax.text(j, i, fmt.format(value), ha="center", va="center", fontsize=MIN_FONT_SIZE,
                            color="black" if bright else "white")
            ax.set_xticks(range(len(grid.columns)), [str(n) for n in grid.columns])
            ax.set_yticks(range(len(grid.index)), [f"{phi:g}x" for phi in grid.index])
            ax.set_xlabel("mobile chargers n_m (0: fixed chargers)")
            ax.set_ylabel("charger capacity phi (x c_w)")
            ax.tick_params(length=0)
            fig.colorbar(image, ax=ax, fraction=0.05, pad=0.02, label=label)
        letter_panels(axes.flat)
    return figure_paths(path)


def _spread(x, k, n, log_x, span):
    """x of the k-th of n trials of a configuration at ``x``: spread over a narrow column."""
    offset = (k / max(n - 1, 1) - 0.5) * _SPREAD * span
    return x * 10.0 ** offset if log_x else x + offset


def work_and_efficiency(runs: pandas.DataFrame, bounds: pandas.DataFrame, path: str | os.PathLike, x: str,
                        xlabel: str, efficiency: str = "efficiency", log_x: bool = False,
                        fixed_line: bool = False) -> list[Path]:
    """Figs 10-12: work and efficiency against the varied parameter ``x``, both strategies.

    A page wide: (a) work, (b) efficiency. Per-trial values as small faint markers of the
    strategy (each configuration's trials spread over a narrow column, the strategies side
    by side), means as the strategy's filled marker (fixed chargers squares, mobile chargers
    circles) on a solid line, the analytic bound of each strategy (section 9) as a dashed
    line with hollow markers through its configurations. With ``fixed_line`` the fixed
    strategy, which does not vary with ``x``, is drawn as horizontal lines: its mean (solid)
    and its bound (dashed) across the axis. The legend above the panels names the lines.

    Parameters
    ----------
    runs : pandas.DataFrame
        Per-trial rows: ``strategy``, ``x``, ``work`` (points) and ``efficiency`` (work energy /
        total energy, 0..1), e.g. a run's ``summary`` with the columns of
        :func:`dronefleet.replenishment.experiments.config_row` of its config.
    bounds : pandas.DataFrame
        One row per configuration: ``strategy``, ``x``, ``bound_work`` (points),
        ``bound_efficiency`` (0..1), as :func:`dronefleet.replenishment.experiments.bounds_table`
        gives them (NaN where a bound does not exist: no line there).
    path : str or Path
        Figure file name (its suffix is replaced by each format's).
    x : str
        The varied parameter's column (e.g. ``work_ratio``, ``charge_rate``, ``transfer_loss``).
    xlabel : str
        The x axis label, with the parameter's unit if it has one.
    efficiency : str
        The efficiency column (Fig 12: ``efficiency_with_loss``).
    log_x : bool
        A logarithmic x axis (Fig 10's work ratios span 0.1 to 10).
    fixed_line : bool
        Draw the fixed strategy as horizontal lines across the axis (it does not vary with ``x``).

    Returns
    -------
    list of Path
        The figure's files, one per format.
    """
    panels = (("work", "bound_work", "work W (points)"),
              (efficiency, "bound_efficiency", "efficiency" if efficiency == "efficiency"
               else "efficiency: work energy/(total + lost)"))
    values = np.sort(runs.loc[runs["strategy"] != "fixed" if fixed_line else slice(None), x].unique())
    span = np.log10(values[-1] / values[0]) if log_x else values[-1] - values[0]
    strategy_styles = styles(runs["strategy"], STRATEGY_STYLES)
    trials = int(runs.groupby(["strategy", x]).size().max())
    with _figure(path, (DOUBLE_COLUMN, 3.0), PRINT_RC, ncols=2) as (mpl, fig, axes):
        for ax, (column, bound, label) in zip(axes, panels):
            for s, (strategy, style) in enumerate(strategy_styles.items()):
                colour = style.colour
                mine = runs[runs["strategy"] == strategy]
                limit = bounds[bounds["strategy"] == strategy].sort_values(x)
                if fixed_line and strategy == "fixed":
                    ax.axhline(mine[column].mean(), color=colour, lw=1.5, ls=style.linestyle,
                               label=f"{LABELS.get(strategy, strategy)}: mean")
                    ax.axhline(limit[bound].iloc[0], color=colour, lw=1, ls="--",
                               label=f"{LABELS.get(strategy, strategy)}: bound")
                    continue
                dodge = _dodge(s, len(strategy_styles), 1.5 * _SPREAD)
                offset = dodge * span
                shift = (lambda v, d=offset: v * 10.0 ** d) if log_x else (lambda v, d=offset: v + d)
                for value, group in mine.groupby(x):
                    n = len(group)
                    xs = [_spread(shift(value), k, n, log_x, span) for k in range(n)]
                    ax.plot(xs, group[column], style.marker, color=colour, ms=1.5, alpha=0.35, mew=0)
                means = mine.groupby(x)[column].mean()
                ax.plot([shift(v) for v in means.index], means.to_numpy(), marker=style.marker, ls=style.linestyle,
                        color=colour, ms=3.5, lw=1, label=f"{LABELS.get(strategy, strategy)}: trials and mean")
                ax.plot(limit[x], limit[bound], marker=style.marker, ls="--", color=colour, lw=1, ms=3.5,
                        markerfacecolor="none", label=f"{LABELS.get(strategy, strategy)}: bound")
            if log_x:
                ax.set_xscale("log")
                ax.set_xticks(values, [f"{v:g}" for v in values])
                ax.minorticks_off()
            else:
                ax.set_xticks(values, [f"{v:g}" for v in values])
            if column == efficiency:  # a ratio: the whole of [0, 1] (Fig 12's loss bound leaves it below)
                ax.set_ylim(0.0, 1.02)
            ax.set_xlabel(xlabel)
            ax.set_ylabel(label)
            ax.grid(alpha=0.3)
        letter_panels(axes)
        fig.legend(handles=axes[0].get_legend_handles_labels()[0], loc="outside upper center", ncols=4,
                   title=f"{trials} trials per point")
    return figure_paths(path)
