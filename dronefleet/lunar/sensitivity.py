"""``dronefleet reproduce lunar-e4``: experiment E4 of the lunar study, sensitivity (spec section 14).

The sweep file ``configs/sweeps/lunar-e4.toml`` (the one source of truth) holds the five
scenarios (the E1 layouts at 10 Wh, SOFT-RT at 7.5 and 12.5 Wh) at the defaults and under each
one-at-a-time change of section 14 and the eps = 1 control. A configuration's change is the keys
it sets away from the defaults (:func:`change_of`), its scenario the layout and battery
(:func:`scenario_of`). Run j of every configuration draws the same per-robot streams (section
13), so a change's effect on a per-run value is paired by run index: the mean over runs of
(value under the change - value at the defaults) with its standard error (:func:`effects`).

The figure writes ``runs_by_change`` (one row per run: the simulator's summary after the
condition columns and ``change``) and ``effects`` (derived from it alone), then draws the effects as a dot
plot (:func:`draw_effects`). ``--check`` derives ``effects`` again and re-runs :data:`CHECK`
runs (:func:`rerun`). :mod:`dronefleet.lunar.study` calls these with E4's configurations.
"""

from __future__ import annotations

import dataclasses
import os
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from ..config import SweepError

__all__ = ["FIGURE", "DEFAULT", "METRICS", "SCENARIOS", "SCENARIO_KEYS", "change_of", "scenario_of", "runs_table",
           "effects", "tidy", "check_changes", "draw", "rerun", "draw_effects"]

FIGURE = "lunar-e4"
#: The change of the reference configurations (no key away from its default).
DEFAULT = "default"
#: The per-run values whose change the figure draws: resources returned at T_run, deaths, mobile robots at the end.
METRICS = ("resources", "deaths", "mobile")
#: The scenarios in the figure's order.
SCENARIOS = ("OPEN", "HARD-RT", "SOFT-RT", "SOFT-RT 7.5 Wh", "SOFT-RT 12.5 Wh")
#: Keys that name the scenario or the runs, not a change.
SCENARIO_KEYS = ("layout", "battery_wh", "runs", "first_run", "duration_s")
#: (change index, scenario index) of the runs ``--check`` simulates again, run 0 of each: the first
#: scenario at the defaults, the first change's first scenario and the last change's last scenario.
CHECK = ((0, 0), (1, 0), (-1, -1))
#: The effects table's columns.
EFFECT_COLUMNS = ("change", "condition", "metric", "default_mean", "mean", "effect", "se", "runs")


def _word(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    return f"{value:g}" if isinstance(value, float) else str(value)


def change_of(config: Any) -> str:
    """The words of ``config``'s change: ``key=value`` of each key away from its default (but
    :data:`SCENARIO_KEYS`), in the order of the keys, joined by ", "; :data:`DEFAULT` for none."""
    from .params import LunarParams

    default = LunarParams()
    words = [f"{field.name}={_word(getattr(config, field.name))}" for field in dataclasses.fields(config)
             if field.name not in SCENARIO_KEYS and getattr(config, field.name) != getattr(default, field.name)]
    return ", ".join(words) or DEFAULT


def scenario_of(config: Any) -> str:
    """The scenario's words: the layout, and the battery where it is not the default (``SOFT-RT 7.5 Wh``)."""
    from .experiments import condition_of
    from .params import LunarParams

    return condition_of(config.layout, config.battery_wh, LunarParams().eps)


def _summary_of(config: Any) -> pd.DataFrame:
    """The summary table of one chunk (module level: it runs in worker processes)."""
    from .simulate import simulate

    return simulate(config)["summary"].to_pandas()


def runs_table(configs: Sequence[Any], summaries: dict) -> pd.DataFrame:
    """One row per run of ``configs`` (``summaries``: chunk -> its summary table): ``experiment``,
    ``change``, ``condition`` (the scenario), the configuration columns, the summary, then
    ``selected`` (the runs of each change and scenario with most resources, as the other figures)."""
    from .experiments import chunks, condition_row, selected

    frames = []
    for config in configs:
        head = {**condition_row(config, "e4"), "condition": scenario_of(config), "v0": config.v0}
        head = {"experiment": "e4", "change": change_of(config), **{k: v for k, v in head.items() if k != "experiment"}}
        for chunk in chunks(config):
            table = summaries[chunk]
            frames.append(pd.concat([pd.DataFrame({k: np.repeat(v, len(table)) for k, v in head.items()}),
                                     table.drop(columns=[c for c in head if c in table.columns])], axis=1))
    runs = pd.concat(frames, ignore_index=True)
    twice = runs.duplicated(["change", "condition", "run"])
    if twice.any():
        row = runs[twice].iloc[0]
        raise SweepError(f"lunar e4: {row['change']}, {row['condition']} holds run {row['run']} twice")
    keep = pd.Series(False, index=runs.index)
    for _, mine in runs.groupby("change", sort=False):
        keep[mine.index] = selected(mine).to_numpy()
    return runs.assign(selected=keep.to_numpy())


def effects(runs: pd.DataFrame, metrics: Sequence[str] = METRICS) -> pd.DataFrame:
    """Each change's effect on each of ``metrics`` per scenario, paired by run index: over the runs
    both the change and :data:`DEFAULT` hold, ``effect`` = mean of (value - default value) and
    ``se`` its standard error (sd of the differences, ddof 1, / sqrt(runs); NaN for one run);
    ``default_mean`` and ``mean`` the two means over those runs. Changes in the order of
    ``runs``, the default left out; SweepError if a change has a run the default has not."""
    base = runs[runs["change"] == DEFAULT]
    rows = []
    for change in dict.fromkeys(runs["change"]):
        if change == DEFAULT:
            continue
        mine = runs[runs["change"] == change]
        for condition in dict.fromkeys(mine["condition"]):
            pair = mine[mine["condition"] == condition].merge(base[base["condition"] == condition], on="run",
                                                               how="left", suffixes=("", "_default"))
            if pair[f"{metrics[0]}_default"].isna().any():
                raise SweepError(f"lunar e4: {change}, {condition}: run {int(pair['run'].iloc[0])} has no run "
                                 "at the defaults to pair with")
            for metric in metrics:
                value = pair[metric].to_numpy(dtype=np.float64)
                ref = pair[f"{metric}_default"].to_numpy(dtype=np.float64)
                diff = value - ref
                n = len(diff)
                se = float(np.std(diff, ddof=1) / np.sqrt(n)) if n > 1 else float("nan")
                rows.append({"change": change, "condition": condition, "metric": metric,
                             "default_mean": float(ref.mean()), "mean": float(value.mean()),
                             "effect": float(diff.mean()), "se": se, "runs": n})
    return pd.DataFrame(rows, columns=list(EFFECT_COLUMNS)).astype({"runs": np.int64})


def tidy(study, configs: Sequence[Any]) -> None:
    """Run E4's ``configs`` (each chunk once, its summaries only) on ``study``'s processes; write
    ``runs_by_change`` and ``effects`` under ``study.figure_dir``."""
    from .experiments import chunks

    todo = list(dict.fromkeys(chunk for config in configs for chunk in chunks(config)))
    start = time.perf_counter()
    summaries = {}
    for chunk, table, error in study.map(_summary_of, todo):
        if error is not None:
            raise SweepError(f"lunar e4: {change_of(chunk)}, {scenario_of(chunk)}, runs {chunk.first_run}.."
                             f"{chunk.first_run + chunk.runs - 1}: {error}")
        summaries[chunk] = table
    study.log(f"  e4: {len(configs)} configurations, {len(todo)} chunks; {time.perf_counter() - start:.1f} s")
    runs = runs_table(configs, summaries)
    d = study.figure_dir(FIGURE)
    study.write_table(runs, d / "runs_by_change.parquet")
    study.write_table(effects(runs), d / "effects.parquet")


def check_changes(table: pd.DataFrame, path: Path, configs: Sequence[Any]) -> None:
    """SweepError (one line naming ``path`` and the value) if a ``change`` of ``table`` is none of ``configs``'."""
    unknown = sorted(set(table["change"]) - {change_of(c) for c in configs})
    if unknown:
        raise SweepError(f"{path}: change {unknown[0]!r} is none of configs/sweeps/lunar-e4.toml's")


def draw(tables: dict[str, pd.DataFrame], path: str | os.PathLike) -> list[Path]:
    """The figure's files from its tables (``runs_by_change``, ``effects``) alone."""
    n = int(tables["runs_by_change"].groupby(["change", "condition"]).size().min())
    return draw_effects(tables["effects"], n, path)


def rerun(runs: pd.DataFrame, configs: Sequence[Any]) -> list[tuple[str, pd.DataFrame, pd.DataFrame]]:
    """The :data:`CHECK` runs of ``configs`` simulated again: (their words, their rows of ``runs``,
    the fresh rows), ``selected`` left out (it ranks a run among its condition's)."""
    changes = list(dict.fromkeys(change_of(c) for c in configs))
    found = []
    for change_at, scenario_at in CHECK:
        change = changes[change_at]
        config = dataclasses.replace([c for c in configs if change_of(c) == change][scenario_at], runs=1)
        condition = scenario_of(config)
        old = runs[(runs["change"] == change) & (runs["condition"] == condition) & (runs["run"] == config.first_run)]
        fresh = runs_table([config], {config: _summary_of(config)})
        found.append((f"{change}, {condition} run {config.first_run}",
                      old.drop(columns=["selected"]).reset_index(drop=True), fresh.drop(columns=["selected"])))
    return found


METRIC_WORDS = {"resources": "resources returned by the end", "deaths": "deaths", "mobile": "mobile robots at the end"}


def draw_effects(table: pd.DataFrame, runs: int, path: str | os.PathLike) -> list[Path]:
    """E4: one panel per metric of :data:`METRICS`; a row per change (the table's order, top
    down), a dot per scenario (its colour and marker) at the paired effect, whiskers +- one
    standard error; a line at no effect."""
    from ..figstyle import DOUBLE_COLUMN, MIN_FONT_SIZE, PRINT_RC, _dodge, _figure, figure_paths, letter_panels
    from .figures import CONDITION_STYLES, WITHOUT

    changes = list(dict.fromkeys(table["change"]))
    scenarios = [s for s in SCENARIOS if s in set(table["condition"])]
    with _figure(path, (DOUBLE_COLUMN, 0.26 * len(changes) + 1.6), PRINT_RC, ncols=len(METRICS), sharey=True,
                 squeeze=False) as (mpl, fig, axes):
        for ax, metric in zip(axes[0], METRICS):
            ax.axvline(0.0, color="0.4", lw=0.8)
            for k, scenario in enumerate(scenarios):
                style = CONDITION_STYLES[scenario]
                rows = table[(table["metric"] == metric) & (table["condition"] == scenario)].set_index("change")
                rows = rows.reindex([c for c in changes if c in rows.index])
                y = np.array([changes.index(c) for c in rows.index], dtype=float) + _dodge(k, len(scenarios), 0.14)
                ax.errorbar(rows["effect"], y, xerr=rows["se"], ls="none", marker=style.marker, ms=3.0,
                            color=style.colour, elinewidth=0.7, capsize=1.2, label=scenario)
            ax.set_xlabel(METRIC_WORDS[metric])
            ax.grid(alpha=0.3, axis="x")
            ax.tick_params(labelsize=MIN_FONT_SIZE)
        axes[0, 0].set_yticks(range(len(changes)), [WITHOUT if c == "eps=1" else c.replace("=", " = ")
                                                     for c in changes])
        axes[0, 0].invert_yaxis()
        letter_panels(axes.flat)
        handles, labels = axes[0, 0].get_legend_handles_labels()
        fig.legend(handles, labels, loc="outside lower center", ncols=len(labels), frameon=False,
                   title=f"change from the defaults, paired by run: mean difference +- standard error "
                         f"({runs} runs each)")
    return figure_paths(path)
