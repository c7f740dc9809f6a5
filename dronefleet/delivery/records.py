"""A delivery run's tables (docs/delivery-model.md section 10) and its metrics (section 11), written and
read back through the shared :mod:`dronefleet.records`.

Schemas (times in seconds from the start of the run, SoC in percent, null = did not happen
by the horizon):

``orders``: order_id int32, arrival_s, arrival_week int16 (1 = first week), distance_m, mass_kg,
attempts int16, winners list<int16> (UAVs of its attempts in order), delivered_s, delivery_time_s.
(An order reserved but not yet flown at the horizon has no attempt: the UAV waits for it; the
summary's reservations_won counts it.)

``attempts``: attempt_id int32, uav int16, order_id int32, takeoff_s, takeoff_soc,
outcome string (in_flight | delivered | aborted | lost: the UAV did not come back),
parcel_delivered bool, turn_s (delivery or abort instant), return_s (landing or loss instant),
return_soc, allocated_s (auction won), reserved bool (won by a reservation bid),
wait_s (takeoff_s - allocated_s), forecast_wait_s (the reservation bid; null if not reserved),
forecast_met bool (reserved attempts whose parcel has turned: whether the forecast that the
UAV can deliver once charged held, i.e. it delivered; null otherwise).

``fleet``: one row per UAV at the end of every week (and at the horizon): week int16, t_s,
uav int16, soh, w_distance, w_mass, w_soc, intercept (policy on standardised features),
steps (learner step counter t_), soc (null once lost), lost bool, decision_accuracy
(:func:`dronefleet.delivery.metrics.decision_accuracy` of the policy then, on the run's test points),
period int16 (operating period: 1, or the saved fleet's plus one for a warm start).

``timeseries``: t_s, delivered, unallocated, in_flight, aborted_attempts, idle, lost, reserved
(int64 counts at that instant, after every event at it).

``summary``: one row: seed, rule, tau_minutes, n_uavs, horizon_weeks, period, then the metrics of
:func:`dronefleet.delivery.metrics.run_metrics`.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pyarrow as pa

from ..contract import Column
from ..records import arrow_array, arrow_table, write_tables
from ..records import read_config as read_file_config
from .config import SECONDS_PER_WEEK, Config, config_from_dict
from .engine import IN_FLIGHT, OUTCOME_DELIVERED, OUTCOME_NAMES

if TYPE_CHECKING:
    from .result import RunResult

TABLES = ("orders", "attempts", "fleet", "timeseries", "summary")


def _schema(**columns: pa.DataType) -> pa.Schema:
    return pa.schema(list(columns.items()))


_f64, _i16, _i32, _i64 = pa.float64(), pa.int16(), pa.int32(), pa.int64()
#: Every table's columns and types, as :func:`tables` writes them (the module doc says what
#: they mean): a sweep checks each file it reads back against them.
SCHEMAS = {
    "orders": _schema(order_id=_i32, arrival_s=_f64, arrival_week=_i16, distance_m=_f64, mass_kg=_f64,
                      attempts=_i16, winners=pa.list_(_i16), delivered_s=_f64, delivery_time_s=_f64),
    "attempts": _schema(attempt_id=_i32, uav=_i16, order_id=_i32, takeoff_s=_f64, takeoff_soc=_f64,
                        outcome=pa.string(), parcel_delivered=pa.bool_(), turn_s=_f64, return_s=_f64,
                        return_soc=_f64, allocated_s=_f64, reserved=pa.bool_(), wait_s=_f64,
                        forecast_wait_s=_f64, forecast_met=pa.bool_()),
    "fleet": _schema(week=_i16, t_s=_f64, uav=_i16, soh=_f64, w_distance=_f64, w_mass=_f64, w_soc=_f64,
                     intercept=_f64, steps=_f64, soc=_f64, lost=pa.bool_(), decision_accuracy=_f64, period=_i16),
    "timeseries": _schema(t_s=_f64, delivered=_i64, unallocated=_i64, in_flight=_i64, aborted_attempts=_i64,
                          idle=_i64, lost=_i64, reserved=_i64),
    "summary": _schema(seed=_i64, rule=pa.string(), tau_minutes=_f64, n_uavs=_i64, horizon_weeks=_f64,
                       period=_i64, orders_arrived=_i64, delivered=_i64, median_delivery_time_s=_f64,
                       attempts=_i64, aborted_attempts=_i64, aborted_pct=_f64, pending=_i64, backlog_age_s=_f64,
                       lost_uavs=_i64, auctions=_i64, decision_accuracy=_f64, reservations_won=_i64,
                       median_reservation_wait_s=_f64, forecast_met_pct=_f64),
}

_AT_T = "by the horizon"
#: What every column of :data:`SCHEMAS` holds, with its unit (the documentation site's table pages).
COLUMNS = {
    "orders": {
        "order_id": Column("index", "the order, numbered from 0 in order of arrival"),
        "arrival_s": Column("s", "when the order arrived, from the start of the run"),
        "arrival_week": Column("week", "the week it arrived in, 1 for the first"),
        "distance_m": Column("m", "distance from the depot to the customer"),
        "mass_kg": Column("kg", "mass of the parcel"),
        "attempts": Column("count", "delivery attempts flown for it (takeoffs)"),
        "winners": Column("index", "the UAVs that flew its attempts, in order"),
        "delivered_s": Column("s", f"when its parcel reached the customer; null if not {_AT_T}"),
        "delivery_time_s": Column("s", f"delivered_s - arrival_s; null if not delivered {_AT_T}"),
    },
    "attempts": {
        "attempt_id": Column("index", "the attempt, numbered from 0 in order of takeoff"),
        "uav": Column("index", "the UAV that flew it"),
        "order_id": Column("index", "the order it carried"),
        "takeoff_s": Column("s", "takeoff instant"),
        "takeoff_soc": Column("%", "the UAV's state of charge at takeoff"),
        "outcome": Column("", "delivered, aborted (the parcel turned back), lost (the UAV did not come back) "
                              "or in_flight (still flying at the horizon)"),
        "parcel_delivered": Column("", "whether the parcel reached the customer"),
        "turn_s": Column("s", f"the instant of delivery or abort; null if neither happened {_AT_T}"),
        "return_s": Column("s", f"the instant of landing or loss; null if neither happened {_AT_T}"),
        "return_soc": Column("%", "state of charge at landing; null if it did not land"),
        "allocated_s": Column("s", "when the UAV won the order's auction"),
        "reserved": Column("", "whether it was won by a reservation bid (takeoff once charged)"),
        "wait_s": Column("s", "takeoff_s - allocated_s: time from winning to takeoff"),
        "forecast_wait_s": Column("s", "the wait the reservation bid forecast; null if not reserved"),
        "forecast_met": Column("", "for a reserved attempt whose parcel has turned: whether it was delivered, as "
                                   "forecast; null otherwise"),
    },
    "fleet": {
        "week": Column("week", "the week that ended (the last row of a run: the horizon)"),
        "t_s": Column("s", "the instant of the record"),
        "uav": Column("index", "the UAV"),
        "soh": Column("1", "its battery's state of health, the share of the nominal capacity it has "
                           "(0.5..1 by default; unknown to the UAV)"),
        "w_distance": Column("1", "its policy's weight on the standardised distance"),
        "w_mass": Column("1", "its policy's weight on the standardised mass"),
        "w_soc": Column("1", "its policy's weight on the standardised state of charge"),
        "intercept": Column("1", "its policy's intercept (it bids where the weighted sum is >= 0)"),
        "steps": Column("count", "learning steps its learner has taken"),
        "soc": Column("%", "its state of charge; null once lost"),
        "lost": Column("", "whether it was lost on a flight"),
        "decision_accuracy": Column("1", "share of the run's 1000 test points where the policy bids exactly when "
                                         "the UAV could fly the order (0..1)"),
        "period": Column("count", "operating period: 1, or the saved fleet's plus one for a warm start"),
    },
    "timeseries": {
        "t_s": Column("s", "the instant (every record_interval_s), after every event at it"),
        "delivered": Column("count", "parcels delivered so far"),
        "unallocated": Column("count", "orders waiting for a winner"),
        "in_flight": Column("count", "UAVs flying"),
        "aborted_attempts": Column("count", "attempts aborted so far"),
        "idle": Column("count", "UAVs on the ground, free to bid"),
        "lost": Column("count", "UAVs lost so far"),
        "reserved": Column("count", "UAVs charging for a reserved takeoff"),
    },
    "summary": {
        "seed": Column("", "the run's seed"),
        "rule": Column("", "the winner rule of the auctions"),
        "tau_minutes": Column("min", "mean time between two orders"),
        "n_uavs": Column("count", "UAVs in the fleet"),
        "horizon_weeks": Column("week", "length of the run"),
        "period": Column("count", "operating period: 1, or the saved fleet's plus one for a warm start"),
        "orders_arrived": Column("count", "orders that arrived"),
        "delivered": Column("count", f"parcels delivered {_AT_T}"),
        "median_delivery_time_s": Column("s", "median over the delivered orders of arrival to delivery; NaN if none"),
        "attempts": Column("count", "delivery attempts (takeoffs)"),
        "aborted_attempts": Column("count", "attempts whose parcel turned back"),
        "aborted_pct": Column("%", "aborted attempts as a percentage of all attempts"),
        "pending": Column("count", f"orders not delivered {_AT_T}"),
        "backlog_age_s": Column("s", "summed age of the pending orders at the horizon"),
        "lost_uavs": Column("count", "UAVs lost"),
        "auctions": Column("count", "auctions held"),
        "decision_accuracy": Column("1", "mean decision accuracy of the fleet's final policies (0..1)"),
        "reservations_won": Column("count", "orders won by a reservation bid"),
        "median_reservation_wait_s": Column("s", "median wait from winning a reservation to takeoff; NaN if none"),
        "forecast_met_pct": Column("%", "reserved attempts delivered, of those whose parcel has turned; NaN if none"),
    },
}


def _nullable(values):
    return arrow_array(values, null=np.isnan(values))


def orders_table(result: RunResult) -> pa.Table:
    o, a = result.orders, result.attempts
    n = o["arrival_s"].shape[0]
    by_order = np.argsort(a["order"], kind="stable")
    offsets = np.concatenate(([0], np.cumsum(np.bincount(a["order"], minlength=n)))).astype(np.int32)
    winners = pa.ListArray.from_arrays(arrow_array(offsets), arrow_array(a["uav"][by_order].astype(np.int16)))
    return arrow_table({
        "order_id": np.arange(n, dtype=np.int32),
        "arrival_s": o["arrival_s"],
        "arrival_week": (o["arrival_s"] // SECONDS_PER_WEEK).astype(np.int16) + np.int16(1),
        "distance_m": o["distance_m"],
        "mass_kg": o["mass_kg"],
        "attempts": o["attempts"].astype(np.int16),
        "winners": winners,
        "delivered_s": _nullable(o["delivered_s"]),
        "delivery_time_s": _nullable(o["delivered_s"] - o["arrival_s"]),
    })


def attempts_table(result: RunResult) -> pa.Table:
    a = result.attempts
    n = a["uav"].shape[0]
    outcome = np.where(a["lost"], "lost", np.array(OUTCOME_NAMES)[a["outcome"]])
    reserved = ~np.isnan(a["forecast_wait_s"])
    turned = a["outcome"] != IN_FLIGHT
    return arrow_table({
        "attempt_id": np.arange(n, dtype=np.int32),
        "uav": a["uav"].astype(np.int16),
        "order_id": a["order"].astype(np.int32),
        "takeoff_s": a["takeoff_s"],
        "takeoff_soc": a["takeoff_soc"],
        "outcome": outcome,
        "parcel_delivered": a["outcome"] == OUTCOME_DELIVERED,
        "turn_s": _nullable(a["turn_s"]),
        "return_s": _nullable(a["return_s"]),
        "return_soc": _nullable(a["return_soc"]),
        "allocated_s": a["allocated_s"],
        "reserved": reserved,
        "wait_s": a["takeoff_s"] - a["allocated_s"],
        "forecast_wait_s": _nullable(a["forecast_wait_s"]),
        "forecast_met": arrow_array(a["outcome"] == OUTCOME_DELIVERED, null=~(reserved & turned)),
    })


def fleet_table(result: RunResult) -> pa.Table:
    from .metrics import accuracy_points, decision_accuracy

    columns = {name: [] for name in ("week", "t_s", "uav", "soh", "w_distance", "w_mass", "w_soc",
                                     "intercept", "steps", "soc", "lost", "decision_accuracy")}
    points = accuracy_points(result.config)
    for snap in result.snapshots:
        s = snap["soh"].shape[0]
        columns["week"].append(np.full(s, np.ceil(snap["t_s"] / SECONDS_PER_WEEK), np.int16))
        columns["t_s"].append(np.full(s, snap["t_s"]))
        columns["uav"].append(np.arange(s, dtype=np.int16))
        for name in ("soh", "intercept", "steps", "soc", "lost"):
            columns[name].append(snap[name])
        for j, name in enumerate(("w_distance", "w_mass", "w_soc")):
            columns[name].append(snap["coef"][:, j])
        columns["decision_accuracy"].append(
            decision_accuracy(snap["coef"], snap["intercept"], snap["soh"], result.config, points))
    table = {name: np.concatenate(parts) for name, parts in columns.items()}
    table["soc"] = _nullable(table["soc"])  # a lost UAV has none
    table["period"] = np.full(table["uav"].shape[0], result.period, np.int16)
    return arrow_table(table)


def timeseries_table(result: RunResult) -> pa.Table:
    s = result.series
    return arrow_table({
        "t_s": s["t_s"], "delivered": s["delivered"], "unallocated": s["unallocated"],
        "in_flight": s["in_flight"], "aborted_attempts": s["aborted"], "idle": s["idle"], "lost": s["lost"],
        "reserved": s["reserved"],
    })


def summary_table(result: RunResult) -> pa.Table:
    from .metrics import run_metrics

    c = result.config
    row = dict(seed=c.seed, rule=c.rule, tau_minutes=c.tau_minutes, n_uavs=c.n_uavs,
               horizon_weeks=c.horizon_weeks, period=result.period, **run_metrics(result))
    return arrow_table({key: [value] for key, value in row.items()})


def tables(result: RunResult) -> dict[str, pa.Table]:
    """All tables of a run, by name (see the module doc for their schemas)."""
    return {"orders": orders_table(result), "attempts": attempts_table(result), "fleet": fleet_table(result),
            "timeseries": timeseries_table(result), "summary": summary_table(result)}


def write_run(result: RunResult, out_dir: str | os.PathLike, overwrite: bool = False) -> dict[str, Path]:
    """Write every table of the delivery run ``result``: :func:`dronefleet.records.write_tables` of :func:`tables`."""
    return write_tables(tables(result), out_dir, result.config, overwrite)


def read_config(path: str | os.PathLike) -> Config:
    """The config embedded in a delivery parquet file; a plugin rule it names is kept as a name,
    never imported (files are data). DataError naming the file if it holds no valid config."""
    return read_file_config(path, lambda document: config_from_dict(document, trusted=False))
