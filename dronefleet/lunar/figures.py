"""The lunar study's figures (Angyal 2024, Figs 6-3 to 6-11, and the control) from tidy tables alone.

Each function reads the tables :mod:`dronefleet.lunar.study` writes (network snapshots, one row
per robot; per-condition curves, one row per time) and draws one figure as PNG, PDF and SVG with
the style of :mod:`dronefleet.figstyle`: print size (a page wide,
:data:`~dronefleet.figstyle.DOUBLE_COLUMN`), no text below 7 pt, no titles, panels lettered
(a), (b), ... as the captions in ``results/README.md`` letter them; the same tables give the
same bytes. Nothing here imports the simulator: the field is drawn from a layout
(``dronefleet.lunar.layout.build``), given.

Colours (Okabe-Ito): the key and region T (F_OUT, "to T") orange, N (F_IN, "to N") blue, R
(recharger, "to R") bluish green; beacons black; dead robots vermillion crosses. A guidance
vector is an arrow of one length whatever its magnitude, shaded in its key's colour from pale
(0) to full (v0), with a colour bar per key. Each condition has its :data:`CONDITION_STYLES`
colour and line style in every curve figure. Every time axis marks 20 minutes, when the thesis
finds the network at its largest (L1103-L1105); panels of one quantity share their y-axis.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..figstyle import DOUBLE_COLUMN, MIN_FONT_SIZE, OKABE_ITO, PRINT_RC, Style, _dodge, _figure, figure_paths, \
    letter_panels, styles

if TYPE_CHECKING:
    import pandas

#: Keys (and the region each leads to): colour of the vectors, the region disc and the role.
KEY_COLOURS = {"T": OKABE_ITO["orange"], "N": OKABE_ITO["blue"], "R": OKABE_ITO["bluish green"]}
#: Mobile roles: the colour of the key each one follows (F_OUT to T, F_IN to N, R to R).
ROLE_COLOURS = {"F_OUT": KEY_COLOURS["T"], "F_IN": KEY_COLOURS["N"], "R": KEY_COLOURS["R"]}
ROLE_WORDS = {"F_OUT": "F_OUT (to T)", "F_IN": "F_IN (to N)", "R": "R (to recharge)"}
BEACON, DEAD = OKABE_ITO["black"], OKABE_ITO["vermillion"]
#: Every guidance vector and mobile robot's heading is drawn this long [m] (its magnitude: the shade).
ARROW_M = 0.8
#: The time every time axis marks [min]: the thesis's network is at its largest then (L1103-L1105).
MARK_MIN = 20.0
#: Highlighted robots' paths (Figs 6-5, 6-6): colours that are none of the roles'.
PATH_COLOURS = (OKABE_ITO["reddish purple"], OKABE_ITO["sky blue"], OKABE_ITO["vermillion"])
#: The conditions' styles in the curve figures.
CONDITION_STYLES = {
    "OPEN": Style(OKABE_ITO["black"], "o", "-", ""),
    "HARD-RT": Style(OKABE_ITO["vermillion"], "s", "--", "//"),
    "SOFT-RT": Style(OKABE_ITO["bluish green"], "^", "-", ".."),
    "SOFT-RT 7.5 Wh": Style(OKABE_ITO["sky blue"], "v", ":", "xx"),
    "SOFT-RT 12.5 Wh": Style(OKABE_ITO["blue"], "D", "-.", "\\\\"),
    "HARD-NT": Style(OKABE_ITO["orange"], "P", "--", "++"),
    "SOFT-NT": Style(OKABE_ITO["orange"], "P", "-", "++"),
    "HARD-NR": Style(OKABE_ITO["reddish purple"], "X", "--", "oo"),
    "SOFT-NR": Style(OKABE_ITO["reddish purple"], "X", "-", "oo"),
}
#: The eps = 1 control's words: every heading decision random, the network ignored.
WITHOUT = "no guidance (eps = 1)"
#: Axis words of the time-series metrics and of the R-T trip metrics.
METRIC_WORDS = {"resources": "resources returned F(t) [units]", "interruptions": "recharging interruptions C(t)",
                "rate": "rate of return [units / 100 s]", "n_mobile": "mobile robots", "soc_sum": "sum of SOC",
                "n_beacons": "beacons", "n_dead": "dead robots", "alignment_T": "alignment, key T",
                "alignment_N": "alignment, key N", "alignment_R": "alignment, key R",
                "soc_cost": "R-T trip SOC cost", "energy_wh": "R-T trip energy [Wh]",
                "length_m": "R-T trip distance [m]", "duration_s": "R-T trip time [s]"}
#: Metrics that are one quantity (their panels share the y-axis): the alignments of the three keys.
QUANTITY = {f"alignment_{key}": "alignment" for key in KEY_COLOURS}


def _field(ax, geometry: Any) -> None:
    """The walled field, the regions as discs (labelled) and the obstacle: hard solid grey, soft
    a dashed outline hatched (passable, costlier ground)."""
    from matplotlib.patches import Circle, Polygon, Rectangle

    w, h = geometry.field
    ax.add_patch(Rectangle((0, 0), w, h, fill=False, lw=1.6, ec="black", zorder=1))
    for region, (x, y) in geometry.centres.items():
        colour = KEY_COLOURS[region]
        ax.add_patch(Circle((x, y), geometry.radii[region], fc=colour, ec=colour, alpha=0.18, lw=0, zorder=0))
        ax.add_patch(Circle((x, y), geometry.radii[region], fill=False, ec=colour, lw=0.8, zorder=0))
        ax.text(x, y, region, ha="center", va="center", fontsize=9, fontweight="bold", color=colour, alpha=0.6,
                zorder=0)
    if geometry.obstacle is not None:
        corners = np.asarray(geometry.obstacle, dtype=float)
        if geometry.kind == "hard":
            ax.add_patch(Polygon(corners, closed=True, fc="0.35", ec="black", lw=0.8, zorder=1))
        else:
            ax.add_patch(Polygon(corners, closed=True, fc="#e8dcc4", ec="0.3", lw=0.8, ls="--", hatch="....",
                                 zorder=0))
    ax.set_xlim(-0.2, w + 0.2)
    ax.set_ylim(-0.2, h + 0.2)
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")


def _key_colours(key: str, v0: float) -> Any:
    """The shades of ``key``'s vectors: a ScalarMappable from 0 (pale) to v0 (the key's colour)."""
    from matplotlib.cm import ScalarMappable
    from matplotlib.colors import LinearSegmentedColormap, Normalize, to_rgb

    pale = tuple(0.85 + 0.15 * c for c in to_rgb(KEY_COLOURS[key]))
    shades = LinearSegmentedColormap.from_list(f"to {key}", [pale, KEY_COLOURS[key]])
    return ScalarMappable(Normalize(0.0, v0, clip=True), shades)


def _arrows(ax, x, y, angle, **style) -> None:
    """Arrows of ARROW_M from (``x``, ``y``) along ``angle`` [rad]."""
    ax.quiver(x, y, ARROW_M * np.cos(angle), ARROW_M * np.sin(angle), angles="xy", scale_units="xy", scale=1.0,
              width=0.004, headwidth=3.5, headlength=4.0, **style)


def _network(ax, snapshot: pandas.DataFrame, geometry: Any, v0: float) -> None:
    """One network snapshot (the rows of one label and time): the field, the beacons with a vector
    per key whose |v^X| > 0 (unit length, shaded by |v^X|, :func:`_key_colours`), the mobile
    robots coloured by role (hollow while charging) with their heading (none while charging),
    dead robots as crosses.
    A mobile robot's heading, not the guidance vector it follows: snapshots record vectors of
    beacons only (the heading is the vector it follows, as it turned at its last decision)."""
    _field(ax, geometry)
    alive = snapshot[snapshot["status"] == "alive"]
    beacons = alive[alive["role"] == "B"]
    for key in KEY_COLOURS:
        vx, vy = beacons[f"vx_{key}"].to_numpy(dtype=float), beacons[f"vy_{key}"].to_numpy(dtype=float)
        magnitude = np.hypot(vx, vy)
        has = magnitude > 0
        if has.any():
            _arrows(ax, beacons["x"].to_numpy()[has], beacons["y"].to_numpy()[has], np.arctan2(vy[has], vx[has]),
                    color=_key_colours(key, v0).to_rgba(magnitude[has]), ec="0.2", lw=0.2, zorder=3)
    ax.plot(beacons["x"], beacons["y"], "o", ms=3.0, color=BEACON, zorder=4, ls="none")
    mobile = alive[alive["role"].isin(list(ROLE_COLOURS)) & (alive["mode"] != "charging")]   # charging: parked
    if len(mobile):
        _arrows(ax, mobile["x"].to_numpy(dtype=float), mobile["y"].to_numpy(dtype=float),
                mobile["heading"].to_numpy(dtype=float), color=mobile["role"].map(ROLE_COLOURS).tolist(), ec="black",
                lw=0.3, zorder=5)
    for role, colour in ROLE_COLOURS.items():
        mine = alive[alive["role"] == role]
        charging = (mine["mode"] == "charging").to_numpy()
        ax.plot(mine["x"][~charging], mine["y"][~charging], "o", ms=4.0, color=colour, mec="black", mew=0.4,
                ls="none", zorder=5)
        ax.plot(mine["x"][charging], mine["y"][charging], "o", ms=4.0, mfc="white", mec=colour, mew=1.0, ls="none",
                zorder=5)
    dead = snapshot[snapshot["status"] == "dead"]
    ax.plot(dead["x"], dead["y"], "x", ms=4.0, color=DEAD, mew=1.0, ls="none", zorder=5)


def _network_legend(fig, axes, v0: float, paths: Sequence[str] = ()) -> None:
    """The marks of the network figures, in rows under the panels, and a colour bar per key
    (the magnitude of its vectors) right of ``axes``."""
    from matplotlib.lines import Line2D

    handles = [Line2D([], [], marker="o", ls="none", color=BEACON, ms=3.0, label="beacon"),
               Line2D([], [], marker=r"$\rightarrow$", ls="none", color="0.3", ms=8.0,
                      label="mobile robot's heading")]
    handles += [Line2D([], [], marker="o", ls="none", color=colour, mec="black", mew=0.4, ms=4.0,
                       label=ROLE_WORDS[role]) for role, colour in ROLE_COLOURS.items()]
    handles += [Line2D([], [], marker="o", ls="none", mfc="white", mec="0.3", ms=4.0, label="charging"),
                Line2D([], [], marker="x", ls="none", color=DEAD, ms=4.0, label="dead")]
    handles += [Line2D([], [], color=PATH_COLOURS[k], lw=1.4, label=text) for k, text in enumerate(paths)]
    fig.legend(handles=handles, loc="outside lower center", ncols=4, frameon=False)
    # the first bar added is the outermost: R first, so that they read T, N, R, the last one's ticks for all
    for key in reversed(KEY_COLOURS):
        bar = fig.colorbar(_key_colours(key, v0), ax=axes, location="right", fraction=0.012, aspect=25, shrink=0.8,
                           pad=0.01)
        bar.ax.set_title(key, fontsize=MIN_FONT_SIZE, color=KEY_COLOURS[key])
        if key == "R":
            bar.set_label("guidance vector magnitude [m/s]")
        else:
            bar.ax.tick_params(labelright=False)


def _time_text(t: float) -> str:
    return f"t = {t:.0f} s"


def snapshot(rows: pandas.DataFrame, geometry: Any, v0: float, path: str | os.PathLike) -> list[Path]:
    """Fig 6-3: one network snapshot (``rows``: the robots of one label and time of the snapshots
    table), a page wide."""
    with _figure(path, (DOUBLE_COLUMN, 6.6), PRINT_RC) as (mpl, fig, ax):
        _network(ax, rows, geometry, v0)
        ax.set_title(_time_text(float(rows["t"].iloc[0])))
        _network_legend(fig, ax, v0)
    return figure_paths(path)


def panels(snapshots: Mapping[str, pandas.DataFrame | None], geometry: Mapping[str, Any] | Any, v0: float,
           path: str | os.PathLike) -> list[Path]:
    """Figs 6-4 and 6-9: one network panel per entry of ``snapshots`` (its words -> the robots of
    one snapshot, or None for a milestone the run never reached), side by side, lettered.
    ``geometry``: one layout for all, or one per entry."""
    names = list(snapshots)
    with _figure(path, (DOUBLE_COLUMN, 3.0), PRINT_RC, ncols=len(names), squeeze=False) as (mpl, fig, axes):
        for ax, name in zip(axes.flat, names):
            mine = geometry[name] if isinstance(geometry, Mapping) else geometry
            rows = snapshots[name]
            if rows is None:
                _field(ax, mine)
                ax.text(0.5, 0.5, "not reached in this run", transform=ax.transAxes, ha="center", va="center")
                ax.set_title(f"{name}\n")
                continue
            _network(ax, rows, mine, v0)
            ax.set_title(f"{name}\n{_time_text(float(rows['t'].iloc[0]))}")
        for ax in axes.flat[1:]:
            ax.set_ylabel("")
        letter_panels(axes.flat)
        _network_legend(fig, axes, v0)
    return figure_paths(path)


def exploitation(frames: pandas.DataFrame, highlighted: Mapping[int, str], t_end: float, window_s: float,
                 geometry: Any, v0: float, path: str | os.PathLike) -> list[Path]:
    """Figs 6-5, 6-6: the network at the last frame at or before ``t_end`` and the paths of the
    ``highlighted`` robots (robot -> its role) over the frames of (t_end - window_s, t_end]
    (the positions of consecutive frames joined by straight lines; a dot where each path ends)."""
    times = np.sort(frames["t"].unique())
    now = times[times <= t_end + 1e-9][-1]
    window = frames[(frames["t"] > now - window_s - 1e-9) & (frames["t"] <= now + 1e-9)]
    every = float(np.min(np.diff(times))) if len(times) > 1 else 0.0
    with _figure(path, (DOUBLE_COLUMN, 6.6), PRINT_RC) as (mpl, fig, ax):
        _network(ax, frames[frames["t"] == now], geometry, v0)
        words = []
        for colour, (robot, role) in zip(PATH_COLOURS, highlighted.items()):
            mine = window[window["robot"] == robot].sort_values("t")
            ax.plot(mine["x"], mine["y"], "-", color=colour, lw=1.4, alpha=0.9, zorder=6)
            ax.plot(mine["x"].iloc[-1:], mine["y"].iloc[-1:], "o", color=colour, ms=5.0, mec="black", mew=0.5,
                    zorder=7)
            words.append(f"robot {robot}, {ROLE_WORDS.get(role, role)}")
        ax.set_title(f"{_time_text(now)}; paths over the last {window_s:g} s, a position every {every:.2g} s")
        _network_legend(fig, ax, v0, words)
    return figure_paths(path)


def _condition_styles(conditions: Sequence[str]) -> dict[str, Style]:
    return styles(conditions, CONDITION_STYLES)


def _se(rows: pandas.DataFrame, count: str) -> pandas.Series:
    """The standard error of each mean of ``rows``: sd / sqrt(its ``count`` of values) (NaN for one).
    The bands and whiskers show it, not the sd: the sd of these non-negative quantities reaches
    below 0 where runs or trips differ much."""
    return rows["sd"] / np.sqrt(rows[count])


def _band(ax, rows: pandas.DataFrame, x: str, style: Style, label: str) -> None:
    """A mean line (``rows`` sorted by ``x``) with a band of +- its standard error (none where NaN)."""
    rows = rows.sort_values(x)
    xs, mean = (rows[c].to_numpy(dtype=float) for c in (x, "mean"))
    se = _se(rows, "runs").to_numpy(dtype=float)
    ax.fill_between(xs, mean - se, mean + se, color=style.colour, alpha=0.18, lw=0)
    ax.plot(xs, mean, ls=style.linestyle, color=style.colour, label=label)


def _mark(ax) -> None:
    """The 20-minute line (:data:`MARK_MIN`) on a time axis in minutes, labelled at its top."""
    ax.axvline(MARK_MIN, color="0.35", lw=0.8, ls=":", zorder=1)
    ax.text(MARK_MIN, 0.02, f" {MARK_MIN:g} min", transform=ax.get_xaxis_transform(), ha="left", va="bottom",
            color="0.35")


def _share_y(axes, quantities: Sequence[str]) -> None:
    """Panels of one quantity share the y-axis of the first of them (one scale per quantity)."""
    first = {}
    for ax, quantity in zip(axes, quantities):
        if quantity in first:
            ax.sharey(first[quantity])
        else:
            first[quantity] = ax


def _curve_panels(axes, curves: pandas.DataFrame, metrics: Sequence[str], conditions: Sequence[str],
                  x: str = "t", minutes: bool = True) -> None:
    """One panel per metric, one band per condition (in ``conditions`` order), the 20-minute line."""
    mine_styles = _condition_styles(conditions)
    for ax, metric in zip(axes, metrics):
        for condition in conditions:
            rows = curves[(curves["metric"] == metric) & (curves["condition"] == condition)]
            if len(rows):
                rows = rows.assign(**{x: rows[x] / 60.0}) if minutes else rows
                _band(ax, rows, x, mine_styles[condition], condition)
        ax.set_ylabel(METRIC_WORDS.get(metric, metric))
        ax.set_xlabel("time [min]")
        ax.grid(alpha=0.3)
        _mark(ax)


def time_curves(curves: pandas.DataFrame, metrics: Sequence[str], conditions: Sequence[str],
                path: str | os.PathLike, ncols: int = 3) -> list[Path]:
    """Figs 6-7 a-e, the alignment diagnostic: each of ``metrics`` against time, one band (mean
    +- standard error) per condition, panels lettered in ``metrics`` order. ``curves``: rows of one selection
    (:func:`dronefleet.lunar.experiments.curves`)."""
    nrows = -(-len(metrics) // ncols)
    with _figure(path, (DOUBLE_COLUMN, 2.3 * nrows + 0.5), PRINT_RC, nrows=nrows, ncols=ncols, squeeze=False) as \
            (mpl, fig, axes):
        used = list(axes.flat[:len(metrics)])
        _share_y(used, [QUANTITY.get(metric, metric) for metric in metrics])
        _curve_panels(used, curves, metrics, conditions)
        for ax in axes.flat[len(metrics):]:
            ax.set_visible(False)
        letter_panels(used)
        _condition_legend(fig, used[0])
    return figure_paths(path)


def _condition_legend(fig, ax, title: str = "mean +- standard error over the runs") -> None:
    handles, labels = ax.get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncols=min(6, len(labels)), frameon=False, title=title)


def placement(curves: pandas.DataFrame, path: str | os.PathLike) -> list[Path]:
    """Fig 6-11 a-f: resources (a soft, b hard), SOC sum (c soft, d hard), mobile robots (e soft,
    f hard) against time, one band per obstacle location RT, NT, NR."""
    metrics = ("resources", "soc_sum", "n_mobile")
    with _figure(path, (DOUBLE_COLUMN, 7.2), PRINT_RC, nrows=3, ncols=2, squeeze=False, sharey="row") as \
            (mpl, fig, axes):
        for column, kind in enumerate(("SOFT", "HARD")):
            conditions = [f"{kind}-{where}" for where in ("RT", "NT", "NR")]
            _curve_panels(axes[:, column], curves, metrics, conditions)
            axes[0, column].set_title(f"{kind.lower()} obstacle")
            axes[0, column].legend(loc="upper left", frameon=False)
        letter_panels(axes.flat)
    return figure_paths(path)


def trip_curves(bins: pandas.DataFrame, conditions: Sequence[str], bin_s: float, path: str | os.PathLike) -> list[Path]:
    """Fig 6-8 a-d: the R-T trips' SOC cost, energy, distance and time against the entry time,
    the mean (a marker at each bin's middle) +- its standard error (:func:`_se`; none for a bin
    of one trip) per bin, one per condition."""
    mine_styles = _condition_styles(conditions)
    with _figure(path, (DOUBLE_COLUMN, 5.2), PRINT_RC, nrows=2, ncols=2, squeeze=False) as (mpl, fig, axes):
        for ax, metric in zip(axes.flat, ("soc_cost", "energy_wh", "length_m", "duration_s")):
            for k, condition in enumerate(conditions):
                rows = bins[(bins["metric"] == metric) & (bins["condition"] == condition)].sort_values("bin_start_s")
                if len(rows):
                    style = mine_styles[condition]
                    # side by side within each bin, so that the whiskers of the conditions stay apart
                    t = (rows["bin_start_s"] + bin_s / 2 + _dodge(k, len(conditions), 0.12 * bin_s)) / 60.0
                    ax.errorbar(t, rows["mean"], yerr=_se(rows, "trips"), ls=style.linestyle, marker=style.marker,
                                color=style.colour, capsize=1.5, elinewidth=0.6, label=condition)
            ax.set_ylabel(METRIC_WORDS[metric])
            ax.set_xlabel(f"entry time [min] ({bin_s / 60.0:g}-min bins)")
            ax.tick_params(labelsize=MIN_FONT_SIZE)
            ax.grid(alpha=0.3)
            _mark(ax)
        letter_panels(axes.flat)
        _condition_legend(fig, axes.flat[0], "mean +- standard error over the trips of each bin")
    return figure_paths(path)


def control(curves: pandas.DataFrame, stats: pandas.DataFrame, layouts: Sequence[str],
            path: str | os.PathLike, variant: str = "eps=1", words: tuple[str, str] = ("network", WITHOUT)) \
        -> list[Path]:
    """The eps = 1 control (section 14): (a) resources returned against time per layout, with the
    guidance network (solid) and without (eps = 1, dashed); (b) F(T_run) of each, mean +- standard error,
    with the share the control keeps written over its bar, on (a)'s y-scale (one quantity).
    ``stats``: run_stats rows of one selection; conditions named "<layout>" and "<layout> <variant>"
    (``words``: how the legends name the two; E5 draws the Ch 4 baseline as the variant)."""
    from matplotlib.patches import Patch

    colours = _condition_styles(layouts)
    with _figure(path, (DOUBLE_COLUMN, 2.9), PRINT_RC, ncols=2, squeeze=False, sharey=True,
                 width_ratios=(1.6, 1.0)) as (mpl, fig, axes):
        ax, bars = axes[0]
        for layout in layouts:
            for condition, ls, word in ((layout, "-", words[0]), (f"{layout} {variant}", "--", words[1])):
                rows = curves[(curves["metric"] == "resources") & (curves["condition"] == condition)]
                if len(rows):
                    _band(ax, rows.assign(t=rows["t"] / 60.0), "t",
                          colours[layout]._replace(linestyle=ls), f"{layout}, {word}")
        ax.set_xlabel("time [min]")
        ax.set_ylabel(METRIC_WORDS["resources"])
        ax.grid(alpha=0.3)
        _mark(ax)
        ax.legend(loc="upper left", frameon=False, ncols=1)
        final = stats[stats["column"] == "resources"].set_index("condition")
        for k, layout in enumerate(layouts):
            colour = colours[layout].colour
            for offset, condition, fill in ((-0.2, layout, True), (0.2, f"{layout} {variant}", False)):
                if condition not in final.index:
                    continue
                bars.bar(k + offset, final.loc[condition, "mean"], 0.38, yerr=_se(final.loc[[condition]], "runs"),
                         color=colour if fill else "white",
                         hatch="" if fill else "///", ec=colour, lw=0.8, error_kw={"lw": 0.8, "ecolor": "black"})
            if layout in final.index and f"{layout} {variant}" in final.index and final.loc[layout, "mean"] > 0:
                share = final.loc[f"{layout} {variant}", "mean"] / final.loc[layout, "mean"]
                bars.annotate(f"{share:.0%}", (k + 0.2, final.loc[f"{layout} {variant}", "mean"]),
                              xytext=(0, 3), textcoords="offset points", ha="center", va="bottom")
        bars.set_xticks(range(len(layouts)), layouts)
        bars.set_ylabel("resources returned by the end [units]")
        bars.yaxis.set_tick_params(labelleft=True)
        bars.legend(handles=[Patch(fc="0.4", ec="0.4", label=words[0]),
                             Patch(fc="white", ec="0.4", hatch="///", label=words[1])], loc="upper center",
                    bbox_to_anchor=(0.5, -0.1), ncols=2, frameon=False)
        bars.grid(alpha=0.3, axis="y")
        letter_panels([ax, bars])
    return figure_paths(path)
