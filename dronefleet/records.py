"""A run's tables (MODEL.md section 10), its metrics (section 11) and their parquet files.

Every file carries the full resolved config (JSON) in its schema metadata under
``dronefleet.config``, and what made it under ``dronefleet.provenance`` (see
:mod:`dronefleet.provenance`). Files are written under a temporary name and renamed, so a
reader never sees a truncated file. A run folder is complete or absent: its tables are
written into a hidden sibling folder that is renamed into place (:func:`write_run`).

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

import errno
import json
import os
import re
import shutil
import socket
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from .config import SECONDS_PER_WEEK, config_from_dict
from .delivery.engine import IN_FLIGHT, OUTCOME_DELIVERED, OUTCOME_NAMES
from .provenance import stamp

TABLES = ("orders", "attempts", "fleet", "timeseries", "summary")
CONFIG_KEY = b"dronefleet.config"


def _nullable(values):
    return pa.array(values, from_pandas=True)  # nan -> null


def orders_table(result):
    o, a = result.orders, result.attempts
    n = o["arrival_s"].shape[0]
    by_order = np.argsort(a["order"], kind="stable")
    offsets = np.concatenate(([0], np.cumsum(np.bincount(a["order"], minlength=n)))).astype(np.int32)
    winners = pa.ListArray.from_arrays(pa.array(offsets), pa.array(a["uav"][by_order].astype(np.int16)))
    return pa.table({
        "order_id": pa.array(np.arange(n, dtype=np.int32)),
        "arrival_s": o["arrival_s"],
        "arrival_week": (o["arrival_s"] // SECONDS_PER_WEEK).astype(np.int16) + np.int16(1),
        "distance_m": o["distance_m"],
        "mass_kg": o["mass_kg"],
        "attempts": o["attempts"].astype(np.int16),
        "winners": winners,
        "delivered_s": _nullable(o["delivered_s"]),
        "delivery_time_s": _nullable(o["delivered_s"] - o["arrival_s"]),
    })


def attempts_table(result):
    a = result.attempts
    n = a["uav"].shape[0]
    outcome = np.where(a["lost"], "lost", np.array(OUTCOME_NAMES)[a["outcome"]])
    reserved = ~np.isnan(a["forecast_wait_s"])
    turned = a["outcome"] != IN_FLIGHT
    return pa.table({
        "attempt_id": pa.array(np.arange(n, dtype=np.int32)),
        "uav": a["uav"].astype(np.int16),
        "order_id": a["order"].astype(np.int32),
        "takeoff_s": a["takeoff_s"],
        "takeoff_soc": a["takeoff_soc"],
        "outcome": pa.array(outcome.tolist(), pa.string()),
        "parcel_delivered": a["outcome"] == OUTCOME_DELIVERED,
        "turn_s": _nullable(a["turn_s"]),
        "return_s": _nullable(a["return_s"]),
        "return_soc": _nullable(a["return_soc"]),
        "allocated_s": a["allocated_s"],
        "reserved": reserved,
        "wait_s": a["takeoff_s"] - a["allocated_s"],
        "forecast_wait_s": _nullable(a["forecast_wait_s"]),
        "forecast_met": pa.array(np.where(reserved & turned, a["outcome"] == OUTCOME_DELIVERED, None).tolist(),
                                 pa.bool_()),
    })


def fleet_table(result):
    from .delivery.metrics import accuracy_points, decision_accuracy  # pandas: only for delivery's tables

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
    return pa.table(table)


def timeseries_table(result):
    s = result.series
    return pa.table({
        "t_s": s["t_s"], "delivered": s["delivered"], "unallocated": s["unallocated"],
        "in_flight": s["in_flight"], "aborted_attempts": s["aborted"], "idle": s["idle"], "lost": s["lost"],
        "reserved": s["reserved"],
    })


def summary_table(result):
    from .delivery.metrics import run_metrics

    c = result.config
    row = dict(seed=c.seed, rule=c.rule, tau_minutes=c.tau_minutes, n_uavs=c.n_uavs,
               horizon_weeks=c.horizon_weeks, period=result.period, **run_metrics(result))
    return pa.table({key: [value] for key, value in row.items()})


def tables(result):
    """All tables of a run, by name (see the module doc for their schemas)."""
    return {"orders": orders_table(result), "attempts": attempts_table(result), "fleet": fleet_table(result),
            "timeseries": timeseries_table(result), "summary": summary_table(result)}


def _temporary_name(path, kind):
    """Hidden sibling of ``path`` for this host and process: ``.<name>.<host>-<pid>.<kind>``."""
    return path.with_name(f".{path.name}.{socket.gethostname()}-{os.getpid()}.{kind}")


def write_atomic(path, write):
    """``write(tmp)`` a hidden sibling temporary file, then rename it to ``path``; return ``path``.

    A reader never sees a partial file, and an interrupted write leaves only the hidden
    temporary, whose name ends in ``.tmp`` (no dataset reader or ``*.parquet`` glob takes
    it). It names the host and process: writers on several hosts of a shared filesystem
    never collide.
    """
    path = Path(path)
    tmp = _temporary_name(path, "tmp")
    try:
        write(tmp)
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)
    return path


def write_table(table, path, config):
    """Write ``table`` to ``path`` atomically, with the resolved ``config`` and the provenance in its metadata."""
    table = stamp(table.replace_schema_metadata({CONFIG_KEY: config.to_json()}))
    return write_atomic(path, lambda tmp: pq.write_table(table, tmp))


def run_dir_state(out_dir, table_names=TABLES):
    """What ``out_dir`` holds: ``"absent"``, ``"empty"``, ``"complete"`` (every table ``table_names`` of a run),
    ``"partial"`` (some tables and nothing else: left by a dronefleet before complete-or-absent
    run folders), ``"file"`` (not a folder) or ``"other"`` (files that are not a run's tables).
    Hidden entries (``.DS_Store``, ...) go with the run, but a folder holding only those is not empty."""
    out_dir = Path(out_dir)
    if not out_dir.exists():
        return "absent"
    if not out_dir.is_dir():
        return "file"
    entries = [p.name for p in out_dir.iterdir()]
    names = {name for name in entries if not name.startswith(".")}
    tables = {f"{name}.parquet" for name in table_names}
    if not entries:
        return "empty"
    if not names or not names <= tables:
        return "other"
    return "complete" if names == tables else "partial"


def clean_leftovers(out_dir):
    """Remove what interrupted writers of the run folder ``out_dir`` left beside it.

    Only this host's leftovers whose process is gone are touched. A killed replacement
    may have left the previous run aside (``.<name>.<host>-<pid>.old``) and no run in
    place: that run is put back, so the folder again holds the old complete run.
    """
    out_dir = Path(out_dir)
    pattern = re.compile(rf"\.{re.escape(out_dir.name)}\.{re.escape(socket.gethostname())}-(\d+)\.(tmp|old)")
    if not out_dir.parent.is_dir():
        return
    for leftover in sorted(out_dir.parent.iterdir(), key=lambda p: p.name.endswith(".tmp")):  # .old first
        match = pattern.fullmatch(leftover.name)
        if match is None or _alive(int(match[1])):
            continue
        if match[2] == "old" and run_dir_state(out_dir) in ("absent", "empty"):
            os.replace(leftover, out_dir)
        else:
            shutil.rmtree(leftover, ignore_errors=True)


def _alive(pid):
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # another user's process
        return True
    return True


def write_run(result, out_dir, overwrite=False):
    """Write every table of the delivery run ``result``: :func:`write_tables` of :func:`tables`."""
    return write_tables(tables(result), out_dir, result.config, overwrite)


def write_tables(named_tables, out_dir, config, overwrite=False):
    """Write ``named_tables`` (name -> pyarrow Table) as ``out_dir/<name>.parquet`` with
    ``config`` (anything with ``to_json()``) and the provenance in each file's metadata
    (:func:`write_table`); return the paths. Any scenario's run folder is written here.

    The folder is complete or absent: the tables go into the hidden sibling
    ``.<name>.<host>-<pid>.tmp``, which is then renamed to ``out_dir`` (atomic on POSIX). An
    existing run is replaced only with ``overwrite``: it is renamed aside to ``...old``, the
    new one renamed in, the old one deleted. A crash at any point leaves the old complete
    run or the new one, plus at most a hidden leftover that :func:`clean_leftovers` (called
    here first) removes or, if the crash fell between the two renames, puts back in place.

    Raises
    ------
    FileExistsError
        If ``out_dir`` holds a run and not ``overwrite``, or holds files other than a run's
        tables (never deleted, whatever ``overwrite``).
    OSError
        Any failure to write (disk full, read-only, ...); ``out_dir`` is then as it was.
    """
    out_dir = Path(out_dir)
    clean_leftovers(out_dir)
    out_dir.parent.mkdir(parents=True, exist_ok=True)
    tmp, aside = _temporary_name(out_dir, "tmp"), _temporary_name(out_dir, "old")
    try:
        tmp.mkdir()
        paths = {name: out_dir / write_table(table, tmp / f"{name}.parquet", config).name
                 for name, table in named_tables.items()}
        state = run_dir_state(out_dir, named_tables)
        if state in ("complete", "partial") and overwrite:
            os.replace(out_dir, aside)
        elif state not in ("absent", "empty"):
            why = {"other": "holds files other than a run's tables", "file": "is a file"}.get(state, "holds a run")
            raise FileExistsError(errno.EEXIST, why, str(out_dir))
        os.replace(tmp, out_dir)  # fails, leaving out_dir as it is, if another writer came first
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        if aside.exists() and not out_dir.exists():
            os.replace(aside, out_dir)
        raise
    shutil.rmtree(aside, ignore_errors=True)
    return paths


def read_config_dict(path):
    """The resolved config embedded in a dronefleet parquet file, as the dict of its JSON."""
    return json.loads(pq.read_schema(path).metadata[CONFIG_KEY])


def read_config(path):
    """The resolved delivery config embedded in a dronefleet parquet file."""
    return config_from_dict(read_config_dict(path))
