"""Why a closely followed guidance field may not lead robots to the regions (docs/lunar-readings.md).

Functions over the lunar scenario's tables (``snapshots`` with ``frames = true``, ``timeseries``,
``summary``; columns as :func:`dronefleet.lunar.simulate.table_schemas` gives them):

- :func:`stretches`: each mobile robot's net displacement over consecutive frames (a "stretch"),
  with what it was near at the stretch's end (a beacon's body, a wall, charging in R);
- :func:`stuck_shares`: the share of stretches under a displacement threshold, by cause;
- :func:`heading_cosines`: the cosine between a mobile robot's heading and its own guidance
  vector, computed from the beacons in range at that frame by the kernel's own
  :func:`~dronefleet.lunar.kernel.beacon_weight` and :func:`~dronefleet.lunar.kernel.guidance`,
  and the cosine between that vector and the way to its key's region;
- :func:`cosine_shares`: those cosines' distribution (mass near -1: sinks; no guidance);
- :func:`network_course` and :func:`criteria`: the three results a reading must give together
  (network timing C28-C30, survival C38, foraging C18 of docs/lunar-thesis-checklist.md).

Units: metres, seconds, radians; cosines are dimensionless in [-1, 1].
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from . import kernel as k

__all__ = ["stretches", "stuck_shares", "heading_cosines", "cosine_shares", "network_course", "criteria",
           "WEIGHT_FORMS"]

#: The ``weight_form`` option's values, as the kernel's W_* codes (A12).
WEIGHT_FORMS = {"exponent": k.W_EXPONENT, "bracket": k.W_BRACKET, "literal": k.W_LITERAL}
#: Roles as the snapshots name them; a mobile role's index is its guidance key (F_OUT -> T, F_IN -> N,
#: R -> R), the key's index that of its region in ``centres``.
_KEYS = {"F_OUT": k.F_OUT, "F_IN": k.F_IN, "R": k.R}
_REGIONS = ("T", "N", "R")


def _frames(snapshots: pd.DataFrame) -> pd.DataFrame:
    """The ``frame`` rows of ``snapshots``, sorted by run, time, robot."""
    frames = snapshots[snapshots["label"] == "frame"]
    return frames.sort_values(["run", "t", "robot"], kind="stable").reset_index(drop=True)


def stretches(snapshots: pd.DataFrame, field: tuple[float, float], r_body: float, ir_range: float) -> pd.DataFrame:
    """Each mobile robot's net displacement between two consecutive frames.

    Parameters
    ----------
    snapshots : DataFrame
        The snapshots table; only rows labelled ``frame`` are read.
    field : (w, h)
        The walled field [0, w] x [0, h] [m].
    r_body, ir_range : float
        Robot disc radius and IR reach beyond the body [m] (A28, A29): a robot is *near a beacon*
        when its centre lies within 2 r_body + ir_range of an alive beacon's centre (its rays can
        touch the beacon's body), *near a wall* when within r_body + ir_range of the field's edge.

    Returns
    -------
    DataFrame
        One row per stretch of a robot alive and in a mobile role (F_OUT, F_IN, R) at both frames:
        ``run``, ``robot``, ``t0``, ``t1`` [s], ``displacement_m`` [m], and, at the end frame,
        ``near_beacon``, ``near_wall`` and ``charging`` (bool; charging: mode ``charging`` at
        either frame, a robot parked in R by design).
    """
    frames = _frames(snapshots)
    near = np.zeros(len(frames), dtype=bool)
    beacon_reach2 = (2.0 * r_body + ir_range) ** 2
    for _, rows in frames.groupby(["run", "t"], sort=False):
        alive = (rows["status"] == "alive").to_numpy()
        beacon = alive & (rows["role"] == "B").to_numpy()
        if not beacon.any():
            continue
        x, y = rows["x"].to_numpy(), rows["y"].to_numpy()
        d2 = (x[:, None] - x[None, beacon]) ** 2 + (y[:, None] - y[None, beacon]) ** 2
        own = rows["robot"].to_numpy()[:, None] == rows["robot"].to_numpy()[None, beacon]
        near[rows.index] = ((d2 < beacon_reach2) & ~own).any(axis=1)
    frames = frames.assign(near_beacon=near,
                           mobile=(frames["status"] == "alive") & (frames["role"] != "B"))
    frames = frames.sort_values(["run", "robot", "t"], kind="stable").reset_index(drop=True)
    nxt = frames.groupby(["run", "robot"], sort=False).shift(-1)
    both = frames["mobile"] & nxt["mobile"].fillna(False).astype(bool)
    end = nxt[both]
    start = frames[both]
    reach = r_body + ir_range
    ex, ey = end["x"].to_numpy(), end["y"].to_numpy()
    wall = (ex < reach) | (ey < reach) | (ex > field[0] - reach) | (ey > field[1] - reach)
    return pd.DataFrame({
        "run": start["run"].to_numpy(), "robot": start["robot"].to_numpy(),
        "t0": start["t"].to_numpy(), "t1": end["t"].to_numpy(),
        "displacement_m": np.hypot(ex - start["x"].to_numpy(), ey - start["y"].to_numpy()),
        "near_beacon": end["near_beacon"].to_numpy(dtype=bool), "near_wall": wall,
        "charging": ((start["mode"] == "charging").to_numpy() | (end["mode"] == "charging").to_numpy())})


def stuck_shares(table: pd.DataFrame, threshold_m: float = 3.0) -> dict[str, float]:
    """Shares of the stretches of :func:`stretches` whose net displacement is under ``threshold_m``
    [m], of all stretches: ``stuck`` in total and split by cause, each stuck stretch counted once,
    in this order: ``stuck_charging`` (parked in R), ``stuck_beacon`` (near a beacon's body),
    ``stuck_wall`` (near a wall), ``stuck_free`` (none of these: turning about in the open).
    ``stretches`` is their count, ``median_m`` the median displacement [m] (NaN: no stretch)."""
    n = len(table)
    if n == 0:
        return {"stretches": 0, "median_m": math.nan, "stuck": math.nan, "stuck_charging": math.nan,
                "stuck_beacon": math.nan, "stuck_wall": math.nan, "stuck_free": math.nan}
    stuck = table["displacement_m"].to_numpy() < threshold_m
    charging = table["charging"].to_numpy()
    beacon = table["near_beacon"].to_numpy() & ~charging
    wall = table["near_wall"].to_numpy() & ~charging & ~beacon
    free = ~(charging | beacon | wall)
    return {"stretches": n, "median_m": float(np.median(table["displacement_m"])),
            "stuck": stuck.mean(), "stuck_charging": (stuck & charging).mean(),
            "stuck_beacon": (stuck & beacon).mean(), "stuck_wall": (stuck & wall).mean(),
            "stuck_free": (stuck & free).mean()}


def heading_cosines(snapshots: pd.DataFrame, centres: dict, comm_radius: float, rho_f: float, rho_c: float,
                    weight_form: str = "exponent") -> pd.DataFrame:
    """The cosine between each mobile robot's heading and its own guidance vector, per frame.

    The guidance vector is the one the kernel's heading decision computes (Eq 5-14): the weighted
    sum over the alive beacons within ``comm_radius`` [m] (strictly) of the robot, in robot-id
    order, of their vectors for the robot's key (its role), with the F_IN -> R fallback when that
    sum is zero. Only robots in mode ``normal`` are read (a backtracking robot uses the key of its
    last completed region, which the snapshots do not hold; the R -> F_IN fallback needs "R
    visited", also not held, so it is left out). ``rho_f``, ``rho_c``, ``weight_form``: the
    weight's exponents and form (A12). The weights use a beacon's stored S as the kernel does
    (an uninitialised S is 0 in the snapshot, which weighs the same as the kernel's "read as 0").

    Returns
    -------
    DataFrame
        ``run``, ``t`` [s], ``robot``, ``role``, ``in_range`` (beacons within range), ``cos``
        (heading . G / |G|; NaN where G = 0), ``cos_goal`` (G against the straight way from the
        robot to its key's region centre in ``centres`` {"T": (x, y), ...} [m]; NaN where G = 0).
    """
    form = WEIGHT_FORMS[weight_form]
    comm2 = comm_radius * comm_radius
    out = []
    for (run, t), rows in _frames(snapshots).groupby(["run", "t"], sort=False):
        n = int(rows["robot"].max()) + 1
        ids = rows["robot"].to_numpy()
        x = np.zeros(n)
        y = np.zeros(n)
        x[ids], y[ids] = rows["x"].to_numpy(), rows["y"].to_numpy()
        weight = np.zeros((n, 3))
        vx = np.zeros((n, 3))
        vy = np.zeros((n, 3))
        beacon_ids = np.sort(ids[((rows["status"] == "alive") & (rows["role"] == "B")).to_numpy()])
        by_id = rows.set_index("robot")
        for q, region in enumerate(_REGIONS):
            vx[ids, q] = rows[f"vx_{region}"].to_numpy()
            vy[ids, q] = rows[f"vy_{region}"].to_numpy()
        for b in beacon_ids:
            for q, region in enumerate(_REGIONS):
                weight[b, q] = k.beacon_weight(by_id.at[b, f"omega_{region}"], by_id.at[b, f"S_{region}"], True,
                                               rho_f, rho_c, form)
        movers = rows[(rows["status"] == "alive") & rows["role"].isin(list(_KEYS)) & (rows["mode"] == "normal")]
        for robot, role, heading in zip(movers["robot"], movers["role"], movers["heading"]):
            d2 = (x[beacon_ids] - x[robot]) ** 2 + (y[beacon_ids] - y[robot]) ** 2
            in_range = beacon_ids[d2 < comm2].astype(np.int64)
            key = _KEYS[role]
            gx, gy = k.guidance(in_range, len(in_range), weight, vx, vy, key)
            if gx == 0.0 and gy == 0.0 and key == k.F_IN:
                key = k.R
                gx, gy = k.guidance(in_range, len(in_range), weight, vx, vy, key)
            norm = math.hypot(gx, gy)
            cos = cos_goal = math.nan
            if norm > 0.0:
                cos = (gx * math.cos(heading) + gy * math.sin(heading)) / norm
                cx, cy = centres[_REGIONS[key]]
                way = math.hypot(cx - x[robot], cy - y[robot])
                if way > 0.0:
                    cos_goal = (gx * (cx - x[robot]) + gy * (cy - y[robot])) / (norm * way)
            out.append((run, t, robot, role, len(in_range), cos, cos_goal))
    return pd.DataFrame(out, columns=["run", "t", "robot", "role", "in_range", "cos", "cos_goal"])


def cosine_shares(table: pd.DataFrame, column: str = "cos") -> dict[str, float]:
    """The distribution of ``column`` of :func:`heading_cosines`, as shares of all its rows:
    ``no_beacon`` (no beacon in range), ``zero`` (beacons in range, G = 0), and of the rows with
    guidance ``below`` (cos < -0.5: heading against G, or G pointing away from the region),
    ``across`` (|cos| <= 0.5), ``along`` (cos > 0.5); ``mean`` over rows with guidance."""
    n = len(table)
    if n == 0:
        return {"rows": 0, "no_beacon": math.nan, "zero": math.nan, "below": math.nan, "across": math.nan,
                "along": math.nan, "mean": math.nan}
    c = table[column].to_numpy()
    guided = ~np.isnan(c)
    none = table["in_range"].to_numpy() == 0
    g = c[guided]
    return {"rows": n, "no_beacon": none.mean(), "zero": (~guided & ~none).mean(),
            "below": (g < -0.5).sum() / n, "across": (np.abs(g) <= 0.5).sum() / n, "along": (g > 0.5).sum() / n,
            "mean": float(g.mean()) if len(g) else math.nan}


def network_course(timeseries: pd.DataFrame) -> pd.DataFrame:
    """Per run, the course of the network (checklist C28-C30): ``t90`` [s] the first record at
    which the beacon count reaches 90 % of the run's peak, ``t_peak`` [s] the first record of the
    peak, ``peak``, ``final`` (beacons at the last record), ``decay`` = peak - final, and
    ``mobile_rise`` = mobile count at the last record minus its minimum once every robot has
    spawned (``n_unspawned`` = 0; the whole run if that never happens)."""
    rows = []
    for run, ts in timeseries.sort_values(["run", "t"], kind="stable").groupby("run", sort=True):
        beacons = ts["n_beacons"].to_numpy()
        t = ts["t"].to_numpy()
        peak = beacons.max()
        mobile = ts["n_mobile"].to_numpy()
        spawned = ts["n_unspawned"].to_numpy() == 0
        low = mobile[spawned].min() if spawned.any() else mobile.min()
        rows.append((run, t[np.argmax(beacons >= 0.9 * peak)], t[np.argmax(beacons)], peak, beacons[-1],
                     peak - beacons[-1], mobile[-1] - low))
    return pd.DataFrame(rows, columns=["run", "t90", "t_peak", "peak", "final", "decay", "mobile_rise"])


def _beyond_2se(values: np.ndarray) -> bool:
    """True when the mean of ``values`` is above 0 by more than twice its standard error."""
    if len(values) < 2:
        return bool(len(values) == 1 and values[0] > 0)
    return bool(values.mean() > 2.0 * values.std(ddof=1) / math.sqrt(len(values)))


def criteria(timeseries: pd.DataFrame, summary: pd.DataFrame, min_t90_s: float = 600.0,
             min_resources: float = 600.0) -> dict[str, float | bool]:
    """The three results a reading must give together, from one configuration's runs.

    - timing (C28-C30): median ``t90`` >= ``min_t90_s`` [s], the peak - final decay above 0 beyond
      twice its standard error, the mobile rise likewise (:func:`network_course`);
    - survival (C38): no robot reaches SOC 0 in any run (summary ``deaths`` + ``depletions`` = 0);
    - foraging (C18): mean ``resources`` per run above ``min_resources``.

    Returns the numbers (medians and means per run) and ``timing``, ``survival``, ``foraging``
    (bool) and ``all``."""
    course = network_course(timeseries)
    deaths = summary["deaths"].to_numpy()
    depletions = summary["depletions"].to_numpy()
    resources = summary["resources"].to_numpy()
    timing = bool(np.median(course["t90"]) >= min_t90_s and _beyond_2se(course["decay"].to_numpy())
                  and _beyond_2se(course["mobile_rise"].to_numpy()))
    survival = bool(deaths.sum() + depletions.sum() == 0)
    foraging = bool(resources.mean() > min_resources)
    return {"runs": len(summary), "t90_s": float(np.median(course["t90"])),
            "t_peak_s": float(np.median(course["t_peak"])), "peak": float(course["peak"].mean()),
            "decay": float(course["decay"].mean()), "mobile_rise": float(course["mobile_rise"].mean()),
            "deaths": float(deaths.mean()), "depletions": float(depletions.mean()),
            "resources": float(resources.mean()),
            "timing": timing, "survival": survival, "foraging": foraging, "all": timing and survival and foraging}
