"""Synthetic lunar tables with the columns and types of the simulator's (LUNAR-CONTRACT.md), for the
study's and the replay page's tests: made from (layout, battery, eps, run) alone, so that every
statistic of them is known beforehand, and any chunk of runs gives the rows of the whole."""

import math
import types

import numpy as np
import pyarrow as pa

KEYS = "TNR"
ROLES = ("F_OUT", "F_IN", "R", "B")
SUMMARY_INT = ("resources", "trips", "interruptions", "nest_recharges", "sessions", "deaths", "depletions", "beacons",
               "mobile", "units_beacons")
SUMMARY_FLOAT = (*(f"alignment_{k}" for k in KEYS), *(f"alignment_w_{k}" for k in KEYS),
                 *(f"heading_alignment_{k}" for k in KEYS), "deaths_per_session", "t_first_T", "t_first_R",
                 "t_first_row5", "t_beacons_90")
ROWS = (*(f"row{k}" for k in range(1, 12)), "rowD")
TS_INT = ("resources", "trips", "interruptions", "nest_recharges", "sessions")
TS_COUNTS = ("n_mobile", "n_beacons", "n_dead", "n_unspawned", "n_f_out", "n_f_in", "n_r")
LAYOUT_BASE = {"OPEN": 300, "HARD-RT": 200, "SOFT-RT": 250, "HARD-NT": 100, "SOFT-NT": 220, "HARD-NR": 150,
               "SOFT-NR": 240}


def final_resources(layout: str, battery_wh: float, eps: float, run: int) -> int:
    """F(T_run) of a synthetic run: a layout's base, scrambled by run (so the best 30 are not the first)."""
    base = LAYOUT_BASE[layout] * (0.3 if eps == 1.0 else 1.0) + 10 * battery_wh
    return int(base + (run * 37) % 50)


def record_times(params) -> np.ndarray:
    """t of the records: every n_T ticks from n_T to the end [s]."""
    ticks = np.arange(params.n_T, params.ticks + 1, params.n_T)
    return ticks * params.tau


def _summary(params, runs):
    rows = {"run": pa.array(runs, pa.int64()), "seed": pa.array([params.seed] * len(runs), pa.int64()),
            "layout": pa.array([params.layout] * len(runs), pa.string()),
            "battery_wh": pa.array([params.battery_wh] * len(runs), pa.float64())}
    finals = [final_resources(params.layout, params.battery_wh, params.eps, r) for r in runs]
    for name in SUMMARY_INT:
        rows[name] = pa.array(finals if name == "resources" else [(r % 5) + len(name) for r in runs], pa.int64())
    for name in SUMMARY_FLOAT:
        values = [0.1 * (r % 7) for r in runs]
        if name == "deaths_per_session":
            values = [math.nan if r % 4 == 0 else v for r, v in zip(runs, values)]
        rows[name] = pa.array(values, pa.float64())
    for name in ROWS:
        rows[name] = pa.array([r + 1 for r in runs], pa.int64())
    return pa.table(rows)


def _timeseries(params, runs):
    t = record_times(params)
    cols = {name: [] for name in ("run", "t", *TS_INT, "rate", *TS_COUNTS, "soc_sum", "soc_beacons", "soc_mobile",
                                  "soc_min_beacon", "units_beacons", "alignment_T", "alignment_N", "alignment_R")}
    for r in runs:
        final = final_resources(params.layout, params.battery_wh, params.eps, r)
        share = t / params.duration_s
        resources = np.floor(final * share).astype(np.int64)
        cols["run"] += [r] * len(t)
        cols["t"] += t.tolist()
        for name in TS_INT:
            cols[name] += (resources if name == "resources" else np.floor(share * (r + 3))).astype(int).tolist()
        cols["rate"] += (final * params.rate_window_s / params.duration_s + 0 * t).tolist()
        for k, name in enumerate(TS_COUNTS):
            cols[name] += ((r + k) % 7 + np.zeros(len(t), dtype=int)).tolist()
        cols["soc_sum"] += (params.n_robots - share * (10 + r % 5)).tolist()
        cols["soc_beacons"] += (20 - share).tolist()
        cols["soc_mobile"] += (10 - share).tolist()
        cols["soc_min_beacon"] += [math.nan] + [0.5] * (len(t) - 1)
        cols["units_beacons"] += [r % 3] * len(t)
        for k, key in enumerate(KEYS):
            cols[f"alignment_{key}"] += [math.nan] + (0.2 * (k + 1) + 0 * t[1:]).tolist()
    types_ = {name: pa.float64() for name in ("t", "rate", "soc_sum", "soc_beacons", "soc_mobile", "soc_min_beacon",
                                             "alignment_T", "alignment_N", "alignment_R")}
    return pa.table({name: pa.array(values, types_.get(name, pa.int64())) for name, values in cols.items()})


def _trips(params, runs):
    """Per run: R-T and T-R trips entering every 100 s (length 10 + run m), an N-T trip."""
    cols = {name: [] for name in ("run", "origin", "dest", "tick_left", "tick_entered", "length_m", "energy_j",
                                  "energy_wh", "soc_cost", "duration_s", "soft_length_m", "role_left",
                                  "role_entered", "robot")}
    for r in runs:
        for k, entered in enumerate(np.arange(100.0, params.duration_s, 100.0)):
            origin, dest = (("R", "T"), ("T", "R"), ("N", "T"))[k % 3]
            tick_entered = int(entered / params.tau)
            length = 10.0 + r + k
            cols["run"].append(r)
            cols["origin"].append(origin)
            cols["dest"].append(dest)
            cols["tick_left"].append(tick_entered - 100)
            cols["tick_entered"].append(tick_entered)
            cols["length_m"].append(length)
            cols["energy_j"].append(60.0 * length)
            cols["energy_wh"].append(60.0 * length / 3600)
            cols["soc_cost"].append(60.0 * length / (3600 * params.battery_wh))
            cols["duration_s"].append(100 * params.tau)
            cols["soft_length_m"].append(0.0)
            cols["role_left"].append("R")
            cols["role_entered"].append("F_OUT")
            cols["robot"].append(k % params.n_robots)
    types_ = {"run": pa.int64(), "tick_left": pa.int64(), "tick_entered": pa.int64(), "robot": pa.int64(),
              "origin": pa.string(), "dest": pa.string(), "role_left": pa.string(), "role_entered": pa.string()}
    return pa.table({name: pa.array(values, types_.get(name, pa.float64())) for name, values in cols.items()})


def robot_state(params, r, t, robot):
    """(status, role, mode, x, y, soc, load) of a synthetic robot: robots 0-19 beacons on a grid,
    the others circle the field, robot 49 dead after half the run."""
    w, h = 12.6 * params.layout_scale / 0.75, 10.8 * params.layout_scale / 0.75
    if robot < 20:
        return "alive", "B", "normal", 1.0 + (robot % 5) * 2.5, 1.0 + (robot // 5) * 2.5, 0.9, 0
    if robot == params.n_robots - 1 and t > params.duration_s / 2:
        return "dead", "R", "normal", 6.0, 5.0, 0.0, 0
    angle = (t / 60.0 + robot) % (2 * math.pi)
    role = ("F_OUT", "F_IN", "R")[robot % 3]
    return ("alive", role, "charging" if robot % 7 == 0 else "normal", w / 2 + (2 + robot % 4) * math.cos(angle),
            h / 2 + (2 + robot % 4) * math.sin(angle), 0.5 + 0.01 * robot, 6 if role == "F_IN" else 0)


def _snapshots(params, runs):
    times = {"first_T": 12.0, "first_R": 20.0, "first_row5": 300.0, "end": params.duration_s}
    labels = [(label, t) for label, t in times.items() if t <= params.duration_s]
    labels += [("periodic", t) for t in np.arange(params.snapshot_every_s, params.duration_s + 1e-9,
                                                  params.snapshot_every_s)]
    if params.frames:
        every = params.frame_every_ticks   # every n_T ticks, or frame_every_s
        labels += [("frame", t) for t in np.arange(every, params.ticks + 1, every) * params.tau]
    cols = {name: [] for name in ("run", "label", "t", "robot", "status", "role", "mode", "x", "y", "heading", "soc",
                                  "load", *(f"{n}_{k}" for n in ("omega", "vx", "vy", "S") for k in KEYS))}
    for r in runs:
        for label, t in labels:
            for robot in range(params.n_robots):
                status, role, mode, x, y, soc, load = robot_state(params, r, t, robot)
                for name, value in (("run", r), ("label", label), ("t", float(t)), ("robot", robot),
                                    ("status", status), ("role", role), ("mode", mode), ("x", x), ("y", y),
                                    ("heading", 0.5), ("soc", soc), ("load", load)):
                    cols[name].append(value)
                for k, key in enumerate(KEYS):
                    beacon = role == "B" and (robot + k) % 3 != 0
                    cols[f"omega_{key}"].append(0.5 if beacon else 0.0)
                    cols[f"vx_{key}"].append(1.0 * math.cos(k + robot) if beacon else 0.0)
                    cols[f"vy_{key}"].append(1.0 * math.sin(k + robot) if beacon else 0.0)
                    cols[f"S_{key}"].append(0.05 if beacon else 0.0)
    strings = ("label", "status", "role", "mode")
    ints = ("run", "robot", "load")
    return pa.table({name: pa.array(values, pa.string() if name in strings else pa.int64() if name in ints
                                    else pa.float64()) for name, values in cols.items()})


def _robots(params, runs):
    """Per run and robot: robot j made j % 4 trips over 100 m a trip; the last robot died."""
    ids = [(r, robot) for r in runs for robot in range(params.n_robots)]
    half = params.duration_s / 4
    cols = {"run": [r for r, _ in ids], "robot": [robot for _, robot in ids],
            "trips": [robot % 4 for _, robot in ids], "distance_m": [100.0 * (robot % 4) for _, robot in ids],
            "energy_j": [6000.0 * (robot % 4) for _, robot in ids],
            "energy_wh": [6000.0 * (robot % 4) / 3600 for _, robot in ids],
            "recharges": [robot % 2 for _, robot in ids], "loads": [robot % 3 for _, robot in ids],
            "unloads": [robot % 3 for _, robot in ids], "time_f_out_s": [half] * len(ids),
            "time_f_in_s": [half] * len(ids), "time_r_s": [half] * len(ids), "time_b_s": [half] * len(ids),
            "died": [robot == params.n_robots - 1 for _, robot in ids]}
    types_ = {"run": pa.int64(), "robot": pa.int64(), "trips": pa.int64(), "recharges": pa.int64(),
              "loads": pa.int64(), "unloads": pa.int64(), "died": pa.bool_()}
    return pa.table({name: pa.array(values, types_.get(name, pa.float64())) for name, values in cols.items()})


def _deaths(params, runs):
    """The last robot dies in role R at (6, 5), outside every region, half-way through each run."""
    return pa.table({"run": pa.array(runs, pa.int64()), "robot": pa.array([params.n_robots - 1] * len(runs), pa.int64()),
                     "t": pa.array([params.duration_s / 2] * len(runs), pa.float64()),
                     "x": pa.array([6.0] * len(runs), pa.float64()), "y": pa.array([5.0] * len(runs), pa.float64()),
                     "role": pa.array(["R"] * len(runs), pa.string()),
                     "mode": pa.array(["normal"] * len(runs), pa.string()),
                     "region": pa.array([None] * len(runs), pa.string())})


def _recharge_triggers(params, runs):
    """One recharging interruption a run, robot 21 at SOC 0.3, a quarter of the way through."""
    n = len(runs)
    return pa.table({"run": pa.array(runs, pa.int64()), "robot": pa.array([21] * n, pa.int64()),
                     "t": pa.array([params.duration_s / 4] * n, pa.float64()), "role": pa.array(["F_OUT"] * n),
                     **{name: pa.array([value] * n, pa.float64()) for name, value in
                        (("soc", 0.3), ("s_hat_dest", 0.1), ("s_hat_R", 0.15), ("x", 3.0), ("y", 4.0),
                         ("dist_R_m", 5.0))}})


def _beacon_costs(params, runs):
    """At the end of each run, 3 beacons near T and 2 near R, with the costs of their snapshot rows."""
    n = 2 * len(runs)
    return pa.table({"run": pa.array([r for r in runs for _ in "TR"], pa.int64()),
                     "label": pa.array(["end"] * n), "t": pa.array([params.duration_s] * n, pa.float64()),
                     "near": pa.array(list("TR") * len(runs)), "beacons": pa.array([3, 2] * len(runs), pa.int64()),
                     "S_R_mean": pa.array([0.05] * n, pa.float64()), "S_T_mean": pa.array([0.05] * n, pa.float64())})


def simulate(params):
    """The tables of ``params``' runs (first_run .. first_run + runs - 1), synthetic."""
    runs = list(range(params.first_run, params.first_run + params.runs))
    return {"summary": _summary(params, runs), "timeseries": _timeseries(params, runs),
            "trips": _trips(params, runs), "snapshots": _snapshots(params, runs), "robots": _robots(params, runs),
            "deaths": _deaths(params, runs), "recharge_triggers": _recharge_triggers(params, runs),
            "beacon_costs": _beacon_costs(params, runs)}


def module():
    """A stand-in for ``dronefleet.lunar.simulate`` (put in sys.modules)."""
    fake = types.ModuleType("dronefleet.lunar.simulate")
    fake.simulate = simulate
    return fake

