"""What the replay page (:mod:`dronefleet.replay`) shows of a delivery run, from its tables alone.

Every attempt is one flight out along a straight line from the fulfilment centre and back
along it, at the cruise speed: out from ``takeoff_s`` to ``turn_s`` (the delivery or the
abort), back until ``return_s`` (the landing, or the loss of the UAV on the way). The model
knows an order's distance, not its direction, so the page spreads the orders around the
centre by the golden angle of their id: the same picture for the same run, nothing more
(the direction is for the eye only). SoC is interpolated linearly between the takeoff and
landing values, and on the ground between a landing and the next takeoff (charging).
"""

import math
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa

from ..config import ConfigError
from ..datafiles import ColumnType, checked_column, parquet_rows, read_parquet
from .config import SECONDS_PER_WEEK, Config, describe

__all__ = ["replay_data", "check_replayable", "GOLDEN_ANGLE", "MAX_FLIGHTS", "MAX_ORDERS", "MAX_SAMPLES"]

#: Bearing step between consecutive order ids [rad]: successive orders never line up.
GOLDEN_ANGLE = math.pi * (3.0 - math.sqrt(5.0))
OUTCOMES = ("delivered", "aborted", "lost", "in_flight")
#: At most this many attempts in a page (~90 bytes each: a page of ~90 MB, built in a few GB
#: of memory); the paper's 8-week run has ~6,000, the largest run allowed ~10^7.
MAX_FLIGHTS = 1_000_000
#: At most this many orders and time-series samples are read for a page (``--replay`` refuses
#: runs expecting more than MAX_FLIGHTS orders): a tampered table is refused before it is read.
MAX_ORDERS = 2 * MAX_FLIGHTS
MAX_SAMPLES = 10_000_001  # RUN_LIMITS["samples"] + 1


def _rounded(values, decimals):
    """A float column as a JSON-ready list, to ``decimals`` places (the page draws pixels)."""
    return np.round(np.asarray(values, dtype=np.float64), decimals).tolist()


def check_replayable(config: Config) -> None:
    """Refuse (ConfigError, one line) before ``dronefleet run --replay`` simulates a run whose
    expected orders alone exceed :data:`MAX_FLIGHTS`: its page would be refused after the run."""
    from .config import run_size

    orders = run_size(config)["orders"]
    if orders > MAX_FLIGHTS:
        raise ConfigError(f"--replay: the run would hold ~{orders:.2g} orders and a replay page draws at most "
                          f"{MAX_FLIGHTS:,} attempts: run it without --replay, or a shorter run (horizon_weeks)")


def _checked_tables(run_dir: Path, config: Config):
    """The orders, attempts and time series of the run in ``run_dir`` as pandas frames, every
    column the page uses checked value by value first (the page indexes orders by id, UAVs by
    number and outcomes by name): DataError naming the file and column otherwise."""
    import pandas as pd

    horizon, n_uavs = config.horizon_s, config.n_uavs
    integer, floating = ColumnType("an integer", pa.types.is_integer), ColumnType("a float", pa.types.is_floating)
    text = ColumnType("text", pa.types.is_string)
    in_run = f"finite, in [0, {horizon:g}] s"
    soc = "finite, in [0, 100] %"
    farthest = config.distance_max_m * (1 + 1e-9)

    def read(name, columns):
        """``{column: (type predicate, ok, allowed, nullable)}`` of table ``name``, checked."""
        path = run_dir / f"{name}.parquet"
        table = read_parquet(path, {column: spec[0] for column, spec in columns.items()})
        return pd.DataFrame({column: checked_column(table, column, path, ok, allowed, nullable=nullable)
                             for column, (_, ok, allowed, nullable) in columns.items()})

    def times(x):
        return np.isfinite(x) & (x >= 0) & (x <= horizon)

    def percent(x):
        return np.isfinite(x) & (x >= 0) & (x <= 100)

    orders = read("orders", {
        "order_id": (integer, lambda x: x == np.arange(len(x)), "the row number (orders 0, 1, 2, ... in order)", False),
        "arrival_s": (floating, times, in_run, False),
        # at most the run's farthest order (with a margin for the rounding of the annulus's square root)
        "distance_m": (floating, lambda x: np.isfinite(x) & (x >= 0) & (x <= farthest),
                       f"finite, in [0, {config.distance_max_m:g}] m", False)})
    attempts = read("attempts", {
        "uav": (integer, lambda x: (x >= 0) & (x < n_uavs), f"a UAV of the run, 0 to {n_uavs - 1}", False),
        "order_id": (integer, lambda x: (x >= 0) & (x < len(orders)),
                     f"an order of orders.parquet, 0 to {len(orders) - 1}", False),
        "takeoff_s": (floating, times, in_run, False),
        "takeoff_soc": (floating, percent, soc, False),
        "outcome": (text, lambda x: np.isin(x, OUTCOMES), ", ".join(OUTCOMES), False),
        # null: the flight had not turned, or landed, by the horizon
        "turn_s": (floating, times, f"{in_run}, or null", True),
        "return_s": (floating, times, f"{in_run}, or null", True),
        "return_soc": (floating, percent, f"{soc}, or null", True)})
    series = read("timeseries", {
        "t_s": (floating, times, in_run, False),
        "unallocated": (integer, lambda x: x >= 0, "a count >= 0", False)})
    return orders, attempts, series


def replay_data(run_dir: Path) -> dict[str, Any]:
    """The page's data of the delivery run in ``run_dir`` (a folder ``dronefleet run`` wrote).

    Returns a JSON-ready dict: ``title``, ``duration_s`` (the horizon [s]), ``week_s``,
    ``n_uavs``, ``radius_m`` (the farthest order [m]); ``flights``, columns of one row per
    attempt sorted by UAV then takeoff, with ``uav_start`` (n_uavs + 1 offsets: UAV u's
    flights are rows ``uav_start[u]`` to ``uav_start[u + 1] - 1``): ``takeoff_s``,
    ``turn_s``, ``return_s`` [s] (a flight still out at the horizon: when it would turn and
    land), ``turn_m`` (distance from the centre at the turn [m]), ``end_m`` (at
    ``return_s``: 0 unless lost [m]), ``bearing`` [rad], ``soc0``, ``soc1`` (at takeoff
    and at ``return_s`` [%]), ``outcome`` (index into ``outcomes``); ``arrival_s`` (every
    order's arrival, ascending [s]); ``queue``: the unallocated orders of the time series
    (``t_s``, ``orders``).
    """
    from .records import read_config

    config = read_config(run_dir / "summary.parquet")
    flights = parquet_rows(run_dir / "attempts.parquet")
    if flights > MAX_FLIGHTS:  # before the tables are read: the page would not fit in memory, nor play
        raise ConfigError(f"RUN_DIR {str(run_dir)!r} has {flights:,} attempts; a replay page draws at most "
                          f"{MAX_FLIGHTS:,}: replay a shorter run (horizon_weeks) or one of fewer orders")
    for table, limit, what in (("orders", MAX_ORDERS, "orders"), ("timeseries", MAX_SAMPLES, "time-series samples")):
        rows = parquet_rows(run_dir / f"{table}.parquet")
        if rows > limit:
            raise ConfigError(f"RUN_DIR {str(run_dir)!r} has {rows:,} {what} in {table}.parquet; a replay page "
                              f"reads at most {limit:,}: replay a shorter run (horizon_weeks)")
    orders, attempts, series = _checked_tables(run_dir, config)
    horizon, speed = config.horizon_s, config.speed_m_s

    a = attempts.sort_values(["uav", "takeoff_s"], kind="stable").reset_index(drop=True)
    distance = orders["distance_m"].to_numpy()[a["order_id"].to_numpy()]
    takeoff = a["takeoff_s"].to_numpy()
    # a flight still out at the horizon: when it would turn and land, had the run gone on
    turn = a["turn_s"].to_numpy()
    turn = np.where(np.isnan(turn), takeoff + distance / speed, turn)
    back = a["return_s"].to_numpy()
    back = np.where(np.isnan(back), 2.0 * turn - takeoff, back)
    turn_m = np.minimum(distance, speed * (turn - takeoff))
    lost = a["outcome"].to_numpy() == "lost"
    end_m = np.where(lost, np.maximum(turn_m - speed * (back - turn), 0.0), 0.0)
    soc1 = a["return_soc"].fillna(a["takeoff_soc"]).to_numpy()  # still out: no landing SoC yet
    starts = np.searchsorted(a["uav"].to_numpy(), np.arange(config.n_uavs + 1))
    return {
        "scenario": "delivery",
        "title": f"delivery run: {describe(config)}",
        "duration_s": horizon,
        "week_s": SECONDS_PER_WEEK,
        "n_uavs": config.n_uavs,
        "radius_m": float(orders["distance_m"].max()) if len(orders) else 1000.0,
        "outcomes": list(OUTCOMES),
        "uav_start": starts.tolist(),
        "flights": {
            "takeoff_s": _rounded(takeoff, 1),
            "turn_s": _rounded(turn, 1),
            "return_s": _rounded(back, 1),
            "turn_m": _rounded(turn_m, 0),
            "end_m": _rounded(end_m, 0),
            "bearing": _rounded(a["order_id"].to_numpy() * GOLDEN_ANGLE % (2.0 * math.pi), 3),
            "soc0": _rounded(a["takeoff_soc"], 1),
            "soc1": _rounded(soc1, 1),
            "outcome": [OUTCOMES.index(o) for o in a["outcome"]],
        },
        "arrival_s": _rounded(np.sort(orders["arrival_s"].to_numpy()), 1),
        "queue": {"t_s": _rounded(series["t_s"], 1), "orders": series["unallocated"].tolist()},
    }
