"""The items study's figures (Liemhetcharat et al. 2015, Figs 1-12) from tidy tables alone.

Each function reads the tables :mod:`dronefleet.items.study` writes (one row per configuration
and trial; Figs 1-2 one row per step) and draws one figure as PNG, PDF and SVG with the style
of :mod:`dronefleet.figstyle` (the same tables give the same bytes). Each algorithm has its
:data:`dronefleet.figstyle.ALGORITHM_STYLES` colour and marker in every figure. A figure that
depends on an option (the CAS rule, ``cas_variant``; the robots' assumed rate, ``lam_hat_source``) says which
in its title.
Nothing here imports the simulator.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..figstyle import ALGORITHM_STYLES, _figure, figure_paths, styles

if TYPE_CHECKING:
    import pandas

#: Axis words of the config columns.
AXES = {"n_robots": "robots n", "capacity": "capacity c (items)", "speed": "speed s (N per step)",
        "sigma_e": "sigma_e", "mu_l": "mean demand rate mu_l (per location per step)"}
#: The algorithms in the paper's order (legend order).
ORDER = ("GRIC", "GR", "R", "CAS", "AS", "ASTC", "SF")


def rate_label(runs: pandas.DataFrame) -> str:
    """What ``rate`` is in ``runs``: % of generated items served, or items foraged under logistic truth."""
    if (runs["mode"] == "delivery").any():
        return "demands served (% of generated)"
    if (runs["truth"] == "logistic").any():
        return "items brought home in T steps (F)"
    return "foraging rate (% of generated)"


def _algorithms(runs):
    found = set(runs["algorithm"])
    return [a for a in ORDER if a in found] + sorted(found - set(ORDER))


def _title(fig, words, trials):
    fig.suptitle(", ".join(part for part in (words, f"{trials} trials per point") if part), fontsize=9)


def _panels(runs, panel):
    return [None] if panel is None else sorted(runs[panel].unique())


def _means(runs, x, y):
    """Mean rate per (y, x) as a grid (rows y, columns x)."""
    return runs.groupby([y, x])["rate"].mean().unstack(x)


def surfaces(runs: pandas.DataFrame, path: str | os.PathLike, x: str, y: str, panel: str | None = None,
             words: str = "") -> list[Path]:
    """Figs 3, 5, 7, 9: the mean rate over (x, y) as one 3-D surface per algorithm, as the paper draws them.

    One 3-D axes per value of ``panel`` (Fig 7: sigma_e), every algorithm's surface in it.

    Parameters
    ----------
    runs : pandas.DataFrame
        Per-trial rows: ``algorithm``, ``x``, ``y``, ``rate`` (and ``panel``).
    path : str or Path
        Figure file name (its suffix is replaced by each format's).
    x, y, panel : str
        Columns of the two axes and of the panels (None: one panel).
    words : str
        The option it was run with, for the title.
    """
    from matplotlib.patches import Patch

    panels = _panels(runs, panel)
    algorithms = _algorithms(runs)
    algorithm_styles = styles(algorithms, ALGORITHM_STYLES)
    trials = int(runs.groupby(["algorithm", x, y] + ([panel] if panel else [])).size().max())
    with _figure(path, (5.2 * len(panels), 4.8), ncols=len(panels), squeeze=False,
                 subplot_kw={"projection": "3d"}) as (mpl, fig, axes):
        for ax, value in zip(axes.flat, panels):
            mine = runs if panel is None else runs[runs[panel] == value]
            for algorithm in algorithms:
                grid = _means(mine[mine["algorithm"] == algorithm], x, y)
                gx, gy = np.meshgrid(grid.columns.to_numpy(dtype=float), grid.index.to_numpy(dtype=float))
                colour = algorithm_styles[algorithm].colour
                ax.plot_surface(gx, gy, grid.to_numpy(dtype=float), color=colour, alpha=0.55, edgecolor=colour,
                                linewidth=0.3, shade=False)
            ax.set_xlabel(AXES.get(x, x), fontsize=8)
            ax.set_ylabel(AXES.get(y, y), fontsize=8)
            ax.set_zlabel(rate_label(runs), fontsize=8)
            ax.view_init(elev=25, azim=-135)
            ax.set_box_aspect(None, zoom=0.85)  # room for the z label inside the panel
            if panel is not None:
                ax.set_title(f"{panel} = {value:g}", fontsize=9)
        axes.flat[0].legend(handles=[Patch(color=algorithm_styles[a].colour, label=a) for a in algorithms],
                            fontsize=8, loc="upper left")
        _title(fig, words, trials)
    return figure_paths(path)


def heatmaps(runs: pandas.DataFrame, path: str | os.PathLike, x: str, y: str, panel: str | None = None,
             words: str = "") -> list[Path]:
    """The heat-map version of :func:`surfaces` that reads in print: one panel per algorithm (columns)
    and value of ``panel`` (rows), the mean rate per (x, y) cell on one colour scale per row."""
    panels = _panels(runs, panel)
    algorithms = _algorithms(runs)
    trials = int(runs.groupby(["algorithm", x, y] + ([panel] if panel else [])).size().max())
    with _figure(path, (3.2 * len(algorithms) + 1.0, 3.0 * len(panels) + 0.6), nrows=len(panels),
                 ncols=len(algorithms), squeeze=False) as (mpl, fig, axes):
        for row, value in zip(axes, panels):
            mine = runs if panel is None else runs[runs[panel] == value]
            low, high = mine.groupby(["algorithm", x, y])["rate"].mean().agg(["min", "max"])
            for ax, algorithm in zip(row, algorithms):
                grid = _means(mine[mine["algorithm"] == algorithm], x, y)
                image = ax.imshow(grid.to_numpy(dtype=float), origin="lower", cmap="viridis", aspect="auto",
                                  vmin=low, vmax=high)
                ax.set_xticks(range(len(grid.columns)), [f"{v:g}" for v in grid.columns], fontsize=6)
                ax.set_yticks(range(len(grid.index)), [f"{v:g}" for v in grid.index], fontsize=6)
                ax.set_xlabel(AXES.get(x, x), fontsize=8)
                ax.set_ylabel(AXES.get(y, y), fontsize=8)
                ax.set_title(algorithm if panel is None else f"{algorithm}, {panel} = {value:g}", fontsize=9)
            fig.colorbar(image, ax=list(row), fraction=0.03, pad=0.02, label=f"mean {rate_label(runs)}")
        _title(fig, words, trials)
    return figure_paths(path)


def slices(runs: pandas.DataFrame, path: str | os.PathLike, x: str, panel: str, words: str = "") -> list[Path]:
    """Figs 4, 6, 8, 10, 11, 12: the rate against ``x``, one panel per value of ``panel``, each
    algorithm's mean (line and marker) with a band of +- one standard deviation over the trials."""
    panels = _panels(runs, panel)
    algorithms = _algorithms(runs)
    algorithm_styles = styles(algorithms, ALGORITHM_STYLES)
    trials = int(runs.groupby(["algorithm", x, panel]).size().max())
    with _figure(path, (3.6 * len(panels) + 0.4, 3.6), ncols=len(panels), squeeze=False, sharey=True) as \
            (mpl, fig, axes):
        for ax, value in zip(axes.flat, panels):
            mine = runs[runs[panel] == value]
            for algorithm in algorithms:
                stats = mine[mine["algorithm"] == algorithm].groupby(x)["rate"].agg(["mean", "std"])
                style = algorithm_styles[algorithm]
                xs = stats.index.to_numpy(dtype=float)
                ax.fill_between(xs, stats["mean"] - stats["std"], stats["mean"] + stats["std"], color=style.colour,
                                alpha=0.18, lw=0)
                ax.plot(xs, stats["mean"], marker=style.marker, ls=style.linestyle, color=style.colour, ms=4, lw=1.2,
                        label=algorithm)
            ax.set_title(f"{panel} = {value:g}", fontsize=9)
            ax.set_xlabel(AXES.get(x, x))
            ax.grid(alpha=0.3)
        axes.flat[0].set_ylabel(rate_label(runs))
        axes.flat[0].legend(fontsize=8, title="mean +- sd", title_fontsize=8)
        _title(fig, words, trials)
    return figure_paths(path)


def logistic(curve: pandas.DataFrame, path: str | os.PathLike) -> list[Path]:
    """Fig 1: the deterministic logistic population (Eq. 3) against time."""
    with _figure(path, (5.0, 3.6)) as (mpl, fig, ax):
        ax.plot(curve["step"], curve["x"], color=ALGORITHM_STYLES["GR"].colour, lw=1.5)
        ax.set_xlabel("time step t")
        ax.set_ylabel("population x(t)")
        ax.grid(alpha=0.3)
    return figure_paths(path)


def logistic_paths(paths: pandas.DataFrame, curve: pandas.DataFrame, path: str | os.PathLike) -> list[Path]:
    """Fig 2: the stochastic logistic paths (Eq. 10), thin, and the noise-free curve dotted."""
    with _figure(path, (5.0, 3.6)) as (mpl, fig, ax):
        for _, one in paths.groupby("path"):
            ax.plot(one["step"], one["x"], color=ALGORITHM_STYLES["CAS"].colour, lw=0.5, alpha=0.35)
        ax.plot(curve["step"], curve["x"], color="black", lw=1.8, ls=":", label="noise-free (Eq. 3)")
        ax.set_xlabel("time step t")
        ax.set_ylabel("population x(t)")
        ax.legend(fontsize=8, title=f"{paths['path'].nunique()} paths of Eq. 10", title_fontsize=8)
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
