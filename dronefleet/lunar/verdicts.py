"""A verdict for every claim of docs/lunar-thesis-checklist.md, from the runs of E1-E3.

:func:`experiment_runs` runs E1-E3 (the conditions of ``configs/sweeps/lunar-e1.toml``, ``-e2``,
``-e3``: nine conditions of 50 runs) on a base configuration and returns a :class:`Runs`: the
tables the claims read (``summary``, ``timeseries``, ``trips`` (every trip), ``snapshots``
(without frames), ``robots``, ``recharge_triggers``), each with a ``condition`` column
(:func:`~dronefleet.lunar.experiments.condition_of`: ``SOFT-RT``, ``SOFT-RT 7.5 Wh``, ...), and
each condition's configuration. E0 is run 0 of E1's SOFT-RT: the same run as the study's E0
(its frames only add snapshots). The tables keep only the columns the claims read (:data:`KEPT`):
all nine conditions' trips and snapshots would otherwise be tens of megabytes a reading.

Each claim id maps in :data:`CLAIMS` to a function ``f(runs) -> (verdict, numbers)``: verdict
one of :data:`VERDICTS`, numbers a short text of what was measured. The rules are the
checklist's: comparisons between conditions pair the per-run values by run index over all runs
(:func:`paired`), "agrees" only beyond twice the standard error; "similar" within 10 % of the
two means' average; a test on the selected runs (the 30 of 50 with most resources) says so.
:func:`verdict_table` applies every claim to the runs of two configurations. A difference of the
wrong sign does not hold, however small (the checklist's "direction only" needs the thesis's sign).
A claim whose runs hold nothing to measure it on (``--quick``'s short runs: no late window) is
not measured.

``dronefleet reproduce lunar-verdicts`` (:data:`FIGURE`) runs E1-E3 under each reading of
:data:`READINGS` and writes ``verdicts`` (:func:`measure`), drawn as a grid (:func:`draw`). The runs
are seeded, so ``--check`` runs them again and compares every verdict and number; their tables
(about 25 MB a reading) are not committed.

Where a measurement departs from the checklist's wording, for lack of a recorded quantity:

- E0's snapshots are its milestones and its periodic ones (no frames): C2 reads the first
  milestone (the first entry into T or R) rather than the frame before it; C11 the periodic
  snapshot nearest 1800 s, "holding a guidance vector" read as having a beacon in range that
  holds a vector for the robot's key;
- C10, C14: the summary's ``heading_alignment_*``, the cosine between each normal-mode mobile
  robot's motion and the way to its key's region at the end of the run, not a late-window mean;
- C29 and C30 give the same numbers where no robot dies after spawning (mobile + beacons is then
  the swarm's size);
- C65 reads the SOC at each row-2 firing from ``recharge_triggers`` (the checklist predates it);
- C17 and C49 are not measured: no table holds what they need.
"""

from __future__ import annotations

import dataclasses
import itertools
import logging
import math
import os
import time
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from ..config import read_toml
from ..pairs import paired
from . import experiments as ex
from .layout import build

__all__ = ["VERDICTS", "CLAIMS", "Runs", "conditions", "experiment_runs", "paired", "verdict_table",
           "HOLDS", "DIRECTION", "FAILS", "NOT_MEASURED", "FIGURE", "READINGS", "reading_configs", "measure",
           "tidy", "draw"]

logger = logging.getLogger(__name__)

HOLDS, DIRECTION, FAILS, NOT_MEASURED = "holds", "direction only", "does not hold", "not measured"
VERDICTS = (HOLDS, DIRECTION, FAILS, NOT_MEASURED)
#: The tables the claims read.
TABLES = ("summary", "timeseries", "trips", "snapshots", "robots", "recharge_triggers")
#: The columns the claims read of the larger tables (the others are kept whole).
KEPT = {"timeseries": ("run", "t", "resources", "sessions", "rate", "n_mobile", "n_beacons", "n_unspawned",
                       "soc_sum", "soc_beacons", "soc_mobile", "alignment_T", "alignment_N", "alignment_R"),
        "trips": ("run", "origin", "dest", "tick_entered", "length_m", "energy_wh", "soc_cost", "duration_s",
                  "soft_length_m"),
        "snapshots": ("run", "label", "t", "robot", "status", "role", "x", "y", "load",
                      *(f"{axis}_{key}" for axis in ("vx", "vy") for key in "TNR")),
        "robots": ("run", "robot", "unloads"),
        "recharge_triggers": ("run", "robot", "t", "soc")}
#: The experiments whose conditions the claims read (their sweep files).
SWEEPS = ("e1", "e2", "e3")
#: The checklist's windows [s]: early, late, steady phase, and the two halves of the late run.
EARLY, LATE, STEADY, MIDDLE = (0.0, 900.0), (2700.0, 3600.0), (1200.0, 3600.0), (1800.0, 2700.0)
#: "Similar": within this share of the two means' average.
SIMILAR = 0.10


@dataclasses.dataclass
class Runs:
    """The runs of E1-E3 for one base configuration: ``tables`` {name: DataFrame with a
    ``condition`` column}, ``configs`` {condition: LunarParams}."""

    tables: dict[str, pd.DataFrame]
    configs: dict[str, Any]

    def of(self, name: str, condition: str) -> pd.DataFrame:
        """The rows of table ``name`` of ``condition``."""
        table = self.tables[name]
        return table[table["condition"] == condition]

    def summary(self, condition: str) -> pd.DataFrame:
        """``condition``'s summary rows, by run, with ``selected`` (:func:`experiments.selected`)."""
        rows = self.of("summary", condition).sort_values("run").reset_index(drop=True)
        return rows.assign(selected=ex.selected(rows).to_numpy())

    def selected_runs(self, condition: str) -> np.ndarray:
        rows = self.summary(condition)
        return rows.loc[rows["selected"], "run"].to_numpy()


# ---------------------------------------------------------------- running E1-E3


def conditions(base: Any) -> list[Any]:
    """The configurations of E1-E3 (:data:`SWEEPS`: each sweep file's ``[set]`` and ``[grid]``) on
    ``base`` (a LunarParams), one per condition, E2's and E3's references being E1's."""
    out = {}
    for name in SWEEPS:
        _, document = read_toml(ex.grid_path(name), "sweep file")
        grid = document.get("grid", {})
        for values in itertools.product(*grid.values()):
            config = dataclasses.replace(base, **document.get("set", {}), **dict(zip(grid, values)))
            out.setdefault(ex.condition_of(config.layout, config.battery_wh, config.eps, config.model), config)
    return list(out.values())


def _tables_of(config: Any) -> dict[str, pd.DataFrame]:
    """The :data:`TABLES` of one chunk (module level: it runs in worker processes)."""
    from .simulate import simulate

    tables = simulate(config)
    return {name: tables[name].select(list(KEPT.get(name, tables[name].column_names))).to_pandas()
            for name in TABLES}


def _named(configs: Iterable[Any]) -> dict[str, Any]:
    """``configs`` by their condition's words."""
    return {ex.condition_of(c.layout, c.battery_wh, c.eps, c.model): c for c in configs}


def experiment_runs(configs: list[Any], outcomes: Callable | None = None) -> Runs:
    """Run ``configs`` (:func:`conditions`: one per condition) in chunks of :data:`experiments.CHUNK_RUNS`
    runs; ``outcomes(function, items)`` as :func:`experiments.run_configs` takes it (None: here)."""
    each = outcomes or (lambda function, items: ((item, function(item), None) for item in items))
    todo = [chunk for config in configs for chunk in ex.chunks(config)]
    done = {}
    for chunk, result, error in each(_tables_of, todo):
        if error is not None:
            raise error
        done[chunk] = result
    named = _named(configs)
    tables = {}
    for name in TABLES:
        tables[name] = pd.concat([done[chunk][name].assign(condition=condition)
                                  for condition, config in named.items() for chunk in ex.chunks(config)],
                                 ignore_index=True)
    return Runs(tables, named)


# ---------------------------------------------------------------- the rules of a verdict


def sign_verdict(mean: float, se: float) -> str:
    """The checklist's rule for a difference expected positive: beyond twice its standard error
    above 0 holds, above 0 within it is the direction only, below 0 does not hold."""
    if not math.isfinite(mean):
        return NOT_MEASURED
    if mean > 2.0 * se:
        return HOLDS
    return DIRECTION if mean > 0.0 else FAILS


def combine(verdicts: Iterable[str]) -> str:
    """Several comparisons of one claim: any failing fails it; all holding hold it; not measured
    if any is; else the direction only."""
    verdicts = list(verdicts)
    if NOT_MEASURED in verdicts:
        return NOT_MEASURED
    if FAILS in verdicts:
        return FAILS
    return HOLDS if all(v == HOLDS for v in verdicts) else DIRECTION


def _test(ok: bool) -> str:
    return HOLDS if ok else FAILS


def _fmt(mean: float, se: float) -> str:
    return f"{mean:+.3g} (se {se:.2g})"


def _positive(runs: Runs, pairs: Iterable[tuple[str, str]], per_run: Callable[[Runs, str], pd.Series]
              ) -> tuple[str, str]:
    """Each (a, b) of ``pairs``: ``per_run(a) - per_run(b)`` paired by run, expected positive."""
    verdicts, words = [], []
    for a, b in pairs:
        mean, se, _ = paired(per_run(runs, a), per_run(runs, b))
        verdicts.append(sign_verdict(mean, se))
        words.append(f"{a} - {b}: {_fmt(mean, se)}")
    return combine(verdicts), "; ".join(words)


def _above_zero(values: pd.Series) -> tuple[str, str]:
    """A one-sample test over runs: the mean above 0 beyond twice its standard error."""
    values = values.dropna()
    mean = float(values.mean()) if len(values) else math.nan
    se = float(values.std(ddof=1) / math.sqrt(len(values))) if len(values) > 1 else math.inf
    return sign_verdict(mean, se), _fmt(mean, se)


def _similar(a: float, b: float) -> bool:
    return abs(a - b) <= SIMILAR * abs(a + b) / 2.0


# ---------------------------------------------------------------- per-run quantities

E1 = ("OPEN", "HARD-RT", "SOFT-RT")
E2 = ("SOFT-RT 7.5 Wh", "SOFT-RT", "SOFT-RT 12.5 Wh")
E3 = ("HARD-RT", "SOFT-RT", "HARD-NT", "SOFT-NT", "HARD-NR", "SOFT-NR")
#: E0 (section 14): one SOFT-RT run, run 0 (the study's E0; its frames add only snapshots).
E0_CONDITION, E0_RUN = "SOFT-RT", 0
_KEYS = ("T", "N", "R")
_ROLE_KEY = {"F_OUT": "T", "F_IN": "N", "R": "R"}


def _column(runs: Runs, condition: str, column: str) -> pd.Series:
    """A summary column per run."""
    return runs.summary(condition).set_index("run")[column].astype(float)


def _at(runs: Runs, condition: str, column: str, t: float) -> pd.Series:
    """A timeseries column per run at the last record at or before ``t`` [s]."""
    ts = runs.of("timeseries", condition)
    ts = ts[ts["t"] <= t + 1e-9].sort_values("t")
    return ts.groupby("run")[column].last().astype(float)


def _window_mean(runs: Runs, condition: str, column: str, window: tuple[float, float]) -> pd.Series:
    ts = runs.of("timeseries", condition)
    ts = ts[(ts["t"] > window[0]) & (ts["t"] <= window[1] + 1e-9)]
    return ts.groupby("run")[column].mean().astype(float)


def _trips(runs: Runs, condition: str, pairs: Iterable[str] = ("RT",), window: tuple[float, float] | None = None
           ) -> pd.DataFrame:
    """``condition``'s trips between the regions of ``pairs`` (both directions; "RT": R-T and T-R)
    entered in ``window`` [s] (None: any time), with ``t_entered`` [s]."""
    trips = runs.of("trips", condition)
    tau = runs.configs[condition].tau
    ends = {frozenset(p) for p in pairs}
    keep = np.array([frozenset((o, d)) in ends for o, d in zip(trips["origin"], trips["dest"])], dtype=bool)
    trips = trips[keep].assign(t_entered=trips["tick_entered"].to_numpy()[keep] * tau)
    if window is not None:
        trips = trips[(trips["t_entered"] > window[0]) & (trips["t_entered"] <= window[1] + 1e-9)]
    return trips


def _trip_mean(column: str, window: tuple[float, float] | None = LATE, pairs: Iterable[str] = ("RT",)):
    """per_run(runs, condition): the mean ``column`` of the trips of ``pairs`` entered in ``window``."""
    def per_run(runs: Runs, condition: str) -> pd.Series:
        return _trips(runs, condition, pairs, window).groupby("run")[column].mean().astype(float)
    return per_run


def _summary_of(column: str):
    return lambda runs, condition: _column(runs, condition, column)


def _geometry(runs: Runs, condition: str):
    return build(runs.configs[condition])


def _centre_distance(runs: Runs, condition: str, a: str, b: str) -> float:
    centres = _geometry(runs, condition).centres
    return math.dist(centres[a], centres[b])


def _obstacle_width(runs: Runs, condition: str) -> float:
    """The soft obstacle's width along the line joining its regions [m] (layout.OBSTACLE_WIDTH scaled)."""
    from .layout import OBSTACLE_WIDTH

    return OBSTACLE_WIDTH * runs.configs[condition].layout_scale


def _course(runs: Runs, condition: str) -> pd.DataFrame:
    from .diagnosis import network_course

    return network_course(runs.of("timeseries", condition)).set_index("run")


def _per_layout(conditions: Iterable[str], test: Callable[[str], tuple[str, str]]) -> tuple[str, str]:
    results = [(c, *test(c)) for c in conditions]
    return combine(v for _, v, _ in results), "; ".join(f"{c}: {words}" for c, _, words in results)


def _not_measured(reason: str):
    def claim(runs: Runs) -> tuple[str, str]:
        return NOT_MEASURED, reason
    return claim


# ---------------------------------------------------------------- 6-2: the system in one run (E0) and in E1


def _e0_snapshot(runs: Runs, label: str, t: float | None = None) -> pd.DataFrame:
    """The E0 run's first snapshot labelled ``label`` (the one nearest ``t`` [s] if given: periodic
    snapshots fall on whole ticks); empty if none."""
    shots = runs.of("snapshots", E0_CONDITION)
    shots = shots[(shots["run"] == E0_RUN) & (shots["label"] == label)]
    if not len(shots):
        return shots
    at = shots["t"].min() if t is None else shots["t"].to_numpy()[np.argmin(np.abs(shots["t"].to_numpy() - t))]
    return shots[shots["t"] == at]


def _beacons_with(shot: pd.DataFrame, key: str) -> pd.DataFrame:
    """The alive beacons of a snapshot holding a vector (|v| > 0) for ``key``."""
    beacons = shot[(shot["status"] == "alive") & (shot["role"] == "B")]
    return beacons[np.hypot(beacons[f"vx_{key}"], beacons[f"vy_{key}"]) > 0.0]


def _alignment(beacons: pd.DataFrame, key: str, centre: tuple[float, float]) -> float:
    """Mean cosine between the ``key`` vectors of ``beacons`` and the way to ``centre``."""
    vx, vy = beacons[f"vx_{key}"].to_numpy(), beacons[f"vy_{key}"].to_numpy()
    wx, wy = centre[0] - beacons["x"].to_numpy(), centre[1] - beacons["y"].to_numpy()
    norm = np.hypot(vx, vy) * np.hypot(wx, wy)
    return float(np.mean((vx * wx + vy * wy)[norm > 0] / norm[norm > 0])) if (norm > 0).any() else math.nan


def c1(runs: Runs) -> tuple[str, str]:
    shot = _e0_snapshot(runs, "end")
    ids = [set(_beacons_with(shot, key)["robot"]) for key in _KEYS]
    return _test(len(ids[0] & ids[1] & ids[2]) > 0), f"{len(ids[0] & ids[1] & ids[2])} beacons hold T, N and R vectors"


def c2(runs: Runs) -> tuple[str, str]:
    shots = [_e0_snapshot(runs, label) for label in ("first_T", "first_R")]
    shot = min((s for s in shots if len(s)), key=lambda s: s["t"].iloc[0], default=None)
    if shot is None:
        return NOT_MEASURED, "T and R never entered in the E0 run"
    tr = len(_beacons_with(shot, "T")) + len(_beacons_with(shot, "R"))
    n = len(_beacons_with(shot, "N"))
    return (_test(tr == 0 and n > 0),
            f"at the first entry ({shot['t'].iloc[0]:.0f} s; no frames: the milestone snapshot): "
            f"{tr} T/R vectors, {n} N vectors")


def c3(runs: Runs) -> tuple[str, str]:
    rows = runs.summary(E0_CONDITION).set_index("run")
    first = rows["t_first_T"] < rows["t_first_R"]
    return (_test(bool(first.get(E0_RUN, False))),
            f"E0: T at {rows.at[E0_RUN, 't_first_T']:.0f} s, R at {rows.at[E0_RUN, 't_first_R']:.0f} s; "
            f"T first in {first.mean():.0%} of SOFT-RT runs")


def c4(runs: Runs) -> tuple[str, str]:
    shot = _e0_snapshot(runs, "first_R")
    if not len(shot):
        return NOT_MEASURED, "R never entered in the E0 run"
    beacons = len(_beacons_with(shot, "T"))
    loaded = int(((shot["status"] == "alive") & (shot["role"] == "F_IN") & (shot["load"] > 0)).sum())
    return _test(beacons > 0 and loaded > 0), f"{beacons} beacons with a T vector, {loaded} loaded F_IN robots"


def c5(runs: Runs) -> tuple[str, str]:
    shot = _e0_snapshot(runs, "first_row5")
    if not len(shot):
        return NOT_MEASURED, "row 5 never fired in the E0 run"
    layout, config = _geometry(runs, E0_CONDITION), runs.configs[E0_CONDITION]
    beacons = _beacons_with(shot, "R")
    cx, cy = layout.centres["R"]
    near = int((np.hypot(beacons["x"] - cx, beacons["y"] - cy) < layout.radii["R"] + 2 * config.comm_radius).sum())
    return _test(near > 0), f"{near} beacons within 2 delta_comm of R hold an R vector"


def c6(runs: Runs) -> tuple[str, str]:
    shots = [_e0_snapshot(runs, label) for label in ("first_R", "first_row5")]
    if not all(len(s) for s in shots):
        return NOT_MEASURED, "a milestone is missing in the E0 run"
    centre = _geometry(runs, E0_CONDITION).centres["T"]
    held = [_beacons_with(s, "T") for s in shots]
    align = [_alignment(h, "T", centre) for h in held]
    moved = abs(align[1] - align[0]) if all(map(math.isfinite, align)) else math.inf
    differ = set(held[0]["robot"]) != set(held[1]["robot"])
    return (_test(differ or moved > 0.1),
            f"T-vector beacons {len(held[0])} -> {len(held[1])} (set differs: {differ}), "
            f"T alignment {align[0]:.2f} -> {align[1]:.2f}")


def c7(runs: Runs) -> tuple[str, str]:
    def test(condition: str) -> tuple[str, str]:
        ts = runs.of("timeseries", condition)
        ts = ts[ts["run"].isin(runs.selected_runs(condition))]
        full = ts[ts[[f"alignment_{key}" for key in _KEYS]].notna().all(axis=1)]
        first = full.groupby("run")["t"].min()
        reached = len(first) == len(runs.selected_runs(condition))
        return _test(reached), f"{len(first)}/{len(runs.selected_runs(condition))} runs, median {first.median():.0f} s"
    return _per_layout(E1, test)


def _alignments_above_zero(runs: Runs, conditions: Iterable[str], prefix: str = "alignment") -> tuple[str, str]:
    def test(condition: str) -> tuple[str, str]:
        results = [_above_zero(_column(runs, condition, f"{prefix}_{key}")) for key in _KEYS]
        return combine(v for v, _ in results), " ".join(f"{key} {w}" for key, (_, w) in zip(_KEYS, results))
    return _per_layout(conditions, test)


def c8(runs: Runs) -> tuple[str, str]:
    return _alignments_above_zero(runs, E1)


def c9(runs: Runs) -> tuple[str, str]:
    def test(condition: str) -> tuple[str, str]:
        verdicts, words = [], []
        for key in _KEYS:
            late = _window_mean(runs, condition, f"alignment_{key}", LATE)
            mean, se, _ = paired(late, _window_mean(runs, condition, f"alignment_{key}", MIDDLE))
            level, _ = _above_zero(late)
            verdicts.append(_test(abs(mean) <= 2.0 * se and level == HOLDS))
            words.append(f"{key} {late.mean():.2f}, change {_fmt(mean, se)}")
        return combine(verdicts), ", ".join(words)
    return _per_layout(E1, test)


def c10(runs: Runs) -> tuple[str, str]:
    return _alignments_above_zero(runs, E1, "heading_alignment")


def c11(runs: Runs) -> tuple[str, str]:
    shot = _e0_snapshot(runs, "periodic", 1800.0)
    if not len(shot):
        return NOT_MEASURED, "no E0 snapshot at 1800 s"
    comm = runs.configs[E0_CONDITION].comm_radius
    counts = {}
    for role, key in _ROLE_KEY.items():
        movers = shot[(shot["status"] == "alive") & (shot["role"] == role)]
        beacons = _beacons_with(shot, key)
        d2 = ((movers["x"].to_numpy()[:, None] - beacons["x"].to_numpy()[None]) ** 2
              + (movers["y"].to_numpy()[:, None] - beacons["y"].to_numpy()[None]) ** 2)
        counts[role] = int((d2 < comm * comm).any(axis=1).sum()) if len(beacons) else 0
    return (_test(all(counts.values())),
            "robots with a guidance beacon in range (1800-s snapshot): "
            + ", ".join(f"{r} {n}" for r, n in counts.items()))


def c12(runs: Runs) -> tuple[str, str]:
    def test(condition: str) -> tuple[str, str]:
        verdicts, words = [], []
        for key in _KEYS:
            mean, se, _ = paired(_at(runs, condition, f"alignment_{key}", 3600.0),
                                 _at(runs, condition, f"alignment_{key}", 600.0))
            verdicts.append(sign_verdict(mean, se))
            words.append(f"{key} {_fmt(mean, se)}")
        return combine(verdicts), " ".join(words)
    return _per_layout(E1, test)


def c13(runs: Runs) -> tuple[str, str]:
    layout = _geometry(runs, "SOFT-RT")
    direct = _centre_distance(runs, "SOFT-RT", "R", "T") - layout.radii["R"] - layout.radii["T"]
    width = _obstacle_width(runs, "SOFT-RT")
    length = _trip_mean("length_m")(runs, "SOFT-RT").mean()
    soft = _trip_mean("soft_length_m")(runs, "SOFT-RT").mean()
    return (_test(length > direct and soft < width),
            f"length {length:.2f} m (direct {direct:.2f}), soft length {soft:.2f} m (width {width:.2f})")


def c14(runs: Runs) -> tuple[str, str]:
    def test(condition: str) -> tuple[str, str]:
        means = [_column(runs, condition, f"heading_alignment_{key}").mean() for key in _KEYS]
        return _test(all(m < 0.9 for m in means)), " ".join(f"{k} {m:.2f}" for k, m in zip(_KEYS, means))
    return _per_layout(E1, test)


def c15(runs: Runs) -> tuple[str, str]:
    def test(condition: str) -> tuple[str, str]:
        ratio = (_trip_mean("length_m", pairs=("TN",))(runs, condition).mean()
                 / _centre_distance(runs, condition, "T", "N"))
        return _test(ratio > 1.2), f"{ratio:.2f}"
    return _per_layout(E1, test)


def _clipped(trips: pd.DataFrame, width: float) -> pd.Series:
    """Trips that enter the soft obstacle for less than its width: a clipped corner."""
    return (trips["soft_length_m"] > 0) & (trips["soft_length_m"] < width)


def c16(runs: Runs) -> tuple[str, str]:
    width = _obstacle_width(runs, "SOFT-RT")
    trips = _trips(runs, "SOFT-RT")
    clipped = _clipped(trips, width)
    e0 = int(clipped[trips["run"] == E0_RUN].sum())
    share = float(clipped.mean()) if len(trips) else math.nan
    return _test(e0 > 0 and share > 0), f"E0 run: {e0} clipped R-T trips; share at 10 Wh {share:.1%}"


# ---------------------------------------------------------------- 6-3-1: sustained foraging (E1)


def _selected_mean_at_least(column: str, bound: float, conditions: Iterable[str] = E1):
    def claim(runs: Runs) -> tuple[str, str]:
        def test(condition: str) -> tuple[str, str]:
            rows = runs.summary(condition)
            mean = float(rows.loc[rows["selected"], column].mean())
            return _test(mean >= bound), f"{mean:.1f}"
        return _per_layout(conditions, test)
    return claim


def c20(runs: Runs) -> tuple[str, str]:
    def test(condition: str) -> tuple[str, str]:
        robots = runs.of("robots", condition)
        robots = robots[robots["run"].isin(runs.selected_runs(condition)) & (robots["unloads"] > 0)]
        mean = float(robots.groupby("run")["unloads"].mean().mean())
        return _test(mean >= 2), f"{mean:.1f} unloads per unloading robot"
    return _per_layout(E1, test)


def _energy_per_trip(runs: Runs, condition: str) -> pd.Series:
    return runs.of("trips", condition).groupby("run")["energy_wh"].mean().astype(float)


def c26(runs: Runs) -> tuple[str, str]:
    def test(condition: str) -> tuple[str, str]:
        late = _window_mean(runs, condition, "rate", LATE)
        middle = _window_mean(runs, condition, "rate", MIDDLE)
        mean, se, _ = paired(late, middle)
        steady = abs(mean) <= 2.0 * se or abs(mean) <= SIMILAR * middle.mean()
        positive = bool((late.reindex(runs.selected_runs(condition)) > 0).all())
        return _test(steady and positive), f"late {late.mean():.2f}, change {_fmt(mean, se)}"
    return _per_layout(E1, test)


def _mean_curve(runs: Runs, condition: str, column: str) -> pd.Series:
    """The mean of ``column`` over the selected runs at every record (index t)."""
    ts = runs.of("timeseries", condition)
    return ts[ts["run"].isin(runs.selected_runs(condition))].groupby("t")[column].mean()


def c27(runs: Runs) -> tuple[str, str]:
    def test(condition: str) -> tuple[str, str]:
        t = float(_mean_curve(runs, condition, "n_beacons").idxmax())
        return _test(900.0 <= t <= 1800.0), f"peak at {t:.0f} s"
    return _per_layout(E1, test)


def c28(runs: Runs) -> tuple[str, str]:
    def test(condition: str) -> tuple[str, str]:
        t90 = float(_course(runs, condition)["t90"].reindex(runs.selected_runs(condition)).median())
        return _test(600.0 <= t90 <= 1800.0), f"t90 {t90:.0f} s"
    return _per_layout(E1, test)


def _course_positive(column: str, conditions: Iterable[str]):
    def claim(runs: Runs) -> tuple[str, str]:
        return _per_layout(conditions, lambda c: _above_zero(_course(runs, c)[column].astype(float)))
    return claim


def c31(runs: Runs) -> tuple[str, str]:
    def test(condition: str) -> tuple[str, str]:
        ts = runs.of("timeseries", condition)
        ts = ts[ts["run"].isin(runs.selected_runs(condition))]
        spawned = ts[ts["n_unspawned"] == 0]
        mobile = spawned.groupby("run")["n_mobile"].min() > 0
        end = runs.configs[condition].duration_s
        late = (_at(runs, condition, "resources", end) - _at(runs, condition, "resources", end - 600.0)
                ).reindex(runs.selected_runs(condition)) > 0
        return (_test(bool(mobile.all() and late.all())),
                f"mobile always: {int(mobile.sum())}/{len(mobile)}, returns in the last 600 s: "
                f"{int(late.sum())}/{len(late)}")
    return _per_layout(E1, test)


def _covered(shot: pd.DataFrame, field: tuple[float, float], comm: float, step: float = 0.1) -> float:
    """Share of the field within ``comm`` of an alive beacon of ``shot`` (a grid of ``step`` [m])."""
    beacons = shot[(shot["status"] == "alive") & (shot["role"] == "B")]
    if not len(beacons):
        return 0.0
    gx, gy = np.meshgrid(np.arange(step / 2, field[0], step), np.arange(step / 2, field[1], step))
    covered = np.zeros(gx.shape, dtype=bool)
    for x, y in zip(beacons["x"], beacons["y"]):
        covered |= (gx - x) ** 2 + (gy - y) ** 2 < comm * comm
    return float(covered.mean())


def c32(runs: Runs) -> tuple[str, str]:
    def test(condition: str) -> tuple[str, str]:
        course = _course(runs, condition)
        field = _geometry(runs, condition).field
        shots = runs.of("snapshots", condition)
        shares = []
        for run in runs.selected_runs(condition):
            mine = shots[shots["run"] == run]
            t = mine["t"].unique()
            nearest = t[np.argmin(np.abs(t - course.at[run, "t_peak"]))]
            shares.append(_covered(mine[mine["t"] == nearest], field, runs.configs[condition].comm_radius))
        return _test(float(np.mean(shares)) >= 0.95), f"{np.mean(shares):.0%} covered"
    return _per_layout(E1, test)


def c33(runs: Runs) -> tuple[str, str]:
    def test(condition: str) -> tuple[str, str]:
        curve = _mean_curve(runs, condition, "soc_sum")
        step = float(np.median(np.diff(curve.index)))
        smooth = curve.rolling(max(1, int(round(300.0 / step))), center=True).mean().dropna()
        v = smooth.to_numpy()
        rising = np.flatnonzero(np.diff(v) > 0)
        t = float(smooth.index[rising[0]]) if len(rising) else math.nan
        return _test(900.0 <= t <= 1800.0), f"first minimum at {t:.0f} s"
    return _per_layout(E1, test)


def _slopes(runs: Runs, condition: str, column: str) -> pd.Series:
    """Least-squares slope of ``column`` over the steady phase, per run [per s]."""
    ts = runs.of("timeseries", condition)
    ts = ts[(ts["t"] >= STEADY[0]) & (ts["t"] <= STEADY[1])]
    return ts.groupby("run").apply(lambda r: np.polyfit(r["t"], r[column], 1)[0], include_groups=False)


def c34(runs: Runs) -> tuple[str, str]:
    def test(condition: str) -> tuple[str, str]:
        slope = _slopes(runs, condition, "soc_sum")
        verdict, words = _above_zero(-slope)
        fall = -slope.mean() * (STEADY[1] - STEADY[0]) / runs.configs[condition].n_robots
        if verdict == HOLDS and fall >= 0.10:
            verdict = DIRECTION
        return verdict, f"fall over the phase {fall:.1%} of full charge, -slope {words}"
    return _per_layout(E1, test)


def c35(runs: Runs) -> tuple[str, str]:
    def test(condition: str) -> tuple[str, str]:
        total = _slopes(runs, condition, "soc_sum").mean()
        beacons = _slopes(runs, condition, "soc_beacons").mean()
        return (_test(beacons < 0 and total < 0 and beacons <= 0.5 * total),
                f"slopes [1/h] beacons {beacons * 3600:.2f}, all {total * 3600:.2f}")
    return _per_layout(E1, test)


def c36(runs: Runs) -> tuple[str, str]:
    def test(condition: str) -> tuple[str, str]:
        ts = runs.of("timeseries", condition)
        ts = ts[(ts["t"] >= STEADY[0]) & (ts["t"] <= STEADY[1])]

        def spread(column: str) -> float:
            return float(ts.groupby("run").apply(
                lambda r: np.std(r[column] - np.polyval(np.polyfit(r["t"], r[column], 1), r["t"])),
                include_groups=False).mean())
        mobile, beacons = spread("soc_mobile"), spread("soc_beacons")
        return _test(mobile > beacons), f"sd mobile {mobile:.2f}, beacons {beacons:.2f}"
    return _per_layout(E1, test)


def _sessions_each_third(conditions: Iterable[str]):
    def claim(runs: Runs) -> tuple[str, str]:
        def test(condition: str) -> tuple[str, str]:
            end = runs.configs[condition].duration_s
            edges = [_at(runs, condition, "sessions", t) for t in (end / 3, 2 * end / 3, end)]
            thirds = [edges[0], edges[1] - edges[0], edges[2] - edges[1]]
            chosen = runs.selected_runs(condition)
            ok = [int((third.reindex(chosen) >= 1).sum()) for third in thirds]
            return _test(all(n == len(chosen) for n in ok)), f"runs with a session per third {ok} of {len(chosen)}"
        return _per_layout(conditions, test)
    return claim


def c38(runs: Runs) -> tuple[str, str]:
    def test(condition: str) -> tuple[str, str]:
        rows = runs.summary(condition)
        rows = rows[rows["selected"]]
        flat = rows["depletions"]   # the deaths, or the robots that went on (A32 "recorded")
        return _test(bool((flat == 0).all())), f"{flat.mean():.2f} robots at SOC 0 per run"
    return _per_layout(E1, test)


# ---------------------------------------------------------------- 6-3-2: self-organizing and optimization (E2)


def _late_means(runs: Runs, conditions: Iterable[str], column: str, window=LATE) -> dict[str, float]:
    """The mean over runs of each run's mean ``column`` of the R-T trips entered in ``window``."""
    return {c: float(_trip_mean(column, window)(runs, c).mean()) for c in conditions}


def c39(runs: Runs) -> tuple[str, str]:
    cost = _late_means(runs, ["SOFT-RT"], "soc_cost")["SOFT-RT"]
    verdict = HOLDS if 0.2 <= cost <= 0.3 else DIRECTION if cost < 0.2 else FAILS
    return verdict, f"{cost:.3f} of a battery"


def c40(runs: Runs) -> tuple[str, str]:
    conditions = ("SOFT-RT 7.5 Wh", "SOFT-RT", "SOFT-RT 12.5 Wh", "HARD-RT")
    late = _late_means(runs, conditions, "soc_cost")
    early = _late_means(runs, conditions, "soc_cost", EARLY)
    mean = np.mean(list(late.values()))
    close = all(abs(v - mean) <= SIMILAR * mean for v in late.values())
    spread, spread0 = np.ptp(list(late.values())), np.ptp(list(early.values()))
    return (_test(close and spread < spread0),
            ", ".join(f"{c} {v:.3f}" for c, v in late.items()) + f"; spread {spread:.3f} (early {spread0:.3f})")


def c41(runs: Runs) -> tuple[str, str]:
    verdict, words = _positive(runs, [("SOFT-RT", "OPEN"), ("HARD-RT", "OPEN")], _trip_mean("soc_cost"))
    late = _late_means(runs, ("OPEN", "SOFT-RT", "HARD-RT"), "soc_cost")
    lower = late["OPEN"] <= 0.8 * min(late["SOFT-RT"], late["HARD-RT"])
    if verdict == HOLDS and not lower:
        verdict = DIRECTION
    return verdict, f"{words}; OPEN {late['OPEN']:.3f}"


def _paired_claim(pairs: list[tuple[str, str]], per_run: Callable[[Runs, str], pd.Series]):
    return lambda runs: _positive(runs, pairs, per_run)


def c44(runs: Runs) -> tuple[str, str]:
    late = _late_means(runs, ("SOFT-RT 12.5 Wh", "SOFT-RT", "OPEN"), "length_m")
    near = _similar(late["SOFT-RT 12.5 Wh"], late["OPEN"])
    nearer = abs(late["SOFT-RT 12.5 Wh"] - late["OPEN"]) < abs(late["SOFT-RT"] - late["OPEN"])
    return (HOLDS if near and nearer else DIRECTION if nearer else FAILS,
            ", ".join(f"{c} {v:.2f} m" for c, v in late.items()))


def _entering(runs: Runs, condition: str) -> pd.Series:
    """Per run, the share of the late R-T trips that enter the soft obstacle."""
    trips = _trips(runs, condition, window=LATE)
    return (trips["soft_length_m"] > 0).groupby(trips["run"]).mean().astype(float)


def c45(runs: Runs) -> tuple[str, str]:
    verdict, words = _positive(runs, [("SOFT-RT 12.5 Wh", "SOFT-RT"), ("SOFT-RT", "SOFT-RT 7.5 Wh")],
                               _trip_mean("soft_length_m"))
    shares = ", ".join(f"{c} {_entering(runs, c).mean():.0%}" for c in E2)
    return verdict, f"{words}; entering {shares}"


def c46(runs: Runs) -> tuple[str, str]:
    late = _late_means(runs, ("SOFT-RT 7.5 Wh", "HARD-RT"), "length_m")
    return (_test(_similar(late["SOFT-RT 7.5 Wh"], late["HARD-RT"])),
            ", ".join(f"{c} {v:.2f} m" for c, v in late.items()))


def c47(runs: Runs) -> tuple[str, str]:
    bins = []
    for condition in ("SOFT-RT 7.5 Wh", "SOFT-RT", "SOFT-RT 12.5 Wh", "OPEN", "HARD-RT"):
        trips = _trips(runs, condition)
        trips = trips[trips["run"].isin(runs.selected_runs(condition))]
        start = np.maximum(np.ceil(trips["t_entered"] / ex.BIN_S - 1e-9), 1.0)
        bins.append(trips.groupby(start)[["duration_s", "length_m"]].mean())
    both = pd.concat(bins)
    r = float(np.corrcoef(both["duration_s"], both["length_m"])[0, 1])
    return _test(r >= 0.95), f"r = {r:.3f} over {len(both)} bins"


def _early_late(column: str, condition: str, late_higher: bool) -> Callable[[Runs], tuple[str, str]]:
    def claim(runs: Runs) -> tuple[str, str]:
        late = _trip_mean(column, LATE)(runs, condition)
        early = _trip_mean(column, EARLY)(runs, condition)
        mean, se, _ = paired(late, early) if late_higher else paired(early, late)
        what = "late - early" if late_higher else "early - late"
        return sign_verdict(mean, se), f"{condition} {column} {what} {_fmt(mean, se)}"
    return claim


def c51(runs: Runs) -> tuple[str, str]:
    late = _late_means(runs, ("HARD-RT", "SOFT-RT"), "energy_wh")
    return _test(_similar(late["HARD-RT"], late["SOFT-RT"])), ", ".join(f"{c} {v:.3f} Wh" for c, v in late.items())


def c54(runs: Runs) -> tuple[str, str]:
    return _positive(runs, [("SOFT-RT", "SOFT-RT 7.5 Wh")], _entering)


def c55(runs: Runs) -> tuple[str, str]:
    shares = {c: float(_entering(runs, c).mean()) for c in E2}
    trips = _trips(runs, "SOFT-RT", window=LATE)
    entered = trips[trips["soft_length_m"] > 0]
    clipped = float(_clipped(entered, _obstacle_width(runs, "SOFT-RT")).mean()) if len(entered) else math.nan
    low, high = sorted((shares["SOFT-RT 7.5 Wh"], shares["SOFT-RT 12.5 Wh"]))
    return (_test(low <= shares["SOFT-RT"] <= high and clipped > 0.5),
            "entering " + ", ".join(f"{c} {v:.0%}" for c, v in shares.items()) + f"; clipped corners {clipped:.0%}")


def c56(runs: Runs) -> tuple[str, str]:
    verdicts, words = [], []
    for pair in ("NT", "TR", "RN"):
        ratio = {c: _trip_mean("length_m", pairs=(pair,))(runs, c).mean() / _centre_distance(runs, c, *pair)
                 for c in ("SOFT-RT 12.5 Wh", "OPEN")}
        verdicts.append(_test(_similar(ratio["SOFT-RT 12.5 Wh"], ratio["OPEN"])))
        words.append(f"{pair} {ratio['SOFT-RT 12.5 Wh']:.2f} vs OPEN {ratio['OPEN']:.2f}")
    return combine(verdicts), ", ".join(words)


# ---------------------------------------------------------------- 6-3-3: adaptability (E3)


def c59(runs: Runs) -> tuple[str, str]:
    def test(condition: str) -> tuple[str, str]:
        end = runs.configs[condition].duration_s
        late = (_at(runs, condition, "resources", end) - _at(runs, condition, "resources", end - 900.0)
                ).reindex(runs.selected_runs(condition))
        return _test(bool((late > 0).all())), f"{int((late > 0).sum())}/{len(late)}"
    return _per_layout(E3, test)


def c65(runs: Runs) -> tuple[str, str]:
    def soc(runs: Runs, condition: str) -> pd.Series:
        return runs.of("recharge_triggers", condition).groupby("run")["soc"].mean().astype(float)
    return _positive(runs, [("HARD-NR", "HARD-RT"), ("SOFT-NR", "SOFT-RT")], soc)


def _steady(column: str):
    return lambda runs, condition: _window_mean(runs, condition, column, STEADY)


_resources = _summary_of("resources")

#: claim id -> its function (runs -> (verdict, numbers)).
CLAIMS: dict[str, Callable[[Runs], tuple[str, str]]] = {
    "C1": c1, "C2": c2, "C3": c3, "C4": c4, "C5": c5, "C6": c6, "C7": c7, "C8": c8, "C9": c9, "C10": c10,
    "C11": c11, "C12": c12, "C13": c13, "C14": c14, "C15": c15, "C16": c16,
    "C17": _not_measured("needs each heading decision's position relative to the robots that taught its beacons, "
                         "which no table records"),
    "C18": _selected_mean_at_least("resources", 600.0),
    "C19": _selected_mean_at_least("trips", 100.0),
    "C20": c20,
    "C21": _paired_claim([("HARD-RT", "OPEN"), ("SOFT-RT", "OPEN")], _summary_of("interruptions")),
    "C22": _paired_claim([("SOFT-RT", "HARD-RT")], _summary_of("interruptions")),
    "C23": _paired_claim([("SOFT-RT", "HARD-RT")], _energy_per_trip),
    "C24": _paired_claim([("OPEN", "HARD-RT"), ("OPEN", "SOFT-RT")], _resources),
    "C25": _paired_claim([("HARD-RT", "OPEN"), ("SOFT-RT", "OPEN")], _trip_mean("duration_s", None, ("TN",))),
    "C26": c26, "C27": c27, "C28": c28,
    "C29": _course_positive("decay", E1),
    "C30": _course_positive("mobile_rise", E1),
    "C31": c31, "C32": c32, "C33": c33, "C34": c34, "C35": c35, "C36": c36,
    "C37": _sessions_each_third(E1),
    "C38": c38, "C39": c39, "C40": c40, "C41": c41,
    "C42": _paired_claim([("SOFT-RT 12.5 Wh", "SOFT-RT"), ("SOFT-RT", "SOFT-RT 7.5 Wh")], _trip_mean("energy_wh")),
    "C43": _paired_claim([("SOFT-RT 7.5 Wh", "SOFT-RT"), ("SOFT-RT", "SOFT-RT 12.5 Wh")], _trip_mean("length_m")),
    "C44": c44, "C45": c45, "C46": c46, "C47": c47,
    "C48": _early_late("length_m", "HARD-RT", late_higher=True),
    "C49": _not_measured("needs the time in avoidance per trip and the trips' least clearance from the obstacle, "
                         "which the trip records do not hold"),
    "C50": _early_late("energy_wh", "HARD-RT", late_higher=False),
    "C51": c51,
    "C52": _paired_claim([("HARD-RT", "SOFT-RT")], _trip_mean("length_m")),
    "C53": _paired_claim([("HARD-RT", "SOFT-RT 7.5 Wh")], _trip_mean("energy_wh")),
    "C54": c54, "C55": c55, "C56": c56,
    "C57": _paired_claim([("SOFT-RT 7.5 Wh", "SOFT-RT 12.5 Wh"), ("SOFT-RT", "SOFT-RT 12.5 Wh")],
                         _summary_of("beacons")),
    "C58": lambda runs: _alignments_above_zero(runs, E3),
    "C59": c59,
    "C60": _sessions_each_third(E3),
    "C61": _paired_claim([("SOFT-RT", "SOFT-NT"), ("SOFT-RT", "SOFT-NR")], _resources),
    "C62": _paired_claim([("HARD-RT", "HARD-NT"), ("HARD-RT", "HARD-NR")], _resources),
    "C63": _paired_claim([("SOFT-NT", "SOFT-NR")], _resources),
    "C64": _paired_claim([("HARD-NT", "HARD-NR")], _resources),
    "C65": c65,
    "C66": _paired_claim([("SOFT-RT", "SOFT-NR"), ("SOFT-NT", "SOFT-NR")], _steady("soc_sum")),
    "C67": _paired_claim([("HARD-RT", "HARD-NR"), ("HARD-NT", "HARD-NR")], _steady("soc_sum")),
    "C68": _course_positive("mobile_rise", E3),
    "C69": _paired_claim([("SOFT-NT", "SOFT-RT"), ("SOFT-NT", "SOFT-NR")], _steady("n_mobile")),
    "C70": _paired_claim([("HARD-NT", "HARD-RT"), ("HARD-NT", "HARD-NR")], _steady("n_mobile")),
}


def verdicts(runs: Runs) -> pd.DataFrame:
    """Every claim of :data:`CLAIMS` on ``runs``: ``claim``, ``verdict``, ``numbers``."""
    rows = [(claim, *_measured(function, runs)) for claim, function in CLAIMS.items()]
    return pd.DataFrame(rows, columns=["claim", "verdict", "numbers"])


def _measured(function: Callable[[Runs], tuple[str, str]], runs: Runs) -> tuple[str, str]:
    """``function(runs)``, or not measured where the runs hold nothing to measure it on (a window
    the runs do not reach, so an empty table of the wrong type: ``--quick``'s short runs)."""
    try:
        return function(runs)
    except (ValueError, IndexError, KeyError, TypeError, ZeroDivisionError, np.linalg.LinAlgError) as error:
        logger.debug("claim not measured: %s", error)
        return NOT_MEASURED, "nothing to measure in these runs"


def verdict_table(defaults: Runs, thesis: Runs) -> pd.DataFrame:
    """The verdicts under two configurations side by side: ``claim``, ``verdict_defaults``,
    ``numbers_defaults``, ``verdict_thesis``, ``numbers_thesis``."""
    a, b = verdicts(defaults), verdicts(thesis)
    return pd.DataFrame({"claim": a["claim"], "verdict_defaults": a["verdict"], "numbers_defaults": a["numbers"],
                         "verdict_thesis": b["verdict"], "numbers_thesis": b["numbers"]})


# ---------------------------------------------------------------- the figure lunar-verdicts (dronefleet reproduce)

FIGURE = "lunar-verdicts"
#: The readings: the configuration each runs E1-E3 on (a file of configs/), and the figure's words for it.
READINGS = {"defaults": "lunar.toml", "thesis": "lunar-thesis.toml"}
READING_WORDS = {"defaults": "defaults", "thesis": "thesis reading"}
#: The thesis's sections (the checklist's): their words and their first and last claim.
SECTIONS = {"6-2 the system\nin one run": (1, 17), "6-3-1 sustained\nforaging": (18, 38),
            "6-3-2 self-organizing\nand optimization": (39, 57), "6-3-3 adaptability\nto the environment": (58, 70)}
#: The colour of each verdict (:data:`VERDICTS`' order).
VERDICT_COLOURS = ("#1b7837", "#a6dba0", "#c2185b", "#d9d9d9")


def reading_configs(changes: dict | None = None) -> dict[str, list[Any]]:
    """Each reading's configurations of E1-E3 (:func:`conditions` on its configuration file), with
    ``changes`` (``--quick``'s) applied."""
    return {reading: [dataclasses.replace(config, **(changes or {})) for config in conditions(_config_file(path))]
            for reading, path in READINGS.items()}


def _config_file(name: str) -> Any:
    """The LunarParams of the shipped config file ``name``: the defaults updated by its sections' keys,
    checked (read here, not by :func:`dronefleet.lunar.scenario.load`, whose study hook imports this module)."""
    from ..config import shipped_config
    from .keys import checked
    from .params import LunarParams

    _, document = read_toml(shipped_config(name), "config file")
    keys = {key: value for section in document.values() if isinstance(section, dict) for key, value in section.items()}
    return checked({**{f.name: getattr(LunarParams(), f.name) for f in dataclasses.fields(LunarParams)}, **keys})


def measure(study, configs: dict[str, list[Any]]) -> pd.DataFrame:
    """Run E1-E3 under each reading (``configs``: :func:`reading_configs`) on ``study``'s processes
    and return their :func:`verdict_table`. The runs are seeded, so ``--check`` measures again and
    compares the verdicts and numbers (about 80 CPU s a reading); their tables are not kept
    (about 25 MB a reading)."""
    runs = []
    for reading, mine in configs.items():
        start = time.perf_counter()
        runs.append(experiment_runs(mine, study.map))
        study.log(f"  verdicts, {READING_WORDS[reading]}: E1-E3, {len(mine)} conditions; "
                  f"{time.perf_counter() - start:.1f} s")
    return verdict_table(*runs)


def tidy(study, configs: dict[str, list[Any]]) -> None:
    """Write ``verdicts`` (:func:`measure`) into the figure's folder."""
    study.write_table(measure(study, configs), study.figure_dir(FIGURE) / "verdicts.parquet")


def draw(table: pd.DataFrame, path: str | os.PathLike) -> list[Path]:
    """The verdicts as a grid: a panel per thesis section (:data:`SECTIONS`), a row per claim, a
    column per reading, each cell coloured by its verdict."""
    from ..figstyle import DOUBLE_COLUMN, MIN_FONT_SIZE, PRINT_RC, _figure, figure_paths, letter_panels

    number = table["claim"].str[1:].astype(int)
    sections = {title: table[(number >= first) & (number <= last)] for title, (first, last) in SECTIONS.items()}
    tallest = max(len(rows) for rows in sections.values())
    with _figure(path, (DOUBLE_COLUMN, 0.14 * tallest + 1.8), PRINT_RC, ncols=len(sections),
                 squeeze=False) as (mpl, fig, axes):
        colours = mpl.colors.ListedColormap(VERDICT_COLOURS)
        for ax, (title, rows) in zip(axes[0], sections.items()):
            cells = np.array([[VERDICTS.index(v) for v in rows[f"verdict_{reading}"]] for reading in READINGS],
                             dtype=float).T.reshape(-1, len(READINGS))
            ax.imshow(cells, cmap=colours, vmin=-0.5, vmax=len(VERDICTS) - 0.5, aspect="auto",
                      interpolation="nearest")
            ax.set_ylim(tallest - 0.5, -0.5)   # cells of one height in every panel
            ax.set_yticks(range(len(rows)), rows["claim"].tolist())
            ax.set_xticks(range(len(READINGS)), [READING_WORDS[r].replace(" ", "\n") for r in READINGS])
            ax.set_xticks(np.arange(len(READINGS) + 1) - 0.5, minor=True)
            ax.set_yticks(np.arange(len(rows) + 1) - 0.5, minor=True)
            ax.grid(which="minor", color="white", lw=0.8)
            ax.tick_params(which="both", labelsize=MIN_FONT_SIZE, length=0, top=False, labeltop=True,
                           bottom=False, labelbottom=False)
            for side in ax.spines.values():
                side.set_visible(False)
            ax.set_title(title, fontsize=MIN_FONT_SIZE + 1)
        letter_panels(axes.flat)
        handles = [mpl.patches.Patch(color=colour, label=verdict) for verdict, colour in zip(VERDICTS, VERDICT_COLOURS)]
        fig.legend(handles=handles, loc="outside lower center", ncols=len(VERDICTS), frameon=False,
                   title="verdict of each thesis claim (docs/lunar-thesis-checklist.md) from the runs of E1-E3")
    return figure_paths(path)
