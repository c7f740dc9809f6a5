"""The items study's figures (Liemhetcharat et al. 2015, Figs 1-12) from tidy tables alone.

Each function reads the tables :mod:`dronefleet.items.study` writes (one row per configuration
and trial; Figs 1-2 one row per step) and draws one figure as PNG, PDF and SVG with the style
of :mod:`dronefleet.figstyle`: print size (a column, :data:`~dronefleet.figstyle.SINGLE_COLUMN`,
or a page wide, :data:`~dronefleet.figstyle.DOUBLE_COLUMN`), no text below 7 pt, no titles
(the captions live in ``results/README.md``), panels lettered as the paper letters them; the
same tables give the same bytes. Each algorithm has its :data:`~dronefleet.figstyle.ALGORITHM_STYLES`
colour, marker and line style in every figure. The paper's 3-D figures are drawn as wireframes
in those colours (an opaque or translucent surface hides or blends the others) beside one heat
map per algorithm, every heat map and z-axis of a figure on one scale. The option a figure was
run under is said in words in its legend's title. Nothing here imports the simulator.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from ..figstyle import (ALGORITHM_STYLES, DOUBLE_COLUMN, PRINT_RC, SINGLE_COLUMN, _figure, figure_paths,
                        letter_panels, styles)

if TYPE_CHECKING:
    import pandas

#: Axis words of the config columns.
AXES = {"n_robots": "robots n", "capacity": "capacity c (items)", "speed": "speed s (world widths per step)",
        "sigma_e": "process noise $\\sigma_e$", "mu_l": "mean demand rate $\\mu_\\lambda$ (per location, step)"}
#: Panel titles in words: column -> format of one value.
PANEL_WORDS = {"n_robots": "n = {:g} robots", "capacity": "capacity c = {:g}", "speed": "speed s = {:g}",
               "sigma_e": "process noise $\\sigma_e$ = {:g}", "mu_l": "$\\mu_\\lambda$ = {:g}"}
#: Columns that take whole numbers only: their ticks are integers.
INTEGER = frozenset({"n_robots", "capacity"})
#: The algorithms in the paper's order (legend order).
ORDER = ("GRIC", "GR", "R", "CAS", "AS", "ASTC", "SF")


class Block(NamedTuple):
    """One row of a 3-D figure: ``runs`` (per-trial rows of its algorithms) over ``x`` and ``y``
    (config columns); ``heading`` names the row (its sigma_e, say; "" for none)."""
    runs: pandas.DataFrame
    x: str
    y: str
    heading: str = ""


def rate_label(runs: pandas.DataFrame) -> str:
    """What ``rate`` is in ``runs``: the share of demands served (item delivery), the items brought
    home in the run (logistic truth) or the share of resources foraged (Bernoulli, Poisson)."""
    if (runs["mode"] == "delivery").any():
        return "demands served (%)"
    if (runs["truth"] == "logistic").any():
        return "items brought home F"
    return "foraging rate (%)"


def panel_title(column: str, value: float) -> str:
    """A panel's title in words: ``capacity c = 5``."""
    return PANEL_WORDS.get(column, column + " = {:g}").format(value)


def _algorithms(runs):
    found = set(runs["algorithm"])
    return [a for a in ORDER if a in found] + sorted(found - set(ORDER))


def _trials(runs, keys):
    return int(runs.groupby(["algorithm", *keys]).size().max())


def _means(runs, x, y):
    """Mean rate per (y, x) as a grid (rows y, columns x)."""
    return runs.groupby([y, x])["rate"].mean().unstack(x)


def _edges(centres):
    """Cell edges around sorted ``centres`` (the midpoints; the outer cells as wide as their neighbour)."""
    centres = np.asarray(centres, dtype=float)
    if len(centres) == 1:
        return np.array([centres[0] - 0.5, centres[0] + 0.5])
    middle = (centres[1:] + centres[:-1]) / 2
    return np.concatenate([[2 * centres[0] - middle[0]], middle, [2 * centres[-1] - middle[-1]]])


def _ticks(axis, column, values, mpl, most=5):
    """Integer ticks on an integer ``column`` (at most ``most``), else the grid's own values."""
    if column in INTEGER:
        axis.set_major_locator(mpl.ticker.MaxNLocator(nbins=most, integer=True, steps=(1, 2, 5, 10), min_n_ticks=2))
    else:
        values = np.asarray(values, dtype=float)
        axis.set_major_locator(mpl.ticker.FixedLocator(values[::max(1, -(-len(values) // most))]))
        axis.set_major_formatter(mpl.ticker.FormatStrFormatter("%g"))


def _legend(fig, handles, title):
    """One legend for the figure, below its panels, one entry per algorithm in a row."""
    fig.legend(handles=handles, loc="outside lower center", ncols=len(handles), frameon=False, title=title)


def surfaces(blocks: Sequence[Block], path: str | os.PathLike, words: str = "") -> list[Path]:
    """Figs 3, 5, 7, 9: per block (a row), the mean rate over (x, y) as one wireframe per algorithm
    in a 3-D axes, and beside it one heat map per algorithm; every z-axis and heat map of the
    figure on one scale (Fig 7: the sigma_e rows compare). Rows are lettered (a), (b), ... when
    there are several.

    Parameters
    ----------
    blocks : sequence of Block
        The rows, top to bottom; each block's runs hold ``algorithm``, ``rate`` and its x and y columns.
    path : str or Path
        Figure file name (its suffix is replaced by each format's).
    words : str
        The options it was run under, in words, for the legend's title.
    """
    from matplotlib.lines import Line2D

    algorithms = _algorithms(blocks[0].runs)
    algorithm_styles = styles(algorithms, ALGORITHM_STYLES)
    grids = [{a: _means(block.runs[block.runs["algorithm"] == a], block.x, block.y) for a in algorithms}
             for block in blocks]
    low = min(float(np.nanmin(grid.to_numpy(dtype=float))) for row in grids for grid in row.values())
    high = max(float(np.nanmax(grid.to_numpy(dtype=float))) for row in grids for grid in row.values())
    trials = max(_trials(block.runs, [block.x, block.y]) for block in blocks)
    k = len(algorithms)
    mosaic = [[f"3d{r}", *(f"{r}:{a}" for a in algorithms)] for r in range(len(blocks))]
    height = (2.55 if len(blocks) == 1 else 1.95) * len(blocks) + 0.55
    with _figure(path, (DOUBLE_COLUMN, height), PRINT_RC, mosaic, width_ratios=(2.6 + 0.1 * k, *[1.0] * k),
                 per_subplot_kw={f"3d{r}": {"projection": "3d"} for r in range(len(blocks))}) as (mpl, fig, axes):
        images = []
        for r, (block, row) in enumerate(zip(blocks, grids)):
            ax = axes[f"3d{r}"]
            for algorithm in algorithms:
                grid, style = row[algorithm], algorithm_styles[algorithm]
                gx, gy = np.meshgrid(grid.columns.to_numpy(dtype=float), grid.index.to_numpy(dtype=float))
                ax.plot_wireframe(gx, gy, grid.to_numpy(dtype=float), color=style.colour, linewidth=0.6,
                                  linestyles=style.linestyle, rcount=10, ccount=10)
            ax.set_zlim(low, high)
            for axis, column in ((ax.xaxis, block.x), (ax.yaxis, block.y)):
                _ticks(axis, column, row[algorithms[0]].columns if axis is ax.xaxis else row[algorithms[0]].index,
                       mpl, most=4)
            ax.zaxis.set_major_locator(mpl.ticker.MaxNLocator(nbins=3))
            ax.set_xlabel(AXES.get(block.x, block.x), labelpad=-6)
            ax.set_ylabel(AXES.get(block.y, block.y).split(" (")[0], labelpad=-6)
            ax.set_zlabel(rate_label(block.runs), labelpad=-5)
            ax.tick_params(pad=-3)
            ax.view_init(elev=25, azim=-135)
            ax.set_box_aspect(None, zoom=0.92)  # room for the labels inside the panel
            for column, algorithm in enumerate(algorithms):
                heat = axes[f"{r}:{algorithm}"]
                grid = row[algorithm]
                images.append(heat.pcolormesh(_edges(grid.columns), _edges(grid.index), grid.to_numpy(dtype=float),
                                              cmap="viridis", vmin=low, vmax=high, rasterized=True))
                _ticks(heat.xaxis, block.x, grid.columns, mpl, most=4)
                _ticks(heat.yaxis, block.y, grid.index, mpl)
                heat.set_title(algorithm, color=algorithm_styles[algorithm].colour, fontweight="bold", pad=2)
                heat.set_xlabel(AXES.get(block.x, block.x), labelpad=1)
                if column == 0:
                    heat.set_ylabel(AXES.get(block.y, block.y))
                else:
                    heat.tick_params(labelleft=False)
            if block.heading:  # after the panel's letter
                ax.set_title(block.heading, loc="left", pad=5)
        fig.colorbar(images[0], ax=[axes[f"{r}:{a}"] for r in range(len(blocks)) for a in algorithms],
                     label=f"mean {rate_label(blocks[0].runs)}", fraction=0.04, pad=0.02, aspect=12 * len(blocks))
        if len(blocks) > 1:
            letter_panels([axes[f"3d{r}"] for r in range(len(blocks))])
        _legend(fig, [Line2D([], [], color=algorithm_styles[a].colour, ls=algorithm_styles[a].linestyle, lw=1.2,
                             label=a) for a in algorithms],
                "; ".join(part for part in (f"mean of {trials} trials per cell", words) if part))
    return figure_paths(path)


def slices(runs: pandas.DataFrame, path: str | os.PathLike, x: str, panel: str, words: str = "") -> list[Path]:
    """Figs 4, 6, 8, 10, 11, 12: the rate against ``x``, one panel per value of ``panel`` (lettered
    (a), (b), ... when there are several), each algorithm's mean (line and marker) with a band of
    +- one standard deviation over the trials; the panels share the y-axis. ``words``: as
    :func:`surfaces`'s."""
    panels = sorted(runs[panel].unique())
    algorithms = _algorithms(runs)
    algorithm_styles = styles(algorithms, ALGORITHM_STYLES)
    trials = _trials(runs, [x, panel])
    with _figure(path, (DOUBLE_COLUMN, 2.55), PRINT_RC, ncols=len(panels), squeeze=False, sharey=True) as \
            (mpl, fig, axes):
        for ax, value in zip(axes.flat, panels):
            mine = runs[runs[panel] == value]
            for algorithm in algorithms:
                stats = mine[mine["algorithm"] == algorithm].groupby(x)["rate"].agg(["mean", "std"])
                style = algorithm_styles[algorithm]
                xs = stats.index.to_numpy(dtype=float)
                ax.fill_between(xs, stats["mean"] - stats["std"], stats["mean"] + stats["std"], color=style.colour,
                                alpha=0.15, lw=0)
                ax.plot(xs, stats["mean"], marker=style.marker, ls=style.linestyle, color=style.colour, ms=3.5,
                        lw=1.0, label=algorithm)
            _ticks(ax.xaxis, x, sorted(mine[x].unique()), mpl)
            ax.set_title(panel_title(panel, value), pad=3)
            ax.set_xlabel(AXES.get(x, x))
            ax.grid(alpha=0.3)
        axes.flat[0].set_ylabel(rate_label(runs))
        if len(panels) > 1:
            letter_panels(axes.flat)
        handles, _ = axes.flat[0].get_legend_handles_labels()
        _legend(fig, handles, "; ".join(part for part in (f"mean +- sd of {trials} trials", words) if part))
    return figure_paths(path)


def logistic(curve: pandas.DataFrame, path: str | os.PathLike) -> list[Path]:
    """Fig 1: the deterministic logistic population (Eq. 3) against time, a column wide."""
    with _figure(path, (SINGLE_COLUMN, 2.4), PRINT_RC) as (mpl, fig, ax):
        ax.plot(curve["step"], curve["x"], color=ALGORITHM_STYLES["GR"].colour, lw=1.2)
        ax.set_xlabel("time step t")
        ax.set_ylabel("population x(t) (items)")
        ax.grid(alpha=0.3)
    return figure_paths(path)


def logistic_paths(paths: pandas.DataFrame, curve: pandas.DataFrame, path: str | os.PathLike) -> list[Path]:
    """Fig 2: the stochastic logistic paths (Eq. 10), thin, and the noise-free curve dotted, a column wide."""
    with _figure(path, (SINGLE_COLUMN, 2.4), PRINT_RC) as (mpl, fig, ax):
        for _, one in paths.groupby("path"):
            ax.plot(one["step"], one["x"], color=ALGORITHM_STYLES["CAS"].colour, lw=0.4, alpha=0.3)
        ax.plot(curve["step"], curve["x"], color="black", lw=1.4, ls=":", label="noise-free (Eq. 3)")
        ax.set_xlabel("time step t")
        ax.set_ylabel("population x(t) (items)")
        ax.legend(title=f"{paths['path'].nunique()} paths of Eq. 10", loc="lower right")
        ax.grid(alpha=0.3)
    return figure_paths(path)


def write_ttests(table: pandas.DataFrame, path: str | os.PathLike) -> list[Path]:
    """The t-test table as CSV and markdown (``<path>.csv``, ``<path>.md``), each renamed into place."""
    path = Path(path)
    columns = list(table.columns)
    lines = ["| " + " | ".join(columns) + " |", "|" + "---|" * len(columns)]
    lines += ["| " + " | ".join(f"{v:.4g}" if isinstance(v, float) else str(v) for v in row) + " |"
              for row in table.itertuples(index=False)]
    out = []
    for suffix, write in ((".csv", lambda p: table.to_csv(p, index=False, float_format="%.6g")),
                          (".md", lambda p: p.write_text("\n".join(lines) + "\n"))):
        target = path.with_suffix(suffix)
        tmp = target.with_name(f".{target.name}.{os.getpid()}.tmp")
        try:
            write(tmp)
            os.replace(tmp, target)
        finally:
            tmp.unlink(missing_ok=True)
        out.append(target)
    return out
