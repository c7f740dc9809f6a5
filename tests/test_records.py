"""A run's tables, metrics and parquet files
(docs/delivery-model.md sections 10 and 11; delivery/records.py, records.py)."""

import json
import math

import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from conftest import ALWAYS, NEVER, WEEK, rate, run_state, scenario, scenario_config
from dronefleet.delivery.metrics import run_metrics
from dronefleet import records
from dronefleet.delivery import config as cfg
from dronefleet.delivery import simulation, records as delivery_records

SCHEMAS = {
    "orders": {"order_id": pa.int32(), "arrival_s": pa.float64(), "arrival_week": pa.int16(),
               "distance_m": pa.float64(), "mass_kg": pa.float64(), "attempts": pa.int16(),
               "winners": pa.list_(pa.int16()), "delivered_s": pa.float64(), "delivery_time_s": pa.float64()},
    "attempts": {"attempt_id": pa.int32(), "uav": pa.int16(), "order_id": pa.int32(), "takeoff_s": pa.float64(),
                 "takeoff_soc": pa.float64(), "outcome": pa.string(), "parcel_delivered": pa.bool_(),
                 "turn_s": pa.float64(), "return_s": pa.float64(), "return_soc": pa.float64(),
                 "allocated_s": pa.float64(), "reserved": pa.bool_(), "wait_s": pa.float64(),
                 "forecast_wait_s": pa.float64(), "forecast_met": pa.bool_()},
    "fleet": {"week": pa.int16(), "t_s": pa.float64(), "uav": pa.int16(), "soh": pa.float64(),
              "w_distance": pa.float64(), "w_mass": pa.float64(), "w_soc": pa.float64(),
              "intercept": pa.float64(), "steps": None, "soc": pa.float64(), "lost": pa.bool_(),
              "decision_accuracy": pa.float64(), "period": pa.int16()},
    "timeseries": {"t_s": pa.float64(), "delivered": pa.int64(), "unallocated": pa.int64(),
                   "in_flight": pa.int64(), "aborted_attempts": pa.int64(), "idle": pa.int64(),
                   "lost": pa.int64(), "reserved": pa.int64()},
}
SUMMARY_HEAD = ["seed", "rule", "tau_minutes", "n_uavs", "horizon_weeks", "period"]
METRICS = ["orders_arrived", "delivered", "median_delivery_time_s", "attempts", "aborted_attempts",
           "aborted_pct", "pending", "backlog_age_s", "lost_uavs", "auctions", "decision_accuracy",
           "reservations_won", "median_reservation_wait_s", "forecast_met_pct"]


@pytest.fixture(scope="module")
def small_run():
    c = cfg.replace(cfg.default_config(), horizon_weeks=1.5, n_uavs=8, seed=4)
    return simulation.simulate(c)


# ---------------------------------------------------------------------------- schemas and config


def test_table_schemas(small_run, tmp_path):
    paths = delivery_records.write_run(small_run, tmp_path)
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(f"{n}.parquet" for n in delivery_records.TABLES)
    for name, columns in SCHEMAS.items():
        schema = pq.read_schema(paths[name])
        assert schema.names == list(columns), name
        for col, typ in columns.items():
            if typ is None:
                assert pa.types.is_integer(schema.field(col).type) or pa.types.is_floating(schema.field(col).type)
            else:
                assert schema.field(col).type == typ, (name, col)
    summary = pq.read_table(paths["summary"])
    assert summary.num_rows == 1
    assert summary.schema.names[:6] == SUMMARY_HEAD
    assert set(METRICS) <= set(summary.schema.names)
    row = summary.to_pylist()[0]
    c = small_run.config
    assert (row["seed"], row["rule"], row["tau_minutes"], row["n_uavs"], row["horizon_weeks"], row["period"]) == (
        c.seed, c.rule, c.tau_minutes, c.n_uavs, c.horizon_weeks, 1)
    assert pa.types.is_string(summary.schema.field("rule").type)
    for key in ("orders_arrived", "delivered", "attempts", "aborted_attempts", "pending", "lost_uavs", "auctions"):
        assert pa.types.is_integer(summary.schema.field(key).type), key
    # Contents that follow from the schema's definitions.
    fleet = pq.read_table(paths["fleet"]).to_pydict()
    assert sorted(set(zip(fleet["week"], fleet["t_s"]))) == [(1, WEEK), (2, 1.5 * WEEK)]
    assert fleet["uav"] == list(range(8)) * 2
    assert all(float(s).is_integer() and s >= 15 for s in fleet["steps"])
    orders = pq.read_table(paths["orders"]).to_pydict()
    assert orders["order_id"] == list(range(len(orders["order_id"])))
    for arrival, week in zip(orders["arrival_s"], orders["arrival_week"]):
        assert week == math.floor(arrival / WEEK) + 1
    attempts = pq.read_table(paths["attempts"]).to_pydict()
    assert set(attempts["outcome"]) <= {"in_flight", "delivered", "aborted", "lost"}
    assert {"delivered", "aborted"} <= set(attempts["outcome"])
    for j, winners in enumerate(orders["winners"]):
        assert winners == [u for u, o in zip(attempts["uav"], attempts["order_id"]) if o == j]
        assert len(winners) == orders["attempts"][j]
        if orders["delivered_s"][j] is None:
            assert orders["delivery_time_s"][j] is None
        else:
            assert orders["delivery_time_s"][j] == pytest.approx(orders["delivered_s"][j] - orders["arrival_s"][j])
    for outcome, parcel in zip(attempts["outcome"], attempts["parcel_delivered"]):
        if outcome != "lost":  # a lost UAV may or may not have delivered its parcel
            assert parcel == (outcome == "delivered")


def test_config_is_embedded_in_every_file(small_run, tmp_path):
    paths = delivery_records.write_run(small_run, tmp_path)
    for name, path in paths.items():
        assert delivery_records.read_config(path) == small_run.config, name
        meta = pq.read_schema(path).metadata
        assert json.loads(meta[b"dronefleet.config"]) == small_run.config.to_dict()
    # Another config is read back as itself, not as the default.
    c = cfg.replace(cfg.default_config(), seed=99, rule="threshold", theta=70.0, tau_minutes=25.0,
                    scaler_mean=(1.0, 2.0, 3.0), horizon_weeks=0.05)
    result = simulation.simulate(c)
    path = records.write_table(delivery_records.tables(result)["timeseries"], tmp_path / "ts.parquet", c)
    assert delivery_records.read_config(path) == c
    assert delivery_records.read_config(path) != cfg.default_config()


# ---------------------------------------------------------------------------- metrics by hand


def test_metrics_on_a_tiny_scenario():
    # One UAV (SoH 1) that bids on everything; horizon 1900 s.
    c = scenario_config(horizon_s=1900.0)
    T = c.horizon_s
    arrivals = [0.0, 10.0, 20.0, 1000.0]
    distances = [1000.0, 6000.0, 6000.0, 1000.0]
    masses = [1.0, 5.0, 5.0, 1.0]
    st = scenario(c, arrivals, distances, masses, policies=ALWAYS)
    # o0: takes off at 0, delivered at 100, lands at 200.
    land0 = 100.0 - 100.0 * (rate(1.0) + rate(0.0))
    # o1 (the oldest waiting) at 200 s: reaches 6 km before the abort level -> delivered at 800.
    assert 600.0 * rate(5.0) < 0.5 * land0
    land1 = land0 - 600.0 * (rate(5.0) + rate(0.0))
    # o2 (older than o3) at 1400 s: aborts, is not back by the horizon; o3 is never flown.
    assert 600.0 * rate(5.0) >= 0.5 * land1
    t_abort = 1400.0 + 0.5 * land1 / rate(5.0)
    assert t_abort < T < t_abort + (t_abort - 1400.0)
    r = run_state(st, c)
    m = run_metrics(r)
    assert m["orders_arrived"] == 4
    assert m["delivered"] == 2
    assert m["median_delivery_time_s"] == pytest.approx((100.0 + 790.0) / 2, rel=1e-12)
    assert m["attempts"] == 3
    assert m["aborted_attempts"] == 1
    assert m["aborted_pct"] == pytest.approx(100.0 / 3, rel=1e-12)
    assert m["pending"] == 2
    assert m["backlog_age_s"] == pytest.approx((T - 20.0) + (T - 1000.0), rel=1e-12)
    assert m["lost_uavs"] == 0
    assert m["auctions"] == 3
    assert m["reservations_won"] == 0
    assert math.isnan(m["median_reservation_wait_s"]) and math.isnan(m["forecast_met_pct"])
    t = delivery_records.tables(r)
    orders = t["orders"].to_pydict()
    assert orders["delivered_s"][:2] == pytest.approx([100.0, 800.0], rel=1e-12)
    assert orders["delivered_s"][2:] == [None, None]
    assert orders["delivery_time_s"][:2] == pytest.approx([100.0, 790.0], rel=1e-12)
    assert orders["winners"] == [[0], [0], [0], []]
    attempts = t["attempts"].to_pydict()
    assert attempts["order_id"] == [0, 1, 2]
    assert attempts["takeoff_s"] == [0.0, 200.0, 1400.0]
    assert attempts["outcome"] == ["delivered", "delivered", "aborted"]
    assert attempts["parcel_delivered"] == [True, True, False]
    assert attempts["turn_s"] == pytest.approx([100.0, 800.0, t_abort], rel=1e-12)
    assert attempts["return_s"][:2] == pytest.approx([200.0, 1400.0], rel=1e-12)
    assert attempts["return_s"][2] is None and attempts["return_soc"][2] is None
    assert attempts["takeoff_soc"] == pytest.approx([100.0, land0, land1], rel=1e-12)
    assert attempts["allocated_s"] == attempts["takeoff_s"] and attempts["wait_s"] == [0.0, 0.0, 0.0]
    assert attempts["reserved"] == [False] * 3
    assert attempts["forecast_wait_s"] == attempts["forecast_met"] == [None] * 3
    summary = t["summary"].to_pylist()[0]
    assert str({k: summary[k] for k in METRICS}) == str(m)  # nan-safe
    ts = t["timeseries"].to_pydict()
    assert ts["t_s"] == [0.0, 900.0, 1800.0]
    assert ts["delivered"] == [0, 2, 2]
    assert ts["in_flight"] == [1, 1, 1]
    assert ts["idle"] == [0, 0, 0]
    # 0: o0 taken at once; 900: o2 waits (o3 not arrived); 1800: o3 waits, o2 is still being
    # flown home after its abort, so it is not unallocated yet.
    assert ts["unallocated"] == [0, 1, 1]
    assert ts["aborted_attempts"] == [0, 0, 1]


def test_backlog_and_pending_by_arrival_week():
    # Nobody bids: every order is pending at the horizon; its age counts from its own arrival.
    c = scenario_config(horizon_s=2 * WEEK)
    T = c.horizon_s
    arrivals = [0.0, WEEK - 1.0, WEEK, 1.5 * WEEK]
    st = scenario(c, arrivals, [2000.0] * 4, [1.0] * 4, policies=NEVER)
    r = run_state(st, c)
    m = run_metrics(r)
    assert m["delivered"] == 0 and m["pending"] == 4 and m["attempts"] == 0
    assert math.isnan(m["median_delivery_time_s"]) and math.isnan(m["aborted_pct"])
    assert m["backlog_age_s"] == pytest.approx(sum(T - a for a in arrivals), rel=1e-12)
    orders = delivery_records.tables(r)["orders"].to_pydict()
    assert orders["arrival_week"] == [1, 1, 2, 2]
    by_week = {}
    for a, w in zip(orders["arrival_s"], orders["arrival_week"]):
        by_week[w] = by_week.get(w, 0.0) + (T - a)
    assert by_week == pytest.approx({1: 2 * T - WEEK + 1.0, 2: 2 * T - 2.5 * WEEK})
    # Every tick advertised an order (the queue is never empty after t = 0).
    assert m["auctions"] == math.floor(T / 2.0) + 1


# ---------------------------------------------------------------------------- atomic writes


class _Boom(OSError):
    pass


def _failing_writer(calls_before_failure=0):
    """A pq.write_table that writes a truncated file and raises (after some good calls)."""
    real = pq.write_table
    calls = []

    def write(table, where, *args, **kwargs):
        calls.append(where)
        if len(calls) > calls_before_failure:
            with open(where, "wb") as fh:
                fh.write(b"PAR1 truncated")
            raise _Boom("disk full")
        return real(table, where, *args, **kwargs)

    return write, calls


def test_failed_write_leaves_no_file(small_run, tmp_path, monkeypatch):
    table = delivery_records.tables(small_run)["attempts"]
    write, calls = _failing_writer()
    monkeypatch.setattr(pq, "write_table", write)
    target = tmp_path / "attempts.parquet"
    with pytest.raises(_Boom):
        records.write_table(table, target, small_run.config)
    assert calls  # the patched writer was used
    assert not target.exists()
    assert list(tmp_path.iterdir()) == []


def test_failed_write_keeps_the_previous_file(small_run, tmp_path, monkeypatch):
    tables = delivery_records.tables(small_run)
    target = tmp_path / "orders.parquet"
    records.write_table(tables["orders"], target, small_run.config)
    before = target.read_bytes()
    write, calls = _failing_writer()
    monkeypatch.setattr(pq, "write_table", write)
    with pytest.raises(_Boom):
        records.write_table(tables["attempts"], target, small_run.config)
    assert calls
    assert target.read_bytes() == before
    assert pq.read_table(target).equals(tables["orders"].replace_schema_metadata(
        pq.read_table(target).schema.metadata))
    assert [p.name for p in tmp_path.iterdir()] == ["orders.parquet"]


def test_interrupted_run_leaves_no_run_folder(small_run, tmp_path, monkeypatch):
    write, calls = _failing_writer(calls_before_failure=2)
    monkeypatch.setattr(pq, "write_table", write)
    with pytest.raises(_Boom):
        delivery_records.write_run(small_run, tmp_path / "run")
    assert len(calls) == 3
    assert list(tmp_path.iterdir()) == []  # neither the run folder nor its hidden temporary
