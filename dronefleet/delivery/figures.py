"""The study's figures (docs/delivery-experiments.md, Figures 16-20) as PNG, PDF and SVG files, from tidy tables alone.

Each function takes a table of :mod:`dronefleet.delivery.analysis` (as stored in parquet under
``results/<figure>/``), draws one figure and writes it to ``path`` in each format of
:data:`dronefleet.figstyle.FORMATS` (``path``'s suffix replaced). Nothing here imports
the simulator, so a figure can be redrawn without re-simulating.

Drawn in the shared style of :mod:`dronefleet.figstyle` (matplotlib only when a figure is
drawn, never pyplot, no titles, the same table gives the same bytes) at print size: as wide
as a journal column (:data:`~dronefleet.figstyle.SINGLE_COLUMN`, 3.5 in) or page
(:data:`~dronefleet.figstyle.DOUBLE_COLUMN`, 7.2 in), no text below 7 pt. Each rule
(``rule`` column) has its colour, marker, line style and hatch of
:data:`dronefleet.figstyle.RULE_STYLES` in every figure. :func:`rule_outcomes` is Figures 16
and 19 whole, panels (a)-(c) in one file; :func:`delivered_vs_delivery_time`,
:func:`aborted_by_tau` and :func:`backlog_bars` draw one of its panels alone.
"""

import os
from pathlib import Path

import numpy as np
import pandas as pd

from ..figstyle import (DOUBLE_COLUMN, MIN_FONT_SIZE, PRINT_RC, RULE_STYLES, SINGLE_COLUMN, _dodge, _figure,
                        figure_paths, letter_panels, styles)

SECONDS_PER_MINUTE = 60.0
SECONDS_PER_DAY = 86_400.0


#: Labels of Fig. 16a/19a closer than this (axes fraction, along x and along y) would overlap.
_LABEL_CLEARANCE = 0.035
#: Grey of the legend's key to the marks, which every rule draws in its own colour.
_KEY_GREY = "0.35"


def _rule_styles(rules):
    return styles(rules, RULE_STYLES)


def _rule_handles(mpl, rule_styles):
    """Legend entries, one per rule: its box (colour, hatch) under its marker and line style."""
    return {rule: (mpl.patches.Patch(facecolor=style.colour, alpha=0.5, hatch=style.hatch, edgecolor=style.colour),
                   mpl.lines.Line2D([], [], color=style.colour, ls=style.linestyle, marker=style.marker, ms=3.5))
            for rule, style in rule_styles.items()}


def _box_key(mpl, runs_per_box):
    """Legend entries that explain the marks of the box plots (Fig. 16a/b), in grey."""
    return {f"quartiles of {runs_per_box} runs": mpl.patches.Patch(facecolor="0.85", edgecolor=_KEY_GREY),
            "median, whiskers (1.5 IQR)": mpl.lines.Line2D([], [], color=_KEY_GREY, marker="+", ms=9, mew=1.0,
                                                            ls="none"),
            "runs beyond the whiskers": mpl.lines.Line2D([], [], color=_KEY_GREY, marker="o", ms=3, ls="none"),
            "(a): tau (min), black if shared": mpl.lines.Line2D([], [], color="black", marker="$15$", ms=9,
                                                                 ls="none")}


def _legend(mpl, fig, entries, **kwargs):
    """A legend of ``entries`` (label -> handle or tuple of handles drawn over each other)."""
    return fig.legend(list(entries.values()), list(entries), handler_map={
        tuple: mpl.legend_handler.HandlerTuple(ndivide=None)}, **kwargs)


def _delivered_panel(mpl, ax, outcomes, rule_styles):
    """Fig. 16a/19a's 2-D boxes on ``ax``; their geometry for :func:`_tau_labels` (data coordinates):
    ``(rule, tau, (q1_x, q1_y, q3_x, q3_y), (whislo_x, whislo_y, whishi_x, whishi_y), (med_x, med_y))``."""
    boxes = []
    for (rule, tau), runs in outcomes.groupby(["rule", "tau_minutes"], sort=True):
        style = rule_styles[rule]
        minutes = runs["median_delivery_time_s"].to_numpy(np.float64) / SECONDS_PER_MINUTE
        delivered = runs["delivered"].to_numpy(np.float64)
        sx = mpl.cbook.boxplot_stats(minutes[~np.isnan(minutes)])[0]
        sy = mpl.cbook.boxplot_stats(delivered)[0]
        ax.add_patch(mpl.patches.Rectangle((sx["q1"], sy["q1"]), sx["q3"] - sx["q1"], sy["q3"] - sy["q1"],
                                           facecolor=style.colour, alpha=0.3, edgecolor=style.colour,
                                           hatch=style.hatch, lw=0.6))
        ax.plot([sx["whislo"], sx["whishi"]], [sy["med"], sy["med"]], color=style.colour, ls=style.linestyle,
                lw=0.8)
        ax.plot([sx["med"], sx["med"]], [sy["whislo"], sy["whishi"]], color=style.colour, ls=style.linestyle,
                lw=0.8)
        outside = ((minutes < sx["whislo"]) | (minutes > sx["whishi"])
                   | (delivered < sy["whislo"]) | (delivered > sy["whishi"]))
        ax.plot(minutes[outside], delivered[outside], style.marker, color=style.colour, ms=2.5, mew=0)
        boxes.append((rule, tau, (sx["q1"], sy["q1"], sx["q3"], sy["q3"]),
                      (sx["whislo"], sy["whislo"], sx["whishi"], sy["whishi"]), (sx["med"], sy["med"])))
    ax.set_xscale("log")  # medians span minutes (light load) to days (overload)
    ax.autoscale_view()
    ax.xaxis.set_major_formatter(mpl.ticker.FormatStrFormatter("%g"))
    # on a narrow range (a small sweep) only minor ticks get labels: plain minutes there too, the
    # same ticks labelled as by the default formatter, which would write "6x10^0"
    ax.xaxis.set_minor_formatter(mpl.ticker.LogFormatter(labelOnlyBase=False))
    ax.set_xlabel("delivery time, per-run median (min, log scale)")
    ax.set_ylabel("delivered parcels per run")
    return boxes


def _overlap(a, b):
    """Area (px^2) that the display boxes ``a`` and ``b`` share."""
    width = min(a.x1, b.x1) - max(a.x0, b.x0)
    height = min(a.y1, b.y1) - max(a.y0, b.y0)
    return width * height if width > 0 and height > 0 else 0.0


def _tau_labels(mpl, ax, boxes, rule_styles):
    """Write each box's tau beside it, once for the boxes of one tau whose corners meet, where it
    overlaps no other label and as little of the boxes, whiskers and dots as it can.

    ``boxes`` as :func:`_delivered_panel` returns them. Boxes of one tau whose upper right
    corners lie within :data:`_LABEL_CLEARANCE` of each other share a label (drawn in black
    then): at light load the rules' boxes coincide. Each label tries positions around its
    boxes (their corners and sides, then the whiskers' ends) in turn and takes the first
    that stays inside the axes and off the other labels, with the least area over other marks.
    Call it once the figure's layout is final (the labels are left out of the layout).
    """
    fig = ax.figure
    fig.draw_without_rendering()  # the constrained layout, so the axes have their final size
    renderer = fig.canvas.get_renderer()
    to_axes = ax.transData + ax.transAxes.inverted()
    groups = []  # [tau, [boxes], [upper right corners, axes fractions]]
    for box in boxes:
        corner = to_axes.transform(box[2][2:])
        group = next((g for g in groups if g[0] == box[1] and any(
            abs(corner - other).max() < _LABEL_CLEARANCE for other in g[2])), None)
        if group is None:
            groups.append([box[1], [box], [corner]])
        else:
            group[1].append(box)
            group[2].append(corner)

    def extent(corners):  # display box around data corners (x0, y0, x1, y1)
        points = ax.transData.transform(np.reshape(corners, (-1, 2)))
        return mpl.transforms.Bbox([points.min(axis=0), points.max(axis=0)])

    marks = []  # what a label should rather not cover: boxes, whiskers, outlying runs
    for _, _, quartiles, whiskers, (mx, my) in boxes:
        marks += [extent(quartiles), extent((whiskers[0], my, whiskers[2], my)),
                  extent((mx, whiskers[1], mx, whiskers[3]))]
    for line in ax.lines:
        if line.get_linestyle() == "None":
            marks += [extent((x, y, x, y)).padded(2.0) for x, y in line.get_xydata()]
    pad = 2.0 * fig.dpi / 72.0  # 2 pt between a box and its label
    frame, placed = ax.bbox, []
    for tau, members, _ in groups:
        rules = [member[0] for member in members]
        box = mpl.transforms.Bbox.union([extent(member[2]) for member in members])
        reach = mpl.transforms.Bbox.union([extent(member[3]) for member in members])
        mx, my = ax.transData.transform(members[0][4])
        candidates = [(box.x1 + pad, box.y1 + pad, "left", "bottom"), (box.x0 - pad, box.y1 + pad, "right", "bottom"),
                      (box.x1 + pad, box.y0 - pad, "left", "top"), (box.x0 - pad, box.y0 - pad, "right", "top"),
                      (box.x1 + pad, my, "left", "center"), (box.x0 - pad, my, "right", "center"),
                      (mx, box.y1 + pad, "center", "bottom"), (mx, box.y0 - pad, "center", "top"),
                      (reach.x1 + pad, my, "left", "center"), (reach.x0 - pad, my, "right", "center"),
                      (mx, reach.y1 + pad, "center", "bottom"), (mx, reach.y0 - pad, "center", "top"),
                      (reach.x1 + pad, reach.y1 + pad, "left", "bottom"),
                      (reach.x0 - pad, reach.y1 + pad, "right", "bottom"),
                      (reach.x1 + pad, reach.y0 - pad, "left", "top"), (reach.x0 - pad, reach.y0 - pad, "right", "top")]
        best = None
        for x, y, ha, va in candidates:
            label = ax.text(*ax.transAxes.inverted().transform((x, y)), f"{tau:g}", transform=ax.transAxes,
                            ha=ha, va=va, fontsize=MIN_FONT_SIZE, in_layout=False,
                            color=rule_styles[rules[0]].colour if len(rules) == 1 else "black")
            bounds = label.get_window_extent(renderer)
            clash = (bounds.x0 < frame.x0 or bounds.x1 > frame.x1 or bounds.y0 < frame.y0 or bounds.y1 > frame.y1
                     or any(bounds.overlaps(other) for other in placed))
            score = (clash, sum(_overlap(bounds, mark) for mark in marks))
            if best is None or score < best[0]:
                if best is not None:
                    best[1].remove()
                best = (score, label, bounds)
            else:
                label.remove()
            if score == (False, 0.0):
                break
        placed.append(best[2])


def _aborted_panel(mpl, ax, outcomes, rule_styles):
    """Fig. 16b/19b's box plots on ``ax``: aborted attempts (%) per tau, the rules side by side."""
    taus = np.sort(outcomes["tau_minutes"].unique())
    step = np.diff(taus).min() if taus.size > 1 else 1.0
    width = 0.8 * step / len(rule_styles)
    for k, (rule, style) in enumerate(rule_styles.items()):
        runs = outcomes[outcomes["rule"] == rule]
        at, stats = zip(*[(tau, mpl.cbook.boxplot_stats(values.dropna().to_numpy())[0])
                          for tau, values in runs.groupby("tau_minutes", sort=True)["aborted_pct"]])
        offset = _dodge(k, len(rule_styles), width)
        ax.bxp(stats, positions=np.array(at) + offset, widths=0.9 * width, patch_artist=True,
               manage_ticks=False,
               boxprops=dict(facecolor=style.colour, alpha=0.6, hatch=style.hatch, edgecolor=style.colour, lw=0.6),
               whiskerprops=dict(color=style.colour, ls=style.linestyle, lw=0.8),
               capprops=dict(color=style.colour, lw=0.8), medianprops=dict(color="black", lw=0.8),
               flierprops=dict(marker=style.marker, markeredgecolor=style.colour, markersize=2.5, mew=0.6))
    ax.set_xticks(taus, [f"{tau:g}" for tau in taus])
    ax.set_xlabel("mean inter-arrival time tau (min)")
    ax.set_ylabel("aborted attempts (% of attempts)")


def _backlog_panels(mpl, axes, backlog):
    """Fig. 16c/19c on ``axes`` (one per rule, sharing y): backlog age stacked by arrival week; the
    weeks' legend entries."""
    days = (backlog.groupby(["rule", "tau_minutes", "arrival_week"], sort=True)["backlog_age_s"].mean()
            / SECONDS_PER_DAY).unstack("arrival_week", fill_value=0.0)
    weeks = days.columns
    # viridis: its lightness rises with the week, so the weeks stay apart in greyscale too
    week_colours = mpl.colormaps["viridis"](np.linspace(0.0, 0.9, len(weeks)))
    for ax, rule in zip(axes, days.index.get_level_values("rule").unique()):
        stack = days.loc[rule]
        taus = [f"{tau:g}" for tau in stack.index]
        bottom = np.zeros(len(stack))
        for week, colour in zip(weeks, week_colours):
            ax.bar(taus, stack[week], bottom=bottom, color=colour, width=0.75)
            bottom += stack[week].to_numpy()
        ax.text(0.96, 0.96, rule, transform=ax.transAxes, ha="right", va="top", fontsize=MIN_FONT_SIZE)
        ax.set_xlabel("tau (min)")
    axes[0].set_ylabel("backlog age at the end (days)\nsum over pending orders")
    for ax in axes[1:]:
        ax.sharey(axes[0])
        ax.tick_params(labelleft=False)
    return {f"{week}": mpl.patches.Patch(color=colour) for week, colour in zip(weeks, week_colours)}


def rule_outcomes(outcomes: pd.DataFrame, backlog: pd.DataFrame, path: str | os.PathLike) -> list[Path]:
    """Figures 16 and 19 in one file, as wide as a page: (a) delivered parcels against delivery
    time, 2-D box plots per (rule, tau); (b) aborted attempts against tau; (c) backlog age at the
    end by arrival week, one small panel per rule.

    (a) x: per-run median delivery time (min, log scale), y: delivered parcels. Each box spans
    the quartiles on both axes, crossed by the medians; whiskers (1.5 IQR, matplotlib's
    rule) run along the median lines; runs outside a whisker are the rule's marker. tau (min)
    is written beside its box, once for the boxes of one tau that meet (in black then), where
    it covers no other label. (b) box plots of aborted attempts (% of all attempts), the rules
    side by side at each tau. (c) bar: the mean over runs of the summed age (horizon - arrival)
    of the orders pending at the end, in days; each segment the orders of one arrival week.
    The legend above explains the rules and the marks, the one below the weeks. Runs without a
    delivery have no delivery time and are left out of (a)'s x statistics.

    Parameters
    ----------
    outcomes : pandas.DataFrame
        :func:`dronefleet.delivery.analysis.run_outcomes` rows: ``rule, tau_minutes, delivered,
        median_delivery_time_s, aborted_pct``.
    backlog : pandas.DataFrame
        :func:`dronefleet.delivery.analysis.backlog_by_arrival_week` rows: ``rule, tau_minutes, seed,
        arrival_week, backlog_age_s``.
    path : str or Path
        Figure file name (its suffix is replaced by each format's).

    Returns
    -------
    list of Path
        The figure's files, one per format.
    """
    rule_styles = _rule_styles(outcomes["rule"])
    n = len(_rule_styles(backlog["rule"]))
    # (a) two thirds of the page's width and (b) the rest; below them (c), a panel per rule. Rows
    # of their own (nested), so that (b)'s axis labels leave no gap between (c)'s panels.
    mosaic = [[[["a", "a", "b"]]], [[[f"c{k}" for k in range(n)]]]]
    runs_per_box = int(outcomes.groupby(["rule", "tau_minutes"]).size().max())
    with _figure(path, (DOUBLE_COLUMN, 6.2), PRINT_RC, mosaic, height_ratios=(1.35, 1.0)) as (mpl, fig, axes):
        boxes = _delivered_panel(mpl, axes["a"], outcomes, rule_styles)
        _aborted_panel(mpl, axes["b"], outcomes, rule_styles)
        backlog_axes = [axes[f"c{k}"] for k in range(n)]
        weeks = _backlog_panels(mpl, backlog_axes, backlog)
        letter_panels([axes["a"], axes["b"], backlog_axes[0]])
        _legend(mpl, fig, {**_rule_handles(mpl, rule_styles), **_box_key(mpl, runs_per_box)},
                loc="outside upper center", ncols=4)
        _legend(mpl, fig, weeks, loc="outside lower center", ncols=len(weeks), title="(c): arrival week",
                handlelength=1.2, columnspacing=0.8)
        _tau_labels(mpl, axes["a"], boxes, rule_styles)
    return figure_paths(path)


def delivered_vs_delivery_time(outcomes: pd.DataFrame, path: str | os.PathLike) -> list[Path]:
    """Panel (a) of :func:`rule_outcomes` alone, a column wide (Fig. 16a/19a).

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
    runs_per_box = int(outcomes.groupby(["rule", "tau_minutes"]).size().max())
    with _figure(path, (SINGLE_COLUMN, 3.9), PRINT_RC) as (mpl, fig, ax):
        boxes = _delivered_panel(mpl, ax, outcomes, rule_styles)
        _legend(mpl, fig, {**_rule_handles(mpl, rule_styles), **_box_key(mpl, runs_per_box)},
                loc="outside upper center", ncols=2)
        _tau_labels(mpl, ax, boxes, rule_styles)
    return figure_paths(path)


def aborted_by_tau(outcomes: pd.DataFrame, path: str | os.PathLike) -> list[Path]:
    """Panel (b) of :func:`rule_outcomes` alone, a column wide: aborted attempts (% of all
    attempts) against tau, box plots side by side per rule (Fig. 16b/19b).

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
    with _figure(path, (SINGLE_COLUMN, 2.8), PRINT_RC) as (mpl, fig, ax):
        _aborted_panel(mpl, ax, outcomes, rule_styles)
        _legend(mpl, fig, _rule_handles(mpl, rule_styles), loc="outside upper center", ncols=2)
    return figure_paths(path)


def backlog_bars(backlog: pd.DataFrame, path: str | os.PathLike) -> list[Path]:
    """Panel (c) of :func:`rule_outcomes` alone, a page wide: backlog age at the end, stacked by
    arrival week, per tau; one small panel per rule (Fig. 16c/19c).

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
    n = len(_rule_styles(backlog["rule"]))
    with _figure(path, (DOUBLE_COLUMN, 2.8), PRINT_RC, ncols=n, squeeze=False) as (mpl, fig, axes):
        weeks = _backlog_panels(mpl, list(axes[0]), backlog)
        _legend(mpl, fig, weeks, loc="outside right", title="arrival week", handlelength=1.2)
    return figure_paths(path)


def accuracy_over_weeks(accuracy: pd.DataFrame, path: str | os.PathLike) -> list[Path]:
    """Mean decision accuracy per week, one line per rule with its confidence band, a column wide (Fig. 17).

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
    with _figure(path, (SINGLE_COLUMN, 2.7), PRINT_RC) as (mpl, fig, ax):
        for rule, style in rule_styles.items():
            rows = accuracy[accuracy["rule"] == rule].sort_values("week")
            ax.fill_between(rows["week"], rows["ci_low"], rows["ci_high"], color=style.colour, alpha=0.25, lw=0)
            ax.plot(rows["week"], rows["mean_accuracy"], marker=style.marker, ls=style.linestyle,
                    color=style.colour, ms=3.5, label=rule)
        confidence = accuracy["confidence"].iloc[0]
        uavs = accuracy.groupby("rule")["uavs"].max()
        per_rule = f"{uavs.iloc[0]} UAVs per rule" if uavs.nunique() == 1 else "UAVs per rule: " + ", ".join(
            f"{rule} {n}" for rule, n in uavs.items())
        ax.set_xlabel("end of week")
        ax.set_ylabel("decision accuracy\n(share of 1000 test points)")
        ax.set_xticks(np.sort(accuracy["week"].unique()))
        fig.legend(loc="outside upper center", ncols=2,
                   title=f"{per_rule}; band: {100 * confidence:g} % CI of the mean")
    return figure_paths(path)


def winner_soh_heatmaps(grid: pd.DataFrame, path: str | os.PathLike) -> list[Path]:
    """Mean SoH of the auction winner over distance and mass, one heat map per SoC, a page wide (Fig. 18).

    One blue-to-red colour scale (matplotlib's coolwarm: blue low SoH, red high) for every
    panel; hatched grey where nobody bid in any run.

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
    with _figure(path, (DOUBLE_COLUMN, 1.45 * nrows + 0.55), PRINT_RC, nrows=nrows, ncols=ncols,
                 sharex=True, sharey=True, squeeze=False) as (mpl, fig, axes):
        for ax, soc in zip(axes.flat, socs):
            cells = grid[grid["soc"] == soc].pivot(index="mass_kg", columns="distance_m", values="mean_winner_soh")
            # what shows through the blank cells: nobody bids there
            ax.add_patch(mpl.patches.Rectangle((0.0, 0.0), 1.0, 1.0, transform=ax.transAxes, facecolor="white",
                                               edgecolor="0.6", hatch="/////", lw=0, zorder=0))
            # rasterized: in PDF and SVG the 7,000 cells as one image, not one path each (14 MB of SVG)
            mesh = ax.pcolormesh(cells.columns / 1000.0, cells.index, cells.to_numpy(), shading="nearest",
                                 cmap="coolwarm", vmin=vmin, vmax=vmax, rasterized=True)
            ax.text(0.95, 0.95, f"SoC {soc:g} %", transform=ax.transAxes, ha="right", va="top",
                    fontsize=MIN_FONT_SIZE, bbox=dict(facecolor="white", edgecolor="none", alpha=0.85, pad=1.0))
        for ax in axes.flat[len(socs):]:
            ax.set_visible(False)
        fig.supxlabel("order distance (km)", fontsize=8)
        fig.supylabel("parcel mass (kg)", fontsize=8)
        fig.colorbar(mesh, ax=axes, label="mean SoH of the winner\n(hatched: nobody bids)", fraction=0.04,
                     pad=0.015, aspect=25)
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
    """Pending orders at the end by arrival week, bars side by side per rule, a column wide (Fig. 20).

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
    with _figure(path, (SINGLE_COLUMN, 2.7), PRINT_RC) as (mpl, fig, ax):
        for k, (rule, style) in enumerate(rule_styles.items()):
            rows = pending[pending["rule"] == rule].sort_values(["arrival_week", "seed"])
            offset = _dodge(k, len(rule_styles), width)
            mean = rows.groupby("arrival_week", sort=True)["pending"].mean()
            ax.bar(mean.index + offset, mean, width=0.9 * width, color=style.colour, alpha=0.6, hatch=style.hatch,
                   edgecolor=style.colour, label=rule)
            # Each run's dot sits in its bar by its rank among the week's runs.
            by_week = rows.groupby("arrival_week")
            share = (by_week.cumcount().to_numpy() + 0.5) / by_week["seed"].transform("size").to_numpy()
            ax.plot(rows["arrival_week"].to_numpy() + offset + (share - 0.5) * 0.7 * width, rows["pending"], ".",
                    color="black", ms=1.5)
        ax.set_xticks(np.sort(pending["arrival_week"].unique()))
        ax.set_xlabel("arrival week")
        ax.set_ylabel("pending orders at the end")
        runs = pending.groupby("rule")["seed"].nunique().max()
        fig.legend(loc="outside upper center", ncols=2, title=f"bars: mean of {runs} runs, dots: single runs")
    return figure_paths(path)
