"""The study's figures (docs/delivery-experiments.md, Figures 16-20) as PNG, PDF and SVG files, from tidy tables alone.

Each function takes a table of :mod:`dronefleet.delivery.analysis` (as stored in parquet under
``results/<figure>/``), draws one figure and writes it to ``path`` in each format of
:data:`dronefleet.figstyle.FORMATS` (``path``'s suffix replaced). Nothing here imports
the simulator, so a figure can be redrawn without re-simulating.

Drawn in the shared style of :mod:`dronefleet.figstyle` (matplotlib only when a figure is
drawn, never pyplot, no titles, the same table gives the same bytes). Each rule (``rule``
column) has its colour, marker, line style and hatch of
:data:`dronefleet.figstyle.RULE_STYLES` in every figure.
"""

import os
from pathlib import Path

import numpy as np
import pandas as pd

from ..figstyle import RULE_STYLES, _dodge, _figure, figure_paths, styles

SECONDS_PER_MINUTE = 60.0
SECONDS_PER_DAY = 86_400.0


#: Labels of Fig. 16a/19a closer than this (axes fraction, along x and along y) would overlap.
_LABEL_CLEARANCE = 0.035


def _rule_styles(rules):
    return styles(rules, RULE_STYLES)


def _legend_patches(mpl, rule_styles):
    return [mpl.patches.Patch(facecolor=style.colour, alpha=0.6, hatch=style.hatch, edgecolor=style.colour,
                              label=rule) for rule, style in rule_styles.items()]


def _panel_label(ax, text):
    """``text`` in the upper right corner of ``ax``, on white: names a panel (figures have no titles)."""
    ax.text(0.97, 0.97, text, transform=ax.transAxes, ha="right", va="top", fontsize=9,
            bbox=dict(facecolor="white", edgecolor="none", alpha=0.8, pad=2))


def _tau_labels(ax, corners, rule_styles):
    """Write each box's tau at its upper right corner, once for the boxes of one tau whose corners meet.

    ``corners``: ``(rule, tau, x, y)`` in data coordinates, in drawing order. Boxes of
    one tau whose corners lie within :data:`_LABEL_CLEARANCE` of a corner already labelled
    share that label (drawn in black then): at light load the rules' boxes coincide and
    their labels would overprint each other.
    """
    to_axes = ax.transData + ax.transAxes.inverted()  # the limits are final: data are all drawn
    groups = []  # [tau, [rules], [(x, y) axes fractions]]
    for rule, tau, x, y in corners:
        point = to_axes.transform((x, y))
        group = next((g for g in groups if g[0] == tau and any(
            abs(point - other).max() < _LABEL_CLEARANCE for other in g[2])), None)
        if group is None:
            groups.append([tau, [rule], [point]])
        else:
            group[1].append(rule)
            group[2].append(point)
    for tau, rules, points in groups:
        ax.annotate(f"{tau:g}", np.max(points, axis=0), xycoords="axes fraction", xytext=(2, 2),
                    textcoords="offset points", fontsize=7,
                    color=rule_styles[rules[0]].colour if len(rules) == 1 else "black")


def delivered_vs_delivery_time(outcomes: pd.DataFrame, path: str | os.PathLike) -> list[Path]:
    """2-D box plots of delivered parcels against delivery time, one per (rule, tau) (Fig. 16a/19a).

    x: per-run median delivery time (min, log scale), y: delivered parcels. Each box spans the
    quartiles on both axes with a cross at the medians; whiskers (1.5 IQR, matplotlib's
    rule) run along the median lines; runs outside a whisker are dots. tau (min) is
    written at the box's upper right corner, once for boxes of one tau that meet. Runs
    without a delivery have no delivery time and are left out of the x statistics.

    Parameters
    ----------
    outcomes : pandas.DataFrame
        :func:`dronefleet.delivery.analysis.run_outcomes` rows: ``rule, tau_minutes, delivered,
        median_delivery_time_s``.
    path : str or Path
        Figure file name (its suffix is replaced by each format's).

    Returns
    -------
    list of Path
        The figure's files, one per format.
    """
    rule_styles = _rule_styles(outcomes["rule"])
    groups = outcomes.groupby(["rule", "tau_minutes"], sort=True)
    with _figure(path, (8.0, 6.0)) as (mpl, fig, ax):
        corners = []
        for (rule, tau), runs in groups:
            style = rule_styles[rule]
            minutes = runs["median_delivery_time_s"].to_numpy(np.float64) / SECONDS_PER_MINUTE
            delivered = runs["delivered"].to_numpy(np.float64)
            sx = mpl.cbook.boxplot_stats(minutes[~np.isnan(minutes)])[0]
            sy = mpl.cbook.boxplot_stats(delivered)[0]
            ax.add_patch(mpl.patches.Rectangle((sx["q1"], sy["q1"]), sx["q3"] - sx["q1"], sy["q3"] - sy["q1"],
                                               facecolor=style.colour, alpha=0.3, edgecolor=style.colour,
                                               hatch=style.hatch))
            ax.plot([sx["whislo"], sx["whishi"]], [sy["med"], sy["med"]], color=style.colour, ls=style.linestyle,
                    lw=1)
            ax.plot([sx["med"], sx["med"]], [sy["whislo"], sy["whishi"]], color=style.colour, ls=style.linestyle,
                    lw=1)
            outside = ((minutes < sx["whislo"]) | (minutes > sx["whishi"])
                       | (delivered < sy["whislo"]) | (delivered > sy["whishi"]))
            ax.plot(minutes[outside], delivered[outside], style.marker, color=style.colour, ms=3)
            corners.append((rule, tau, sx["q3"], sy["q3"]))
        ax.set_xscale("log")  # medians span minutes (light load) to days (overload)
        ax.autoscale_view()
        _tau_labels(ax, corners, rule_styles)
        ax.xaxis.set_major_formatter(mpl.ticker.FormatStrFormatter("%g"))
        ax.set_xlabel("delivery time, per-run median (min, log scale)")
        ax.set_ylabel("delivered parcels per run")
        ax.legend(handles=_legend_patches(mpl, rule_styles), fontsize=8, title_fontsize=8,
                  title=f"rule, {groups.size().max()} runs per box\nlabels: tau (min), black: shared")
    return figure_paths(path)


def aborted_by_tau(outcomes: pd.DataFrame, path: str | os.PathLike) -> list[Path]:
    """Box plots of aborted attempts (% of all attempts) against tau, side by side per rule (Fig. 16b/19b).

    Parameters
    ----------
    outcomes : pandas.DataFrame
        :func:`dronefleet.delivery.analysis.run_outcomes` rows: ``rule, tau_minutes, aborted_pct``.
    path : str or Path
        Figure file name (its suffix is replaced by each format's).

    Returns
    -------
    list of Path
    """
    rule_styles = _rule_styles(outcomes["rule"])
    taus = np.sort(outcomes["tau_minutes"].unique())
    step = np.diff(taus).min() if taus.size > 1 else 1.0
    width = 0.8 * step / len(rule_styles)
    with _figure(path, (8.0, 4.5)) as (mpl, fig, ax):
        for k, (rule, style) in enumerate(rule_styles.items()):
            runs = outcomes[outcomes["rule"] == rule]
            at, stats = zip(*[(tau, mpl.cbook.boxplot_stats(values.dropna().to_numpy())[0])
                              for tau, values in runs.groupby("tau_minutes", sort=True)["aborted_pct"]])
            offset = _dodge(k, len(rule_styles), width)
            ax.bxp(stats, positions=np.array(at) + offset, widths=0.9 * width, patch_artist=True,
                   manage_ticks=False,
                   boxprops=dict(facecolor=style.colour, alpha=0.6, hatch=style.hatch, edgecolor=style.colour),
                   whiskerprops=dict(color=style.colour, ls=style.linestyle), capprops=dict(color=style.colour),
                   medianprops=dict(color="black"),
                   flierprops=dict(marker=style.marker, markeredgecolor=style.colour, markersize=3))
        ax.set_xticks(taus, [f"{tau:g}" for tau in taus])
        ax.set_xlabel("mean inter-arrival time tau (min)")
        ax.set_ylabel("aborted attempts (% of attempts)")
        ax.legend(handles=_legend_patches(mpl, rule_styles), title="rule", fontsize=8)
    return figure_paths(path)


def backlog_bars(backlog: pd.DataFrame, path: str | os.PathLike) -> list[Path]:
    """Backlog age at the end, stacked by arrival week, per tau; one panel per rule (Fig. 16c/19c).

    Bar height: the mean over runs of the summed age (horizon - arrival) of the orders
    pending at the end, in days; each segment holds the orders of one arrival week.

    Parameters
    ----------
    backlog : pandas.DataFrame
        :func:`dronefleet.delivery.analysis.backlog_by_arrival_week` rows: ``rule, tau_minutes, seed,
        arrival_week, backlog_age_s``.
    path : str or Path
        Figure file name (its suffix is replaced by each format's).

    Returns
    -------
    list of Path
    """
    days = (backlog.groupby(["rule", "tau_minutes", "arrival_week"], sort=True)["backlog_age_s"].mean()
            / SECONDS_PER_DAY).unstack("arrival_week", fill_value=0.0)
    rules = days.index.get_level_values("rule").unique()
    weeks = days.columns
    with _figure(path, (3.2 * len(rules) + 1.5, 4.5), ncols=len(rules), sharey=True,
                 squeeze=False) as (mpl, fig, axes):
        # viridis: its lightness rises with the week, so the weeks stay apart in greyscale too
        week_colours = mpl.colormaps["viridis"](np.linspace(0.0, 0.9, len(weeks)))
        for ax, rule in zip(axes[0], rules):
            stack = days.loc[rule]
            taus = [f"{tau:g}" for tau in stack.index]
            bottom = np.zeros(len(stack))
            for week, colour in zip(weeks, week_colours):
                ax.bar(taus, stack[week], bottom=bottom, color=colour, label=f"week {week}")
                bottom += stack[week].to_numpy()
            _panel_label(ax, rule)
            ax.set_xlabel("tau (min)")
        axes[0, 0].set_ylabel("backlog age at the end (days)\nsum over pending orders, mean over runs")
        axes[0, -1].legend(title="arrival week", fontsize=8, loc="upper left", bbox_to_anchor=(1.0, 1.0))
    return figure_paths(path)


def accuracy_over_weeks(accuracy: pd.DataFrame, path: str | os.PathLike) -> list[Path]:
    """Mean decision accuracy per week, one line per rule with its confidence band (Fig. 17).

    Parameters
    ----------
    accuracy : pandas.DataFrame
        :func:`dronefleet.delivery.analysis.weekly_accuracy` rows: ``rule, week, uavs,
        mean_accuracy, ci_low, ci_high, confidence``.
    path : str or Path
        Figure file name (its suffix is replaced by each format's).

    Returns
    -------
    list of Path
    """
    rule_styles = _rule_styles(accuracy["rule"])
    with _figure(path, (7.0, 4.5)) as (mpl, fig, ax):
        for rule, style in rule_styles.items():
            rows = accuracy[accuracy["rule"] == rule].sort_values("week")
            ax.fill_between(rows["week"], rows["ci_low"], rows["ci_high"], color=style.colour, alpha=0.25, lw=0)
            ax.plot(rows["week"], rows["mean_accuracy"], marker=style.marker, ls=style.linestyle,
                    color=style.colour, ms=4, label=f"{rule} (n = {rows['uavs'].max()} UAVs)")
        confidence = accuracy["confidence"].iloc[0]
        ax.set_xlabel("end of week")
        ax.set_ylabel("decision accuracy (share of 1000 test points)")
        ax.set_xticks(np.sort(accuracy["week"].unique()))
        ax.legend(title=f"rule; band: {100 * confidence:g} % CI of the mean", fontsize=8)
    return figure_paths(path)


def winner_soh_heatmaps(grid: pd.DataFrame, path: str | os.PathLike) -> list[Path]:
    """Mean SoH of the auction winner over distance and mass, one heatmap per SoC (Fig. 18).

    Blank where nobody bid in any run; one colour scale for every panel.

    Parameters
    ----------
    grid : pandas.DataFrame
        :func:`dronefleet.delivery.analysis.winner_soh_grid` rows: ``soc, distance_m, mass_kg,
        mean_winner_soh``.
    path : str or Path
        Figure file name (its suffix is replaced by each format's).

    Returns
    -------
    list of Path
    """
    socs = np.sort(grid["soc"].unique())
    ncols = min(5, len(socs))
    nrows = -(-len(socs) // ncols)
    vmin, vmax = grid["mean_winner_soh"].min(), grid["mean_winner_soh"].max()
    with _figure(path, (3.0 * ncols + 1.0, 2.6 * nrows + 0.6), nrows=nrows, ncols=ncols,
                 sharex=True, sharey=True, squeeze=False) as (mpl, fig, axes):
        for ax, soc in zip(axes.flat, socs):
            cells = grid[grid["soc"] == soc].pivot(index="mass_kg", columns="distance_m", values="mean_winner_soh")
            # rasterized: in PDF and SVG the 7,000 cells as one image, not one path each (14 MB of SVG)
            mesh = ax.pcolormesh(cells.columns / 1000.0, cells.index, cells.to_numpy(), shading="nearest",
                                 cmap="viridis", vmin=vmin, vmax=vmax, rasterized=True)
            _panel_label(ax, f"SoC = {soc:g} %")
        for ax in axes.flat[len(socs):]:
            ax.set_visible(False)
        for ax in axes[-1]:
            ax.set_xlabel("distance (km)")
        for ax in axes[:, 0]:
            ax.set_ylabel("parcel mass (kg)")
        fig.colorbar(mesh, ax=axes, label="mean SoH of the winner (blank: nobody bids)", fraction=0.03, pad=0.01)
    return figure_paths(path)


def write_threshold_table(table: pd.DataFrame, path: str | os.PathLike) -> tuple[Path, Path]:
    """Figure 19's table of thresholds, as CSV (SI units) and as Markdown (readable units).

    Parameters
    ----------
    table : pandas.DataFrame
        :func:`dronefleet.delivery.analysis.threshold_table`'s table.
    path : str or Path
        File name; its suffix is replaced by ``.csv`` and ``.md``.

    Returns
    -------
    (Path, Path)
        The CSV and Markdown files.
    """
    path = Path(path)
    csv, md = path.with_suffix(".csv"), path.with_suffix(".md")
    table.to_csv(csv, index=False)
    shown = pd.DataFrame({
        "theta (%)": table["theta"].map("{:g}".format),
        "runs": table["runs"].map(str),
        "delivered (mean)": table["delivered_mean"].map("{:.1f}".format),
        "delivered (median)": table["delivered_median"].map("{:.1f}".format),
        "delivery time (median, min)": (table["median_delivery_time_s"] / SECONDS_PER_MINUTE).map("{:.1f}".format),
        "aborted (%, mean)": table["aborted_pct_mean"].map("{:.2f}".format),
        "pending (mean)": table["pending_mean"].map("{:.1f}".format),
        "backlog age (days, mean)": (table["backlog_age_s_mean"] / SECONDS_PER_DAY).map("{:.1f}".format),
        "best": table["best"].map({True: "yes", False: ""}),
    })
    lines = ["| " + " | ".join(shown.columns) + " |", "|" + "---|" * shown.shape[1]]
    lines += ["| " + " | ".join(row) + " |" for row in shown.itertuples(index=False)]
    md.write_text("\n".join(lines) + "\n")
    return csv, md


def pending_bars(pending: pd.DataFrame, path: str | os.PathLike) -> list[Path]:
    """Pending orders at the end by arrival week, bars side by side per rule (Fig. 20).

    Bar: mean over runs; dots: the runs (spread evenly across the bar, in seed order).

    Parameters
    ----------
    pending : pandas.DataFrame
        :func:`dronefleet.delivery.analysis.backlog_by_arrival_week` rows with ``by=("rule",)``:
        ``rule, seed, arrival_week, pending``.
    path : str or Path
        Figure file name (its suffix is replaced by each format's).

    Returns
    -------
    list of Path
    """
    rule_styles = _rule_styles(pending["rule"])
    width = 0.8 / len(rule_styles)
    with _figure(path, (8.0, 4.5)) as (mpl, fig, ax):
        for k, (rule, style) in enumerate(rule_styles.items()):
            rows = pending[pending["rule"] == rule].sort_values(["arrival_week", "seed"])
            offset = _dodge(k, len(rule_styles), width)
            mean = rows.groupby("arrival_week", sort=True)["pending"].mean()
            ax.bar(mean.index + offset, mean, width=0.9 * width, color=style.colour, alpha=0.6, hatch=style.hatch,
                   edgecolor=style.colour, label=f"{rule} (mean of {rows['seed'].nunique()} runs)")
            # Each run's dot sits in its bar by its rank among the week's runs.
            by_week = rows.groupby("arrival_week")
            share = (by_week.cumcount().to_numpy() + 0.5) / by_week["seed"].transform("size").to_numpy()
            ax.plot(rows["arrival_week"].to_numpy() + offset + (share - 0.5) * 0.7 * width, rows["pending"], ".",
                    color="black", ms=2.5)
        ax.set_xticks(np.sort(pending["arrival_week"].unique()))
        ax.set_xlabel("arrival week")
        ax.set_ylabel("pending orders at the end")
        ax.legend(title="dots: single runs", fontsize=8)
    return figure_paths(path)
