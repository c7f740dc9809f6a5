"""Run one configuration of the lunar model: all its runs in one kernel call, as pyarrow tables.

:func:`simulate` returns the tables of the contract (``summary``, ``timeseries``, ``trips``,
``snapshots``, ``robots``, ``deaths``, ``recharge_triggers``, ``beacon_costs``); :func:`table_schemas`
gives their columns and types. Run j draws its per-robot
streams from ``seed * 2**32 + j`` whatever the layout or options (spec section 13), so run j of
every scenario is paired with run j of every other.
"""

from __future__ import annotations

import functools
from pathlib import Path

import numpy as np
import pyarrow as pa

from .. import interrupt
from ..supervisor import load_supervisor
from . import kernel as k
from .layout import build, kernel_geometry
from .params import LunarParams

__all__ = ["simulate", "table_schemas", "run_seeds", "kernel_inputs", "run_kernel", "role_table",
           "TABLES", "EVENTS", "ROLES_FILE"]

#: The robots' roles as a Nadzoru 2 supervisor (spec section 9).
ROLES_FILE = Path(__file__).resolve().parent.parent / "data" / "lunar-roles.yaml"
#: The supervisor events the kernel fires, in the kernel's EV_* column order.
EVENTS = ("becomeBeacon", "goCharge", "charge", "goOut", "goIn", "load", "unload", "revert", "turnAround",
          "depleted")
ROLE_NAMES = ("F_OUT", "F_IN", "R", "B")
STATUS_NAMES = ("unspawned", "alive", "dead")
MODE_NAMES = ("normal", "charging", "reconnect", "backtrack")
REGION_NAMES = ("T", "N", "R")
LABEL_NAMES = ("first_T", "first_R", "first_row5", "periodic", "end", "frame")

TABLES = ("summary", "timeseries", "trips", "snapshots", "robots", "deaths", "recharge_triggers", "beacon_costs")
_I, _F, _S = pa.int64(), pa.float64(), pa.string()
ROW_NAMES = tuple(f"row{r}" for r in range(1, 12)) + ("rowD",)

_SUMMARY = (
    [("run", _I), ("seed", _I), ("layout", _S), ("battery_wh", _F), ("resources", _I), ("trips", _I),
     ("interruptions", _I), ("nest_recharges", _I), ("sessions", _I), ("deaths", _I), ("depletions", _I),
     ("beacons", _I),
     ("mobile", _I), ("units_beacons", _I),
     ("alignment_T", _F), ("alignment_N", _F), ("alignment_R", _F),
     ("alignment_w_T", _F), ("alignment_w_N", _F), ("alignment_w_R", _F),
     ("heading_alignment_T", _F), ("heading_alignment_N", _F), ("heading_alignment_R", _F),
     ("deaths_per_session", _F), ("t_first_T", _F), ("t_first_R", _F), ("t_first_row5", _F),
     ("t_beacons_90", _F)]
    + [(name, _I) for name in ROW_NAMES])
_TIMESERIES = [
    ("run", _I), ("t", _F), ("resources", _I), ("trips", _I), ("interruptions", _I),
    ("nest_recharges", _I), ("sessions", _I), ("rate", _F), ("n_mobile", _I), ("n_beacons", _I),
    ("n_dead", _I), ("n_unspawned", _I), ("n_f_out", _I), ("n_f_in", _I), ("n_r", _I),
    ("soc_sum", _F), ("soc_beacons", _F), ("soc_mobile", _F), ("soc_min_beacon", _F),
    ("units_beacons", _I), ("alignment_T", _F), ("alignment_N", _F), ("alignment_R", _F)]
_TRIPS = [
    ("run", _I), ("origin", _S), ("dest", _S), ("tick_left", _I), ("tick_entered", _I),
    ("length_m", _F), ("energy_j", _F), ("energy_wh", _F), ("soc_cost", _F), ("duration_s", _F),
    ("soft_length_m", _F), ("role_left", _S), ("role_entered", _S), ("robot", _I)]
_SNAPSHOTS = (
    [("run", _I), ("label", _S), ("t", _F), ("robot", _I), ("status", _S), ("role", _S), ("mode", _S),
     ("x", _F), ("y", _F), ("heading", _F), ("soc", _F), ("load", _I)]
    + [(f"{q}_{r}", _F) for q in ("omega", "vx", "vy", "S") for r in ("T", "N", "R")])
_ROBOTS = [
    ("run", _I), ("robot", _I), ("trips", _I), ("distance_m", _F), ("energy_j", _F), ("energy_wh", _F),
    ("recharges", _I), ("loads", _I), ("unloads", _I), ("time_f_out_s", _F), ("time_f_in_s", _F),
    ("time_r_s", _F), ("time_b_s", _F), ("died", pa.bool_())]
_DEATHS = [("run", _I), ("robot", _I), ("t", _F), ("x", _F), ("y", _F), ("role", _S), ("mode", _S), ("region", _S)]
_TRIGGERS = [("run", _I), ("robot", _I), ("t", _F), ("role", _S), ("soc", _F), ("s_hat_dest", _F), ("s_hat_R", _F),
             ("x", _F), ("y", _F), ("dist_R_m", _F)]
_BEACON_COSTS = [("run", _I), ("label", _S), ("t", _F), ("near", _S), ("beacons", _I), ("S_R_mean", _F),
                 ("S_T_mean", _F)]
#: The regions whose nearby beacons' stored costs ``beacon_costs`` follows (A36).
COST_REGIONS = ("T", "R")


def table_schemas() -> dict[str, pa.Schema]:
    """``{table: pyarrow.Schema}`` of the tables :func:`simulate` returns (spec sections 12, 19)."""
    return {name: pa.schema(fields) for name, fields in
            zip(TABLES, (_SUMMARY, _TIMESERIES, _TRIPS, _SNAPSHOTS, _ROBOTS, _DEATHS, _TRIGGERS, _BEACON_COSTS))}


@functools.lru_cache(maxsize=1)
def role_table() -> tuple[np.ndarray, int]:
    """(transition table (1, states, len(EVENTS)) int64, initial state) of :data:`ROLES_FILE`."""
    automaton = load_supervisor(ROLES_FILE)
    table = automaton.transition_table(EVENTS)
    table.setflags(write=False)
    return table, int(automaton.init_state[0])


def run_seeds(params: LunarParams) -> tuple[np.ndarray, np.ndarray]:
    """(run indices, root seeds) int64 of runs first_run .. first_run + runs - 1: run j draws from
    seed * 2**32 + j, whatever the layout and options (section 13: common random numbers)."""
    runs = np.arange(params.first_run, params.first_run + params.runs, dtype=np.int64)
    return runs, np.int64(params.seed) * np.int64(2**32) + runs


def kernel_inputs(params: LunarParams) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(opts int64 (N_OPTS,), pars float64 (N_PARS,), geometry (22,)) of ``params`` for the kernel."""
    p = params
    opts = np.zeros(k.N_OPTS, dtype=np.int64)
    opts[k.O_ROBOTS], opts[k.O_TICKS], opts[k.O_NT] = p.n_robots, p.ticks, p.n_T
    opts[k.O_RMAX], opts[k.O_BLOCKED] = p.r_max, p.blocked_ticks
    opts[k.O_RATE_W], opts[k.O_SNAP_EVERY] = p.rate_window_ticks, max(1, p.snapshot_every_ticks)
    opts[k.O_FRAMES] = p.frame_every_ticks if p.frames else 0   # frame interval [ticks], 0: none
    opts[k.O_AVOID_TURN] = p.avoidance == "turn"
    opts[k.O_BCAST_MOTION] = p.broadcast_velocity == "motion"
    opts[k.O_BCAST_UPDATE] = p.broadcast == "update"
    opts[k.O_WFORM] = ("exponent", "bracket", "literal").index(p.weight_form)
    opts[k.O_FALLBACK_LITERAL] = p.fallback == "literal"
    opts[k.O_TURN_ANY] = p.turn_on == "any"
    opts[k.O_LOS_BODIES] = p.los_bodies
    opts[k.O_REDECIDE] = ("none", "avoid_clear", "beacon_change").index(p.redecide)
    opts[k.O_COMPLETION_LAST] = p.completion == "last_region"
    opts[k.O_INIT_STATE] = role_table()[1]
    opts[k.O_DEPLETION_RECORDED] = p.depletion == "recorded"
    opts[k.O_EXPERIENCE_LEAVING] = p.experience == "leaving"
    opts[k.O_BASELINE] = p.model == "baseline"
    pars = np.zeros(k.N_PARS)
    pars[k.P_TAU], pars[k.P_RHO_W], pars[k.P_RHO_V], pars[k.P_RHO_P] = p.tau, p.rho_w, p.rho_v, p.rho_p
    pars[k.P_RHO_F], pars[k.P_RHO_C], pars[k.P_COMM_R], pars[k.P_ETA_W] = p.rho_f, p.rho_c, p.comm_radius, p.eta_w
    pars[k.P_PHI], pars[k.P_V0], pars[k.P_EPS], pars[k.P_REWARD] = p.phi_soc, p.v0, p.eps, p.reward
    pars[k.P_LAMBDA], pars[k.P_KAPPA], pars[k.P_ECAP], pars[k.P_SOC0] = p.diffusion, p.kappa_soft, p.e_cap_j, p.soc0
    pars[k.P_MOVE], pars[k.P_COMP], pars[k.P_COMM], pars[k.P_SCAN] = p.p_move, p.p_comp, p.p_comm, p.p_scan
    pars[k.P_AVOID], pars[k.P_EXPLOIT], pars[k.P_SOLAR] = p.p_avoid, p.e_exploit, p.p_solar
    if p.model == "baseline":  # Ch 4 has no energy: nothing is drawn, E stays E_cap (the powers are not used)
        pars[[k.P_MOVE, k.P_COMP, k.P_COMM, k.P_SCAN, k.P_AVOID, k.P_EXPLOIT]] = 0.0
    pars[k.P_RBODY], pars[k.P_IR] = p.r_body, p.ir_range
    pars[k.P_DECISION_STEP], pars[k.P_SOC0_LOW] = p.decision_step_m, p.soc0_low
    if p.energy_scale != 1.0:  # A8: scaled once here, so that the default's arithmetic is untouched
        for c in (k.P_MOVE, k.P_COMP, k.P_COMM, k.P_SCAN, k.P_AVOID, k.P_EXPLOIT):
            pars[c] *= p.energy_scale
    return opts, pars, kernel_geometry(build(p))


def run_kernel(params: LunarParams) -> tuple[np.ndarray, ...]:
    """The kernel's raw outputs for every run of ``params`` (Ctrl-C stops it): summary
    (runs, N_SUMMARY), series (runs, records, N_SERIES), trips (rows, N_TRIP), snapshots
    (rows, N_SNAP), robots (runs x robots, N_LEDGER), row-2 triggers (rows, N_TRIGGER), float64
    (see the column indices of :mod:`dronefleet.lunar.kernel`)."""
    opts, pars, geometry = kernel_inputs(params)
    runs, seeds = run_seeds(params)
    return interrupt.call(k.run_runs, opts, pars, geometry, seeds, runs, role_table()[0],
                          np.empty((0, k.N_STATE)), culprit="the lunar kernel")


def _names(codes: np.ndarray, names: tuple[str, ...]) -> pa.Array:
    return pa.array(np.asarray(names, dtype=object)[codes.astype(np.int64)], type=pa.string())


def _beacon_costs(params: LunarParams, snaps: np.ndarray) -> pa.Table:
    """Per network snapshot and region X of :data:`COST_REGIONS` (in that order): the alive beacons
    within comm_radius of X's edge (centre distance < radius + comm_radius) and the mean of their
    stored SOC costs S^R and S^F_OUT (A36; a beacon holding none counts 0, as it adds nothing to S_hat)."""
    shots = snaps.reshape(-1, params.n_robots, k.N_SNAP)   # a snapshot is a row per robot, in order
    layout = build(params)
    beacon = (shots[:, :, k.SN_STATUS] == k.ALIVE) & (shots[:, :, k.SN_ROLE] == k.B)
    count, s_r, s_t = [], [], []
    for region in COST_REGIONS:
        (cx, cy), reach = layout.centres[region], layout.radii[region] + params.comm_radius
        near = beacon & ((shots[:, :, k.SN_X] - cx) ** 2 + (shots[:, :, k.SN_Y] - cy) ** 2 < reach * reach)
        count.append(near.sum(axis=1))
        with np.errstate(invalid="ignore"):          # no beacon near: NaN
            s_r.append(np.where(near, shots[:, :, k.SN_S + k.REG_R], 0.0).sum(axis=1) / count[-1])
            s_t.append(np.where(near, shots[:, :, k.SN_S + k.REG_T], 0.0).sum(axis=1) / count[-1])
    per_shot = lambda a: np.repeat(shots[:, 0, a], len(COST_REGIONS))  # noqa: E731
    by_shot = lambda parts: np.stack(parts, axis=1).reshape(-1)  # noqa: E731 (each shot's regions in a row)
    return pa.table({"run": per_shot(k.SN_RUN).astype(np.int64), "label": _names(per_shot(k.SN_LABEL), LABEL_NAMES),
                     "t": per_shot(k.SN_K) * params.tau,
                     "near": pa.array(list(COST_REGIONS) * len(shots), type=pa.string()),
                     "beacons": by_shot(count).astype(np.int64), "S_R_mean": by_shot(s_r), "S_T_mean": by_shot(s_t)},
                    schema=table_schemas()["beacon_costs"])


def simulate(params: LunarParams) -> dict[str, pa.Table]:
    """Every run of ``params`` (first_run .. first_run + runs - 1): ``{table: pyarrow.Table}`` with
    the columns of :func:`table_schemas` (:data:`TABLES`; spec sections 12, 19).

    ``params`` must be valid (``dronefleet.lunar.scenario`` validates it); nothing is checked here.
    """
    summary, series, trips, snaps, robots, triggers = run_kernel(params)
    schemas = table_schemas()
    runs, seeds = run_seeds(params)
    tau = params.tau
    i64 = lambda a: np.asarray(a).astype(np.int64)  # noqa: E731 (integers stored exactly in float64)
    sessions = summary[:, k.SM_SESSIONS]
    with np.errstate(divide="ignore", invalid="ignore"):
        per_session = np.where(sessions > 0, summary[:, k.SM_DEATHS] / np.maximum(sessions, 1), np.nan)
    cols = {"run": runs, "seed": seeds, "layout": pa.array([params.layout] * len(runs), type=pa.string()),
            "battery_wh": np.full(len(runs), float(params.battery_wh))}
    for name, c in (("resources", k.SM_RESOURCES), ("trips", k.SM_TRIPS), ("interruptions", k.SM_INTERRUPTIONS),
                    ("nest_recharges", k.SM_NEST_RECHARGES), ("sessions", k.SM_SESSIONS), ("deaths", k.SM_DEATHS),
                    ("depletions", k.SM_DEPLETIONS), ("beacons", k.SM_BEACONS), ("mobile", k.SM_MOBILE),
                    ("units_beacons", k.SM_UNITS_BEACONS)):
        cols[name] = i64(summary[:, c])
    for q, region in enumerate(REGION_NAMES):
        cols[f"alignment_{region}"] = summary[:, k.SM_ALIGN + q]
        cols[f"alignment_w_{region}"] = summary[:, k.SM_ALIGN_W + q]
        cols[f"heading_alignment_{region}"] = summary[:, k.SM_HEAD_ALIGN + q]
    cols["deaths_per_session"] = per_session
    for name, c in (("t_first_T", k.SM_T_FIRST_T), ("t_first_R", k.SM_T_FIRST_R),
                    ("t_first_row5", k.SM_T_FIRST_ROW5), ("t_beacons_90", k.SM_T_BEACONS_90)):
        cols[name] = summary[:, c]
    for r, name in enumerate(ROW_NAMES):
        cols[name] = i64(summary[:, k.SM_ROWS + r])
    tables = {"summary": pa.table(cols, schema=schemas["summary"])}

    n_runs, n_rec = series.shape[:2]
    flat = series.reshape(n_runs * n_rec, k.N_SERIES)
    cols = {"run": np.repeat(runs, n_rec), "t": flat[:, k.TS_K] * tau}
    for name, c, integer in (
            ("resources", k.TS_RESOURCES, True), ("trips", k.TS_TRIPS, True),
            ("interruptions", k.TS_INTERRUPTIONS, True), ("nest_recharges", k.TS_NEST_RECHARGES, True),
            ("sessions", k.TS_SESSIONS, True), ("rate", k.TS_RATE, False), ("n_mobile", k.TS_MOBILE, True),
            ("n_beacons", k.TS_BEACONS, True), ("n_dead", k.TS_DEAD, True), ("n_unspawned", k.TS_UNSPAWNED, True),
            ("n_f_out", k.TS_F_OUT, True), ("n_f_in", k.TS_F_IN, True), ("n_r", k.TS_R, True),
            ("soc_sum", k.TS_SOC_SUM, False), ("soc_beacons", k.TS_SOC_BEACONS, False),
            ("soc_mobile", k.TS_SOC_MOBILE, False), ("soc_min_beacon", k.TS_SOC_MIN_BEACON, False),
            ("units_beacons", k.TS_UNITS_BEACONS, True)):
        cols[name] = i64(flat[:, c]) if integer else flat[:, c]
    for q, region in enumerate(REGION_NAMES):
        cols[f"alignment_{region}"] = flat[:, k.TS_ALIGN + q]
    tables["timeseries"] = pa.table(cols, schema=schemas["timeseries"])

    energy = trips[:, k.TR_ENERGY]
    left, entered = i64(trips[:, k.TR_TICK_LEFT]), i64(trips[:, k.TR_TICK_ENTERED])
    tables["trips"] = pa.table({
        "run": i64(trips[:, k.TR_RUN]), "origin": _names(trips[:, k.TR_ORIGIN], REGION_NAMES),
        "dest": _names(trips[:, k.TR_DEST], REGION_NAMES), "tick_left": left, "tick_entered": entered,
        "length_m": trips[:, k.TR_LENGTH], "energy_j": energy, "energy_wh": energy / 3600.0,
        "soc_cost": energy / params.e_cap_j, "duration_s": (entered - left) * tau,
        "soft_length_m": trips[:, k.TR_SOFT], "role_left": _names(trips[:, k.TR_ROLE_LEFT], ROLE_NAMES),
        "role_entered": _names(trips[:, k.TR_ROLE_ENTERED], ROLE_NAMES), "robot": i64(trips[:, k.TR_ROBOT]),
    }, schema=schemas["trips"])

    cols = {"run": i64(snaps[:, k.SN_RUN]), "label": _names(snaps[:, k.SN_LABEL], LABEL_NAMES),
            "t": snaps[:, k.SN_K] * tau, "robot": i64(snaps[:, k.SN_ROBOT]),
            "status": _names(snaps[:, k.SN_STATUS], STATUS_NAMES), "role": _names(snaps[:, k.SN_ROLE], ROLE_NAMES),
            "mode": _names(snaps[:, k.SN_MODE], MODE_NAMES), "x": snaps[:, k.SN_X], "y": snaps[:, k.SN_Y],
            "heading": snaps[:, k.SN_HEADING], "soc": snaps[:, k.SN_SOC], "load": i64(snaps[:, k.SN_LOAD])}
    for first, quantity in ((k.SN_OMEGA, "omega"), (k.SN_VX, "vx"), (k.SN_VY, "vy"), (k.SN_S, "S")):
        for q, region in enumerate(REGION_NAMES):
            cols[f"{quantity}_{region}"] = snaps[:, first + q]
    tables["snapshots"] = pa.table(cols, schema=schemas["snapshots"])

    n = params.n_robots
    made = np.bincount((i64(trips[:, k.TR_RUN]) - params.first_run) * n + i64(trips[:, k.TR_ROBOT]),
                       minlength=len(robots))
    ticks = robots[:, k.LG_TICKS:k.LG_TICKS + 4] * tau
    died = robots[:, k.LG_DIED_K] >= 0
    energy = robots[:, k.LG_ENERGY]
    tables["robots"] = pa.table({
        "run": i64(robots[:, k.LG_RUN]), "robot": i64(robots[:, k.LG_ROBOT]), "trips": made.astype(np.int64),
        "distance_m": robots[:, k.LG_MOVES] * (params.v0 * tau), "energy_j": energy, "energy_wh": energy / 3600.0,
        "recharges": i64(robots[:, k.LG_RECHARGES]), "loads": i64(robots[:, k.LG_LOADS]),
        "unloads": i64(robots[:, k.LG_UNLOADS]), "time_f_out_s": ticks[:, k.F_OUT], "time_f_in_s": ticks[:, k.F_IN],
        "time_r_s": ticks[:, k.R], "time_b_s": ticks[:, k.B], "died": died,
    }, schema=schemas["robots"])
    dead = robots[died]
    tables["deaths"] = pa.table({
        "run": i64(dead[:, k.LG_RUN]), "robot": i64(dead[:, k.LG_ROBOT]), "t": dead[:, k.LG_DIED_K] * tau,
        "x": dead[:, k.LG_DIED_X], "y": dead[:, k.LG_DIED_Y], "role": _names(dead[:, k.LG_DIED_ROLE], ROLE_NAMES),
        "mode": _names(dead[:, k.LG_DIED_MODE], MODE_NAMES),
        "region": _names(dead[:, k.LG_DIED_REGION], (*REGION_NAMES, None)),  # NO_REGION (-1): null
    }, schema=schemas["deaths"])
    rx, ry = build(params).centres["R"]
    tx, ty = triggers[:, k.TG_X], triggers[:, k.TG_Y]
    tables["recharge_triggers"] = pa.table({
        "run": i64(triggers[:, k.TG_RUN]), "robot": i64(triggers[:, k.TG_ROBOT]), "t": triggers[:, k.TG_K] * tau,
        "role": _names(triggers[:, k.TG_ROLE], ROLE_NAMES), "soc": triggers[:, k.TG_SOC],
        "s_hat_dest": triggers[:, k.TG_S_HAT_DEST], "s_hat_R": triggers[:, k.TG_S_HAT_R], "x": tx, "y": ty,
        "dist_R_m": np.sqrt((tx - rx) ** 2 + (ty - ry) ** 2),
    }, schema=schemas["recharge_triggers"])
    tables["beacon_costs"] = _beacon_costs(params, snaps)
    return tables
