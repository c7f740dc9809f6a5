"""The study's metrics (docs/delivery-model.md section 11), vectorised over a run's arrays."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from .config import SECONDS_PER_WEEK, Config
from .energy import capable, config_power, drain_per_watt
from .engine import IN_FLIGHT, OUTCOME_ABORTED, OUTCOME_DELIVERED
from .policy import standardise

if TYPE_CHECKING:
    import pandas

    from .result import RunResult

#: Child of the run's SeedSequence that draws the accuracy test points. The simulation
#: uses children 0-3, so evaluating a policy never changes a run.
EVALUATION_STREAM = 4


def run_metrics(result: RunResult) -> dict[str, int | float]:
    """The metrics of one run, as a dict of Python scalars.

    orders_arrived; delivered; median_delivery_time_s (arrival to delivery, nan if none);
    attempts; aborted_attempts (attempts whose parcel turned back, whether or not the UAV
    came home); aborted_pct (of all attempts, nan if none); pending (orders not delivered by
    the horizon); backlog_age_s (sum of horizon - arrival over them); lost_uavs; auctions;
    decision_accuracy (fleet mean at the horizon, see :func:`decision_accuracy`);
    reservations_won (auctions won by a reservation bid, flown or not); median_reservation_wait_s
    (allocation to takeoff over reserved attempts, nan if none); forecast_met_pct (of the
    reserved attempts whose parcel turned, the share that delivered; nan if none).
    """
    o, a, config = result.orders, result.attempts, result.config
    delivered = ~np.isnan(o["delivered_s"])
    times = o["delivered_s"][delivered] - o["arrival_s"][delivered]
    attempts = a["uav"].shape[0]
    aborted = int(np.count_nonzero(a["outcome"] == OUTCOME_ABORTED))
    final = result.snapshots[-1]
    reserved = ~np.isnan(a["forecast_wait_s"])
    turned = reserved & (a["outcome"] != IN_FLIGHT)
    return {
        "orders_arrived": int(o["arrival_s"].shape[0]),
        "delivered": int(delivered.sum()),
        "median_delivery_time_s": float(np.median(times)) if times.size else float("nan"),
        "attempts": int(attempts),
        "aborted_attempts": aborted,
        "aborted_pct": 100.0 * aborted / attempts if attempts else float("nan"),
        "pending": int((~delivered).sum()),
        # math.fsum: correctly rounded, so no summation order (numpy's is SIMD-dependent) matters.
        "backlog_age_s": math.fsum(config.horizon_s - o["arrival_s"][~delivered]),
        "lost_uavs": int(final["lost"].sum()),
        "auctions": int(result.auctions),
        "decision_accuracy": _mean(decision_accuracy(final["coef"], final["intercept"], final["soh"], config)),
        "reservations_won": int(result.reservations),
        "median_reservation_wait_s": (float(np.median(a["takeoff_s"][reserved] - a["allocated_s"][reserved]))
                                      if reserved.any() else float("nan")),
        "forecast_met_pct": (100.0 * float(np.mean(a["outcome"][turned] == OUTCOME_DELIVERED))
                             if turned.any() else float("nan")),
    }


def _mean(values):
    """Mean of a float array, correctly rounded sum (independent of summation order); nan if empty."""
    return math.fsum(values) / values.shape[0] if values.shape[0] else float("nan")


def by_arrival_week(arrival_s: ArrayLike, delivered_s: ArrayLike, horizon_s: float,
                    run: ArrayLike | None = None) -> pandas.DataFrame:
    """Pending orders and backlog age at the horizon, by the week the orders arrived in.

    Parameters
    ----------
    arrival_s, delivered_s : array_like, shape (n_orders,)
        Arrival and delivery instants (nan or None: not delivered by the horizon), s.
        Arrivals must lie in [0, horizon_s).
    horizon_s : float
        End of the run(s), s.
    run : array_like of int, shape (n_orders,), optional
        Run index 0..n_runs-1 of each order, to tabulate many runs of the same horizon at
        once (``dronefleet.delivery.analysis.backlog_by_arrival_week`` does); default one run.

    Returns
    -------
    pandas.DataFrame
        One row per arrival week 1..ceil(horizon / week) (per run, preceded by a ``run``
        column, if ``run`` is given): arrived, pending (orders not delivered by the
        horizon), backlog_age_s (sum of horizon - arrival over them, s).
    """
    import pandas as pd  # here, not at the top: a run's start-up never needs it

    arrival = np.asarray(arrival_s, dtype=np.float64)
    pending = np.isnan(np.asarray(delivered_s, dtype=np.float64))
    n_weeks = int(np.ceil(horizon_s / SECONDS_PER_WEEK))
    if arrival.size and not (arrival.min() >= 0.0 and arrival.max() < horizon_s):
        raise ValueError(f"arrivals must lie in [0, horizon_s = {horizon_s:g}) s; is horizon_s the runs' horizon?")
    codes = np.zeros(arrival.shape[0], dtype=np.int64) if run is None else np.asarray(run, dtype=np.int64)
    n_runs = int(codes.max()) + 1 if codes.size else 1
    # One flat bin per (run, week), so every run is counted by the same three bincounts.
    cell = codes * n_weeks + (arrival // SECONDS_PER_WEEK).astype(np.int64)
    size = n_runs * n_weeks
    table = pd.DataFrame({
        "run": np.repeat(np.arange(n_runs), n_weeks),
        "arrival_week": np.tile(np.arange(1, n_weeks + 1), n_runs),
        "arrived": np.bincount(cell, minlength=size),
        "pending": np.bincount(cell[pending], minlength=size),
        # float64 even with nothing pending (bincount of no values returns int64 zeros).
        "backlog_age_s": np.bincount(cell[pending], weights=horizon_s - arrival[pending],
                                     minlength=size).astype(np.float64),
    })
    return table if run is not None else table.drop(columns="run")


def accuracy_points(config: Config, n_points: int = 1000) -> np.ndarray:
    """The test points of :func:`decision_accuracy`: (n_points, 3) raw [distance_m, mass_kg, soc].

    d ~ U(distance range), m ~ U(mass range), SoC ~ U(0, 100), from the run's evaluation stream.
    """
    rng = np.random.default_rng(np.random.SeedSequence(config.seed).spawn(EVALUATION_STREAM + 1)[-1])
    return np.column_stack([rng.uniform(config.distance_min_m, config.distance_max_m, n_points),
                            rng.uniform(config.mass_min_kg, config.mass_max_kg, n_points),
                            rng.uniform(0.0, 100.0, n_points)])


def decision_accuracy(coef: ArrayLike, intercept: ArrayLike, soh: ArrayLike, config: Config,
                      points: ArrayLike | None = None) -> np.ndarray:
    """Share of test points where each policy's "bid" (f >= 0) equals ground-truth "capable".

    Parameters
    ----------
    coef : array_like, shape (n_uavs, 3)
        Policy weights on standardised [distance, mass, SoC].
    intercept, soh : array_like, shape (n_uavs,)
    config : Config
        Physics, scaling and (for the default points) seed.
    points : array_like, shape (n_points, 3), optional
        Raw [distance_m, mass_kg, soc] test points; default :func:`accuracy_points`.

    Returns
    -------
    numpy.ndarray, shape (n_uavs,)
    """
    points = accuracy_points(config) if points is None else np.asarray(points, dtype=np.float64)
    x = standardise(points, np.array(config.scaler_mean), np.array(config.scaler_std))
    coef, intercept = np.asarray(coef, dtype=np.float64), np.asarray(intercept, dtype=np.float64)
    # policy.decision's operations in its order, elementwise over (points, UAVs): no BLAS, whose
    # kernels (and so last bits) depend on the CPU.
    f = 0.0 + x[:, :1] * coef[:, 0]
    f += x[:, 1:2] * coef[:, 1]
    f += x[:, 2:] * coef[:, 2]
    bids = f + intercept >= 0.0
    truth = capable(points[:, :1], points[:, 1:2], points[:, 2:], drain_per_watt(config.capacity_wh, soh),
                    config_power(config, points[:, 1:2]), config_power(config, 0.0), config.speed_m_s, config.xi)
    return (bids == truth).mean(axis=0)

