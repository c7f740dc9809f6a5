"""Each phase of the lunar tick (spec LUNAR-FORAGING.md section 11) called alone on a small state built
by hand: the arrays ``run_runs`` allocates for a run, a few robots put into them, one phase, and what
that phase's rule says it does to them. ``test_lunar_tick.py`` pins the phases wired together."""

import math
from types import SimpleNamespace

import numpy as np
import pytest

from dronefleet.fpmath import atan2, sincos
from dronefleet.lunar import kernel as k
from dronefleet.lunar.params import LunarParams
from dronefleet.lunar.simulate import kernel_inputs, role_table
from dronefleet.rng import seed_stream, uniform

PI = math.pi
SEED = 7
SUP_OF = {k.F_OUT: k.S_F_OUT, k.F_IN: k.S_F_IN, k.R: k.S_R}
# Points of the default SOFT-RT layout: region centres, a spot in no region and off the soft patch.
N_C, T_C, R_C = (2.25, 5.4), (8.55, 8.55), (8.55, 2.25)
FREE = (5.5, 5.4)


def state(n, **changes):
    """The arrays of one run of ``n`` robots as run_runs starts it (all unspawned), with its inputs
    (``changes``: LunarParams fields), the groups the phases take and each robot's stream of run SEED."""
    opts, pars, g = kernel_inputs(LunarParams(**{"n_robots": n, **changes}))
    s = SimpleNamespace(opts=opts, pars=pars, g=g, table=role_table()[0], n=n)
    corners = g[k.G_CORNERS:k.G_CORNERS + 8]
    s.box = np.array([corners[0::2].min(), corners[1::2].min(), corners[0::2].max(), corners[1::2].max()])
    s.ray_s = np.array([sincos(a)[0] for a in k.RAY_ANGLES])
    s.ray_c = np.array([sincos(a)[1] for a in k.RAY_ANGLES])
    s.rng = np.empty((1, n, 4), dtype=np.uint64)
    for i in range(n):
        seed_stream(s.rng, 0, i, SEED, i)
    ints = ("status", "role", "mode", "role_k1", "role_k2", "blocked", "load", "s_c", "n_failed", "countdown",
            "reg", "last_left", "tick_left", "role_left", "links", "nb_cnt", "mb_cnt", "beacons", "nearest",
            "n_near", "here")
    for name in ints:
        setattr(s, name, np.zeros(n, dtype=np.int64))
    for name in ("x", "y", "sx", "sy", "theta_a", "theta", "pcx", "pcy", "mdx", "mdy", "energy", "soc_ref",
                 "bt_budget", "bt_travel", "rc_travel", "kappa", "driven"):
        setattr(s, name, np.zeros(n))
    for name in ("avoiding", "was_avoiding", "visited_r", "immediate", "search", "decided", "voided", "moved",
                 "loaded_now", "no_r_guidance"):
        setattr(s, name, np.zeros(n, dtype=np.bool_))
    for name in ("omega", "bvx", "bvy", "bsoc", "weight", "acc", "s_hat"):
        setattr(s, name, np.zeros((n, 3)))
    s.binit = np.zeros((n, 3), dtype=np.bool_)
    for name in ("idelta", "ivx", "ivy", "iu", "d2"):
        setattr(s, name, np.zeros((n, n)))
    s.ikey = np.full((n, n), -1, dtype=np.int64)
    s.nb_list = np.zeros((n, n), dtype=np.int64)
    s.close = np.zeros((n, n), dtype=np.int64)
    s.sup = np.full((n, 1), opts[k.O_INIT_STATE], dtype=np.int64)
    s.status[:], s.role[:], s.role_k1[:], s.role_k2[:], s.mode[:] = k.UNSPAWNED, k.R, k.R, k.R, k.NORMAL
    s.x[:], s.y[:] = g[k.G_SPAWN], g[k.G_SPAWN + 1]
    s.pcx[:], s.mdx[:], s.kappa[:] = 1.0, 1.0, 1.0
    s.energy[:] = pars[k.P_SOC0] * pars[k.P_ECAP]
    s.soc_ref[:] = pars[k.P_SOC0]
    s.s_c[:], s.reg[:], s.last_left[:], s.nearest[:] = k.F_IN, k.REG_N, k.NO_REGION, -1
    s.hits = np.empty(k.N_RAYS)
    s.counts = np.zeros(8, dtype=np.int64)
    s.row_counts = np.zeros(k.ROW_D, dtype=np.int64)
    s.t_first = np.full(3, -1, dtype=np.int64)
    s.tally = np.zeros(k.N_TALLY, dtype=np.int64)
    ticks, n_rec = opts[k.O_TICKS], opts[k.O_TICKS] // opts[k.O_NT]
    s.f_hist, s.nb_hist = np.zeros(ticks + 1, dtype=np.int64), np.zeros(ticks + 1, dtype=np.int64)
    s.series = np.full((1, n_rec, k.N_SERIES), np.nan)
    s.align, s.align_w = np.empty(3), np.empty(3)
    s.trips, s.snaps = np.empty((n, k.N_TRIP)), np.empty((k.SNAPS_PER_TICK * n, k.N_SNAP))
    s.heading = (s.theta_a, s.theta, s.pcx, s.pcy, s.mdx, s.mdy)
    s.motion = (s.blocked, s.avoiding, s.was_avoiding, s.moved, s.kappa, s.driven)
    s.memory = (s.omega, s.bvx, s.bvy, s.bsoc, s.binit, s.weight)
    s.inbox = (s.ikey, s.idelta, s.ivx, s.ivy, s.iu)
    s.sensed = (s.sx, s.sy, s.d2, s.nb_cnt, s.nb_list, s.mb_cnt, s.beacons, s.links, s.s_hat, s.no_r_guidance,
                s.nearest)
    s.ledger = np.zeros((n, k.N_LEDGER))
    s.ledger[:, k.LG_DIED_K] = -1.0
    s.triggers, s.n_triggers = np.empty((n, k.N_TRIGGER)), np.zeros(1, dtype=np.int64)
    s.trip = (s.last_left, s.voided, s.tick_left, s.role_left, s.acc, s.ledger, s.triggers, s.n_triggers)
    return s


def put(s, i, x, y, role=k.F_OUT, heading=0.0, soc=0.5, beacon_was=None):
    """Robot i alive at (x, y) (its region the one there) in ``role`` (a beacon that was ``beacon_was``),
    planning and moving along ``heading``, at ``soc`` (= SOC_ref), R visited, no decision due; it was a
    beacon at k-1 and k-2, so that row 1 cannot fire."""
    s.status[i] = k.ALIVE
    if beacon_was is None:
        s.role[i], s.sup[i, 0] = role, SUP_OF[role]
    else:
        s.role[i], s.sup[i, 0] = k.B, {k.F_OUT: k.S_B_F_OUT, k.F_IN: k.S_B_F_IN, k.R: k.S_B_R}[beacon_was]
    s.x[i], s.y[i] = x, y
    s.theta_a[i] = s.theta[i] = heading
    s.pcy[i], s.pcx[i] = sincos(heading)
    s.mdy[i], s.mdx[i] = s.pcy[i], s.pcx[i]
    s.energy[i], s.soc_ref[i] = soc * s.pars[k.P_ECAP], soc
    s.reg[i], s.visited_r[i] = k.region_of(x, y, s.g), True
    s.role_k1[i] = s.role_k2[i] = k.B
    s.countdown[i] = 100


def draws(s, robot, count):
    """The next ``count`` uniforms of ``robot``'s stream, leaving ``s.rng`` as it is."""
    rng = s.rng.copy()
    return [uniform(rng, 0, robot) for _ in range(count)]


# ------------------------------------------------------------------ step 1: spawn (A33)


def test_spawn_waits_until_no_body_is_within_two_radii_of_the_spawn_point():
    s = state(3)
    spawn_x, spawn_y, r_body = s.g[k.G_SPAWN], s.g[k.G_SPAWN + 1], s.pars[k.P_RBODY]
    put(s, 0, spawn_x + 1.9 * r_body, spawn_y)
    s.energy[1] = 0.0
    assert k.spawn(s.opts, s.pars, s.g, 1, s.status, s.x, s.y, s.energy, s.soc_ref, s.search) == (1, -1)
    assert s.status[1] == k.UNSPAWNED
    s.x[0] = spawn_x + 2.01 * r_body
    assert k.spawn(s.opts, s.pars, s.g, 1, s.status, s.x, s.y, s.energy, s.soc_ref, s.search) == (2, 1)
    assert s.status[1] == k.ALIVE and s.search[1] and s.energy[1] == s.pars[k.P_SOC0] * s.pars[k.P_ECAP]
    assert s.status[2] == k.UNSPAWNED


# ------------------------------------------------------------------ step 2: sensing and messages (section 5)


def test_sense_links_robots_within_comm_radius_and_fills_the_inbox_with_their_broadcast():
    s = state(3)
    put(s, 0, N_C[0], N_C[1], role=k.F_IN, soc=0.7)       # in N, its s_c region: gamma = r
    s.reg[0], s.soc_ref[0] = k.REG_N, 0.9
    put(s, 1, N_C[0] + 1.5, N_C[1], beacon_was=k.F_OUT)
    s.omega[1] = (0.1, 0.4, 0.2)
    s.binit[1, k.R], s.bsoc[1, k.R] = True, 0.3
    put(s, 2, N_C[0] + 1.5, N_C[1] + 3.0)                  # 3 m from the beacon: out of range
    k.sense_and_communicate(s.opts, s.pars, s.g, s.box, 3, -1, s.status, s.role, s.mode, s.x, s.y, s.energy, s.s_c,
                            s.soc_ref, s.reg, s.decided, s.immediate, s.heading, s.memory, s.sensed, s.inbox)
    assert list(s.sx) == list(s.x) and list(s.sy) == list(s.y)
    assert (s.nb_cnt[0], s.nb_list[0, 0], s.nb_cnt[2]) == (1, 1, 0)
    assert list(s.links) == [1, 1, 0] and s.nearest[0] == 1
    assert list(s.s_hat[0]) == [0.0, 0.0, 0.3] and s.no_r_guidance[0]
    assert s.ikey[1, 0] == k.F_IN and s.ikey[1, 2] == -1
    assert s.idelta[1, 0] == s.pars[k.P_REWARD] + s.pars[k.P_LAMBDA] * 0.4
    assert s.iu[1, 0] == pytest.approx(0.9 - 0.7)
    assert (s.ivx[1, 0], s.ivy[1, 0]) == (-s.pars[k.P_V0], -0.0)


# ------------------------------------------------------------------ step 3: region actions, rows (sections 9, 10)


def roles(s, tick=1):
    k.roles_and_region_actions(s.opts, s.pars, s.table, tick, s.n, s.sup, s.status, s.role, s.mode, s.reg, s.load,
                               s.loaded_now, s.s_c, s.n_failed, s.role_k1, s.role_k2, s.energy, s.visited_r,
                               s.countdown, s.immediate, s.search, s.heading, s.motion, s.memory, s.inbox, s.sensed,
                               s.trip, s.row_counts, s.t_first, s.tally)


def test_a_loaded_f_in_robot_in_n_unloads_completes_n_and_turns_out_by_row_8():
    s = state(1)
    put(s, 0, N_C[0], N_C[1], role=k.F_IN, heading=0.3)
    s.reg[0], s.load[0], s.s_c[0], s.n_failed[0], s.visited_r[0] = k.REG_N, s.opts[k.O_RMAX], k.F_OUT, 2, True
    roles(s)
    assert (s.tally[k.TL_RESOURCES], s.tally[k.TL_UNLOADS], s.load[0]) == (s.opts[k.O_RMAX], 1, 0)
    assert (s.s_c[0], s.n_failed[0]) == (k.F_IN, 0)
    assert (s.role[0], s.sup[0, 0], s.row_counts[8 - 1]) == (k.F_OUT, k.S_F_OUT, 1)
    assert s.theta_a[0] == s.theta[0] == k.wrap(0.3 + PI)


def test_a_robot_without_beacons_outside_n_becomes_a_beacon_by_row_1():
    s = state(1)
    put(s, 0, *FREE, role=k.F_OUT)
    s.reg[0], s.role_k1[0], s.role_k2[0], s.avoiding[0], s.blocked[0] = k.NO_REGION, k.F_OUT, k.F_OUT, True, 3
    s.omega[0] = (1.0, 1.0, 1.0)
    roles(s)
    assert (s.role[0], s.sup[0, 0], s.countdown[0], s.row_counts[0]) == (k.B, k.S_B_F_OUT, s.opts[k.O_NT], 1)
    assert list(s.omega[0]) == [0.0, 0.0, 0.0] and not s.avoiding[0] and s.blocked[0] == 0
    assert s.theta_a[0] == 0.0                             # row 1 does not turn


# ------------------------------------------------------------------ step 4: heading decisions (7.1, 7.3)


def test_row_2_records_the_soc_the_costs_it_compared_with_and_where_the_robot_was():
    s = state(2)
    put(s, 0, *FREE, role=k.F_OUT, soc=0.2)
    put(s, 1, FREE[0] + 1.0, FREE[1], role=k.F_IN, soc=0.5)
    s.sx[:], s.sy[:] = s.x, s.y
    s.nb_cnt[:] = 1
    s.s_hat[0] = (0.1, 0.0, 0.25)                  # SOC 0.2 < S_hat^R = 0.25: row 2
    s.s_hat[1] = (0.3, 0.4, 0.45)                  # SOC 0.5 above both: no row 2
    roles(s, tick=40)
    assert (s.role[0], s.role[1], s.row_counts[1], s.n_triggers[0]) == (k.R, k.F_IN, 1, 1)
    soc = s.energy[0] / s.pars[k.P_ECAP]
    assert list(s.triggers[0, k.TG_ROBOT:]) == [0, 40, k.F_OUT, soc, 0.1, 0.25, FREE[0], FREE[1]]


def test_the_ledger_counts_each_robots_unloads_loads_and_charging_sessions():
    s = state(3)
    put(s, 0, *N_C, role=k.F_IN)
    s.load[0] = 3
    put(s, 1, *T_C, role=k.F_OUT)
    put(s, 2, *R_C, role=k.R)
    roles(s)
    assert (s.mode[2], s.row_counts[3]) == (k.CHARGING, 1)
    counts = s.ledger[:, [k.LG_UNLOADS, k.LG_LOADS, k.LG_RECHARGES]]
    assert counts.tolist() == [[1, 0, 0], [0, 1, 0], [0, 0, 1]] and s.n_triggers[0] == 0


def decide(s):
    k.heading_decisions(s.opts, s.pars, s.rng, s.n, s.status, s.role, s.mode, s.n_failed, s.bt_budget, s.bt_travel,
                        s.immediate, s.countdown, s.search, s.s_c, s.visited_r, s.decided, s.heading, s.memory,
                        s.sensed, s.motion)


def test_a_due_robot_follows_the_guidance_of_its_role_with_two_draws_and_restarts_its_countdown():
    s = state(3)
    s.pars[k.P_EPS] = 0.0                                  # always follow
    put(s, 0, *FREE, role=k.F_OUT)
    s.countdown[0] = 0
    put(s, 1, FREE[0] + 1.0, FREE[1], beacon_was=k.F_OUT)
    s.weight[1, k.F_OUT], s.bvy[1, k.F_OUT] = 2.0, 1.0       # G^F_OUT = (0, 2)
    s.nb_cnt[0], s.nb_list[0, 0] = 1, 1
    put(s, 2, FREE[0], FREE[1] + 1.0, heading=0.5)
    s.countdown[2] = 5
    after_two = s.rng.copy()
    uniform(after_two, 0, 0), uniform(after_two, 0, 0)
    untouched = s.rng[0, 2].copy()
    decide(s)
    assert s.theta_a[0] == s.theta[0] == atan2(2.0, 0.0) and s.decided[0]
    assert s.countdown[0] == s.opts[k.O_NT] - 1
    assert np.array_equal(s.rng[0, 0], after_two[0, 0])
    assert (s.countdown[2], s.theta_a[2], s.decided[2]) == (4, 0.5, False)
    assert np.array_equal(s.rng[0, 2], untouched)


@pytest.mark.parametrize("model", ["full", "baseline"])
def test_an_f_in_robot_without_f_in_guidance_follows_the_r_key_only_in_the_full_model(model):
    # Eq 5-16's F_IN -> R fallback; the Ch 4 baseline has no R key (Eq 4-11): a random search
    s = state(2, model=model)
    s.pars[k.P_EPS] = 0.0                                  # always follow when there is guidance
    put(s, 0, *FREE, role=k.F_IN)
    s.countdown[0] = 0
    put(s, 1, FREE[0] + 1.0, FREE[1], beacon_was=k.F_OUT)
    s.weight[1, k.R], s.bvy[1, k.R] = 1.0, 1.0             # G^R points north, no G^F_IN
    s.nb_cnt[0], s.nb_list[0, 0] = 1, 1
    decide(s)
    assert s.decided[0] and (s.theta_a[0] == atan2(1.0, 0.0)) == (model == "full")


def test_a_reconnecting_robot_in_contact_backtracks_with_budget_n_failed_half_comm():
    s = state(2)
    put(s, 0, *FREE, role=k.F_IN)
    s.mode[0], s.n_failed[0], s.s_c[0] = k.RECONNECT, 3, k.F_IN
    put(s, 1, FREE[0] + 1.0, FREE[1], beacon_was=k.F_OUT)
    s.weight[1, k.F_IN], s.bvx[1, k.F_IN] = 1.0, -1.0        # G^s_c points west
    s.nb_cnt[0], s.nb_list[0, 0] = 1, 1
    decide(s)
    assert (s.mode[0], s.bt_budget[0], s.bt_travel[0]) == (k.BACKTRACK, 3 * 0.5 * s.pars[k.P_COMM_R], 0.0)
    assert s.decided[0] and not s.immediate[0]


# ------------------------------------------------------------------ step 5: avoidance (7.4), translation (7.5)


def test_avoidance_turns_the_motion_heading_abeam_of_a_wall_ahead_and_keeps_the_plan():
    s = state(1)
    wall_x, r_body = s.g[k.G_W], s.pars[k.P_RBODY]
    put(s, 0, wall_x - r_body - 0.01, 0.3, heading=0.0)   # the floor shortens the right rays: turn left
    k.avoidance(s.opts, s.pars, s.g, s.box, s.ray_c, s.ray_s, 1, -1, s.status, s.role, s.mode, s.x, s.y, s.immediate,
                s.heading, s.motion, s.sensed, s.hits, s.close, s.n_near)
    assert s.avoiding[0] and s.hits[0] == pytest.approx(r_body + 0.01)
    assert s.theta[0] == k.HALF_PI and s.theta_a[0] == 0.0    # the nearest hit is straight ahead
    assert (s.mdy[0], s.mdx[0]) == sincos(k.HALF_PI) and (s.pcx[0], s.pcy[0]) == (1.0, 0.0)


def translate(s):
    k.translation(s.opts, s.pars, s.g, s.box, s.rng, s.n, s.status, s.role, s.mode, s.x, s.y, s.immediate, s.search,
                  s.rc_travel, s.bt_travel, s.bt_budget, s.heading, s.motion, s.sensed, s.trip, s.close, s.n_near)


def test_translation_steps_v0_tau_and_stops_at_a_wall_until_the_blocked_turn():
    s = state(2)
    step, wall_x, r_body = s.pars[k.P_V0] * s.pars[k.P_TAU], s.g[k.G_W], s.pars[k.P_RBODY]
    put(s, 0, *FREE)
    put(s, 1, wall_x - r_body - step / 2, 8.0, heading=0.0)
    s.blocked[1] = s.opts[k.O_BLOCKED] - 2
    translate(s)
    assert (s.x[0], s.y[0], s.moved[0], s.acc[0, 0]) == (FREE[0] + step, FREE[1], True, step)
    assert (s.x[1], s.moved[1], s.blocked[1]) == (wall_x - r_body - step / 2, False, s.opts[k.O_BLOCKED] - 1)
    assert list(s.ledger[:, k.LG_MOVES]) == [1.0, 0.0]          # the ticks each robot moved (section 19)
    (u,) = draws(s, 1, 1)
    translate(s)
    assert s.x[1] == wall_x - r_body - step / 2 and s.blocked[1] == 0
    assert s.theta_a[1] == s.theta[1] == k.wrap(0.0 + (2.0 * u - 1.0) * PI)


def test_translation_checks_bodies_at_the_positions_already_updated_this_tick():
    s = state(3)
    step, r_body = s.pars[k.P_V0] * s.pars[k.P_TAU], s.pars[k.P_RBODY]
    put(s, 0, FREE[0] + 2 * r_body + step / 2, FREE[1])   # ahead of 1 and first to move (A29): 1 can follow
    put(s, 1, *FREE)
    put(s, 2, FREE[0], FREE[1] - 2 * r_body - step / 2, heading=PI / 2)   # steps into 1: blocked
    s.d2[:] = (s.x[:, None] - s.x[None, :]) ** 2 + (s.y[:, None] - s.y[None, :]) ** 2
    s.n_near[:] = 2
    s.close[0, :2], s.close[1, :2], s.close[2, :2] = (1, 2), (0, 2), (0, 1)
    translate(s)
    assert s.moved[0] and s.x[0] == FREE[0] + 2 * r_body + step / 2 + step
    assert s.moved[1] and s.x[1] == FREE[0] + step
    assert not s.moved[2] and s.blocked[2] == 1


# ------------------------------------------------------------------ step 6: energy (section 8)


def energy(s, spawned):
    k.energy_and_deaths(s.opts, s.pars, s.g, s.table, spawned, s.sup, s.status, s.role, s.x, s.y, s.here,
                        s.loaded_now, s.energy, s.motion, s.sensed, s.trip, s.tally)


def test_energy_drains_by_p_out_tau_gains_p_solar_in_r_and_dies_at_zero():
    s = state(3)
    p, tau, e_cap = s.pars, s.pars[k.P_TAU], s.pars[k.P_ECAP]
    put(s, 0, *FREE, soc=0.5)
    s.links[0], s.moved[0] = 2, True
    put(s, 1, R_C[0], R_C[1], beacon_was=k.R, soc=0.5)
    put(s, 2, *T_C, soc=0.0)
    s.energy[2] = 1e-9
    energy(s, 3)
    p_out = p[k.P_COMP] + p[k.P_COMM] * 2 + p[k.P_SCAN] + p[k.P_MOVE] * 1.0
    assert s.energy[0] == 0.5 * e_cap + (0.0 - p_out) * tau and s.acc[0, 1] == p_out * tau
    assert s.energy[1] == 0.5 * e_cap + (p[k.P_SOLAR] - p[k.P_COMP]) * tau
    assert list(s.here) == [k.NO_REGION, k.REG_R, k.REG_T]
    assert (s.status[2], s.sup[2, 0], s.tally[k.TL_DEATHS], s.tally[k.TL_DEPLETIONS]) == (k.DEAD, k.S_DEAD, 1, 1)


def test_energy_adds_each_robots_energy_and_tick_in_its_role_to_its_ledger_and_the_tick_it_died():
    s = state(2)
    put(s, 0, *FREE, role=k.F_IN, soc=0.5)
    s.moved[0] = True
    put(s, 1, *T_C, beacon_was=k.R, soc=0.0)
    s.energy[1] = 1e-9
    s.tally[k.TL_TICK] = 57
    energy(s, 2)
    used = s.acc[0, 1]
    s.tally[k.TL_TICK] = 58
    energy(s, 2)
    ticks_0, ticks_1 = (list(s.ledger[i, k.LG_TICKS:k.LG_TICKS + 4]) for i in (0, 1))
    assert ticks_0 == [0.0, 2.0, 0.0, 0.0] and ticks_1 == [0.0, 0.0, 0.0, 1.0]   # F_OUT, F_IN, R, B
    assert s.ledger[0, k.LG_ENERGY] == s.acc[0, 1] and s.acc[0, 1] > used > 0.0   # the trip's, from the same ticks
    assert (s.status[1], s.ledger[1, k.LG_DIED_K], s.ledger[0, k.LG_DIED_K]) == (k.DEAD, 57.0, -1.0)


# ------------------------------------------------------------------ step 7: bookkeeping, trips (sections 10, 12)


def test_bookkeeping_records_the_trip_of_a_robot_entering_another_region_than_it_left():
    s = state(2)
    put(s, 0, *N_C, role=k.F_IN, soc=0.4)
    s.reg[0], s.here[0], s.s_c[0] = k.NO_REGION, k.REG_N, k.F_IN
    s.last_left[0], s.tick_left[0], s.role_left[0], s.acc[0] = k.REG_T, 10, k.F_OUT, (3.0, 50.0, 1.0)
    put(s, 1, *T_C)
    s.reg[1], s.here[1] = k.NO_REGION, k.REG_T
    n_trips = k.bookkeeping(s.pars, 40, 9, 2, s.status, s.role, s.s_c, s.energy, s.here, s.reg, s.soc_ref,
                            s.visited_r, s.trip, s.trips, 0, s.t_first, s.tally)
    assert n_trips == 1
    assert list(s.trips[0]) == [9, k.REG_T, k.REG_N, 10, 40, 3.0, 50.0, 1.0, k.F_OUT, k.F_IN, 0]
    assert list(s.reg) == [k.REG_N, k.REG_T] and s.soc_ref[0] == 0.4
    assert s.t_first[0] == 40 and s.tally[k.TL_MILESTONES] == 1 << k.LABEL_FIRST_T


# ------------------------------------------------------------------ step 8: beacon windows (section 6)


def windows(s):
    k.beacon_windows(s.opts, s.pars, s.table, s.n, s.sup, s.status, s.role, s.mode, s.countdown, s.n_failed,
                     s.rc_travel, s.heading, s.memory, s.inbox, s.row_counts)


def test_a_new_beacons_first_window_closes_at_k_plus_n_t_minus_1():
    s = state(2)
    n_t, rho_w = s.opts[k.O_NT], s.pars[k.P_RHO_W]
    put(s, 0, *FREE)
    put(s, 1, FREE[0] + 1.0, FREE[1], role=k.F_OUT)
    s.reg[1], s.role_k1[1], s.role_k2[1] = k.NO_REGION, k.F_OUT, k.F_OUT
    roles(s, tick=1)                                       # robot 1 becomes a beacon at tick k = 1 (row 1)
    assert s.role[1] == k.B and s.countdown[1] == n_t
    s.ikey[1, 0], s.idelta[1, 0] = k.F_OUT, 2.0
    for _ in range(n_t - 1):                               # step 8 of ticks 1 .. n_T - 1
        windows(s)
    assert s.omega[1, k.F_OUT] == 0.0 and s.ikey[1, 0] == k.F_OUT and s.countdown[1] == 1
    windows(s)                                             # tick n_T = k + n_T - 1
    assert s.omega[1, k.F_OUT] == rho_w * 2.0 and s.ikey[1, 0] == -1 and s.countdown[1] == n_t


def test_a_silent_beacon_below_eta_w_reverts_to_its_former_role_in_reconnect():
    s = state(1)
    put(s, 0, *FREE, heading=0.2, beacon_was=k.F_IN)
    s.omega[0, k.F_IN], s.countdown[0], s.n_failed[0], s.rc_travel[0] = s.pars[k.P_ETA_W] / 2, 1, 1, 5.0
    windows(s)
    assert (s.role[0], s.sup[0, 0], s.mode[0], s.n_failed[0], s.rc_travel[0]) == (k.F_IN, k.S_F_IN, k.RECONNECT,
                                                                                   2, 0.0)
    assert list(s.omega[0]) == [0.0, 0.0, 0.0] and s.row_counts[k.ROW_D - 1] == 1
    assert s.theta_a[0] == s.theta[0] == k.wrap(0.2 + PI)


# ------------------------------------------------------------------ step 9: records (section 12)


def record(s, tick):
    return k.records(s.opts, s.pars, s.g, tick, 0, 0, s.n, s.status, s.role, s.role_k1, s.role_k2, s.mode, s.x, s.y,
                     s.energy, s.load, s.heading, s.memory, s.row_counts, s.f_hist, s.nb_hist, s.series, s.align,
                     s.align_w, s.counts, s.tally, s.snaps, 0)


def test_records_shift_the_role_history_and_write_the_series_every_n_t_ticks():
    s = state(2)
    n_t = s.opts[k.O_NT]
    put(s, 0, *FREE, role=k.F_IN)
    s.role_k1[0], s.role_k2[0] = k.R, k.F_OUT
    put(s, 1, *T_C, beacon_was=k.F_OUT)
    s.tally[k.TL_RESOURCES] = 12
    assert record(s, n_t - 1) == 0
    assert (s.role_k1[0], s.role_k2[0]) == (k.F_IN, k.R) and (s.f_hist[n_t - 1], s.nb_hist[n_t - 1]) == (12, 1)
    assert np.isnan(s.series[0, 0, k.TS_K])
    record(s, n_t)
    row = s.series[0, 0]
    assert (row[k.TS_K], row[k.TS_RESOURCES], row[k.TS_MOBILE], row[k.TS_BEACONS], row[k.TS_F_IN]) == (n_t, 12, 1, 1, 1)


# ------------------------------------------------------------------ the tick loop


def ticks(s, first, n_trips):
    return k.run_ticks(s.opts, s.pars, s.g, s.box, s.ray_c, s.ray_s, s.table, np.zeros(1, np.int8), s.rng, 0, 0, first,
                       0, s.status, s.sup, s.role, s.mode, s.role_k1, s.role_k2, s.x, s.y, s.energy, s.load, s.s_c,
                       s.soc_ref, s.visited_r, s.n_failed, s.bt_budget, s.bt_travel, s.rc_travel, s.countdown,
                       s.immediate, s.search, s.decided, s.reg, s.loaded_now, s.here, s.heading, s.motion, s.memory,
                       s.inbox, s.sensed, s.trip, s.hits, s.close, s.n_near, s.counts, s.row_counts, s.t_first, s.tally,
                       s.f_hist, s.nb_hist, s.series, s.align, s.align_w, s.trips, n_trips, s.snaps, 0)


def test_the_tick_loop_stops_before_a_tick_without_room_for_a_trip_or_a_row_2_trigger_per_robot():
    s = state(2, duration_s=0.64)
    assert ticks(s, 3, 1) == (3, 0, 1, 0) and s.status[0] == k.UNSPAWNED    # 1 + 2 robots > 2 rows
    s.n_triggers[0] = 1
    assert ticks(s, 3, 0) == (3, 0, 0, 0) and s.status[0] == k.UNSPAWNED    # the same for the triggers
    s.n_triggers[0] = 0
    end = ticks(s, 3, 0)                                   # ticks 3 .. K; the end snapshot (a row per robot)
    assert (end[0], end[2], end[3]) == (s.opts[k.O_TICKS] + 1, 0, 2) and s.status[0] == k.ALIVE


# ------------------------------------------------------------------ the readings of the second review (section 21)


def test_decision_step_m_makes_a_robot_decide_when_it_has_driven_that_far_since_its_last_decision():
    step_m = 0.5
    s = state(2, decision_step_m=step_m)
    step = s.pars[k.P_V0] * s.pars[k.P_TAU]
    put(s, 0, *FREE)
    s.driven[0] = step_m - step / 2               # this tick's step reaches the decision step
    put(s, 1, FREE[0], FREE[1] + 1.0)
    s.driven[1] = step_m - 1.5 * step             # one step short
    translate(s)
    assert s.moved[0] and s.immediate[0] and s.driven[0] == step_m + step / 2
    assert s.moved[1] and not s.immediate[1]
    decide(s)                                     # countdowns at 100: only robot 0 decides
    assert s.decided[0] and s.driven[0] == 0.0 and not s.immediate[0]
    assert not s.decided[1] and s.driven[1] == step_m - 0.5 * step


def test_without_decision_step_m_driving_takes_no_decision():
    s = state(1)
    put(s, 0, *FREE)
    s.driven[0] = 100.0
    translate(s)
    assert s.moved[0] and not s.immediate[0] and s.driven[0] == 100.0


def test_energy_scale_multiplies_every_consumption_term_and_not_the_solar_input():
    base, scaled = state(2), state(2, energy_scale=2.0)
    assert np.array_equal(base.pars, kernel_inputs(LunarParams(n_robots=2, energy_scale=1.0))[1])
    for s in (base, scaled):
        put(s, 0, *FREE, soc=0.5)
        s.links[0], s.moved[0], s.avoiding[0], s.loaded_now[0] = 2, True, True, True
        put(s, 1, R_C[0], R_C[1], beacon_was=k.R, soc=0.5)
        energy(s, 2)
    half = 0.5 * base.pars[k.P_ECAP]
    assert half - scaled.energy[0] == 2.0 * (half - base.energy[0]) > 0.0
    assert scaled.acc[0, 1] == 2.0 * base.acc[0, 1]
    solar, comp, tau = base.pars[k.P_SOLAR], base.pars[k.P_COMP], base.pars[k.P_TAU]
    assert (scaled.pars[k.P_SOLAR], scaled.energy[1]) == (solar, half + (solar - 2.0 * comp) * tau)


def test_depletion_recorded_keeps_a_robot_at_soc_0_alive_sends_a_forager_to_r_and_counts_each_depletion():
    s = state(3, depletion="recorded")
    put(s, 0, *FREE, role=k.F_OUT)
    s.energy[0], s.moved[0] = 1e-9, True                     # reaches 0 this tick
    put(s, 1, *FREE, role=k.R)
    s.energy[1] = 0.0                                        # already at 0: no new depletion
    put(s, 2, *T_C, beacon_was=k.F_IN)
    s.energy[2] = 1e-9
    energy(s, 3)
    assert list(s.energy) == [0.0, 0.0, 0.0] and list(s.status) == [k.ALIVE] * 3
    assert (s.role[0], s.sup[0, 0]) == (k.R, k.S_R)
    assert (s.role[2], s.sup[2, 0]) == (k.B, k.S_B_F_IN)      # a beacon stays a beacon
    assert (s.tally[k.TL_DEPLETIONS], s.tally[k.TL_DEATHS]) == (2, 0)


def test_experience_leaving_takes_only_the_messages_of_robots_moving_away_from_region_s_c():
    heard = {}
    for experience in ("any", "leaving"):
        s = state(3, experience=experience)
        put(s, 0, 4.0, N_C[1], role=k.F_OUT, heading=0.0)   # east of N, heading east: leaves N
        put(s, 1, 4.5, N_C[1] + 1.0, beacon_was=k.F_OUT)
        put(s, 2, 5.0, N_C[1], role=k.F_OUT, heading=PI)    # heading west: back towards N
        s.s_c[0] = s.s_c[2] = k.F_IN
        k.sense_and_communicate(s.opts, s.pars, s.g, s.box, 3, -1, s.status, s.role, s.mode, s.x, s.y, s.energy,
                                s.s_c, s.soc_ref, s.reg, s.decided, s.immediate, s.heading, s.memory, s.sensed,
                                s.inbox)
        assert list(s.nb_cnt[[0, 2]]) == [1, 1]
        heard[experience] = list(s.ikey[1, [0, 2]])
    assert heard == {"any": [k.F_IN, k.F_IN], "leaving": [k.F_IN, -1]}
