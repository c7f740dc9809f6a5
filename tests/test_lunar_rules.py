"""Rules of the lunar model (spec LUNAR-FORAGING.md sections 5-12), each pinned on a situation built
by hand: the kernel's small compiled functions are called with plain arrays, so every precondition
is in the input, never in a trajectory that happens to produce it."""

import math

import numpy as np
import pytest

from dronefleet.lunar import kernel as k
from dronefleet.lunar.layout import build, kernel_geometry
from dronefleet.lunar.params import LunarParams
from dronefleet.lunar.simulate import EVENTS, ROLES_FILE, kernel_inputs, role_table, simulate
from dronefleet.supervisor import load_supervisor

PI = math.pi


# ------------------------------------------------------------------ the role supervisor (section 9)

STATES = {"F_OUT": k.S_F_OUT, "F_IN": k.S_F_IN, "R": k.S_R, "R_CHARGING": k.S_R_CHARGING,
          "B_F_OUT": k.S_B_F_OUT, "B_F_IN": k.S_B_F_IN, "B_R": k.S_B_R, "DEAD": k.S_DEAD}
# Every row of the section-9 table: (row, event, from state, to state).
ROWS = [
    (1, "becomeBeacon", "F_OUT", "B_F_OUT"), (1, "becomeBeacon", "F_IN", "B_F_IN"),
    (1, "becomeBeacon", "R", "B_R"), (1, "becomeBeacon", "R_CHARGING", "B_R"),
    (2, "goCharge", "F_OUT", "R"), (2, "goCharge", "F_IN", "R"),
    (3, "goCharge", "F_OUT", "R"), (3, "goCharge", "F_IN", "R"), (3, "goCharge", "R", "R"),
    (4, "charge", "R", "R_CHARGING"),
    (5, "goIn", "R_CHARGING", "F_IN"), (6, "goOut", "R_CHARGING", "F_OUT"), (7, "goIn", "R_CHARGING", "F_IN"),
    (8, "goOut", "F_IN", "F_OUT"), (9, "goOut", "R", "F_OUT"), (10, "goIn", "F_OUT", "F_IN"),
    (11, "goIn", "R", "F_IN"),
    ("D", "revert", "B_F_OUT", "F_OUT"), ("D", "revert", "B_F_IN", "F_IN"), ("D", "revert", "B_R", "R"),
] + [("X", "depleted", state, "DEAD") for state in ("F_OUT", "F_IN", "R", "R_CHARGING", "B_F_OUT", "B_F_IN", "B_R")]
CONTROLLABLE = ("becomeBeacon", "goCharge", "charge", "goOut", "goIn", "load", "unload", "revert", "turnAround",
                "follow", "randomTurn", "avoid")
UNCONTROLLABLE = ("noBeacon", "socLowDest", "socLowR", "atNest", "atTarget", "atRecharge", "neverCharged", "full",
                  "noRGuidance", "loaded", "socOkOut", "socOkIn", "decay", "depleted", "updateDue", "obstacle",
                  "contact", "backtrackDone")


def test_roles_file_loads_with_the_section_9_events():
    automaton = load_supervisor(ROLES_FILE)
    assert set(automaton.events) == set(CONTROLLABLE) | set(UNCONTROLLABLE)
    for name in CONTROLLABLE:
        assert automaton.controllable[automaton.event_index(name)], name
    for name in UNCONTROLLABLE:
        assert not automaton.controllable[automaton.event_index(name)], name
    assert automaton.init_state[0] == k.S_R          # spawned robots are R (Alg 4 l.1)
    assert role_table()[1] == k.S_R


@pytest.mark.parametrize("row, event, source, target", ROWS)
def test_every_row_is_a_transition_of_the_roles_file(row, event, source, target):
    automaton = load_supervisor(ROLES_FILE)
    assert automaton.transitions[0][(STATES[source], automaton.event_index(event))] == STATES[target]
    # the kernel fires the row through the same event, on the same table
    table = automaton.transition_table(EVENTS)
    if isinstance(row, int):
        assert EVENTS[k.ROW_EVENT[row]] == event
    states = np.array([[STATES[source]]], dtype=np.int64)
    assert k.take(table, states, 0, EVENTS.index(event))
    assert states[0, 0] == STATES[target]


def test_role_is_the_supervisor_state_and_forbidden_events_do_not_fire():
    table, _ = role_table()
    assert [k.ROLE_OF_STATE[STATES[s]] for s in ("F_OUT", "F_IN", "R", "R_CHARGING", "B_F_OUT", "B_F_IN", "B_R")] \
        == [k.F_OUT, k.F_IN, k.R, k.R, k.B, k.B, k.B]
    for state, event in (("F_OUT", "charge"), ("B_F_IN", "goOut"), ("DEAD", "revert"), ("F_IN", "revert"),
                         ("DEAD", "depleted"), ("B_R", "becomeBeacon"), ("R_CHARGING", "goCharge")):
        states = np.array([[STATES[state]]], dtype=np.int64)
        assert not k.take(table, states, 0, EVENTS.index(event)), (state, event)
        assert states[0, 0] == STATES[state]


def situation(**changes):
    """Inputs of choose_row: a mobile robot outside every region, one beacon in range, SOC 0.5,
    no cost known, R visited, not full, empty, R guidance present; ``changes`` override."""
    s = dict(role=k.F_OUT, mode=k.NORMAL, region=k.NO_REGION, n_in_range=1, role_k1=k.F_OUT, role_k2=k.F_OUT,
             soc=0.5, s_hat=np.zeros(3), visited_r=True, full=False, loaded=False, no_r_guidance=False)
    s.update(changes)
    if not isinstance(s["s_hat"], np.ndarray):
        s["s_hat"] = np.array(s["s_hat"], dtype=np.float64)
    return s


STATE_OF = {(k.F_OUT, k.NORMAL): "F_OUT", (k.F_IN, k.NORMAL): "F_IN", (k.R, k.NORMAL): "R",
            (k.R, k.BACKTRACK): "R", (k.F_OUT, k.RECONNECT): "F_OUT", (k.R, k.CHARGING): "R_CHARGING"}
CASES = [
    # (situation, row, state after the row's event)
    (situation(n_in_range=0), 1, "B_F_OUT"),
    (situation(role=k.R, mode=k.CHARGING, region=k.REG_R, n_in_range=0, role_k1=k.R, role_k2=k.R), 1, "B_R"),
    (situation(n_in_range=0, region=k.REG_N), 0, None),                          # A19: never in N
    (situation(n_in_range=0, mode=k.RECONNECT), 0, None),                        # A19: never in RECONNECT
    (situation(n_in_range=0, role_k2=k.B), 0, None),                             # A3: two mobile ticks
    (situation(soc=0.2, s_hat=[0.3, 0.0, 0.0]), 2, "R"),                         # SOC < S_hat^{role}
    (situation(role=k.F_IN, role_k1=k.F_IN, soc=0.2, s_hat=[0.0, 0.0, 0.25]), 2, "R"),   # SOC < S_hat^R
    (situation(role=k.R, soc=0.2, s_hat=[0.3, 0.3, 0.3]), 0, None),              # rows 2-3 not for R outside N
    (situation(role=k.F_IN, region=k.REG_N, visited_r=False), 3, "R"),
    (situation(role=k.R, region=k.REG_N, visited_r=False), 3, "R"),               # a no-op that blocks row 9
    (situation(role=k.R, region=k.REG_R), 4, "R_CHARGING"),
    (situation(role=k.R, mode=k.BACKTRACK, region=k.REG_R), 4, "R_CHARGING"),
    (situation(role=k.R, mode=k.CHARGING, region=k.REG_R, full=True, no_r_guidance=True, loaded=True), 5, "F_IN"),
    (situation(role=k.R, mode=k.CHARGING, region=k.REG_R, full=True), 6, "F_OUT"),
    (situation(role=k.R, mode=k.CHARGING, region=k.REG_R, full=True, loaded=True), 7, "F_IN"),
    (situation(role=k.R, mode=k.CHARGING, region=k.REG_R, full=False), 0, None),  # charges to exactly E_cap
    (situation(role=k.F_IN, region=k.REG_N), 8, "F_OUT"),
    (situation(role=k.R, region=k.REG_N), 9, "F_OUT"),
    (situation(role=k.R, region=k.REG_N, soc=0.3, s_hat=[0.3, 0.0, 0.0]), 0, None),   # needs SOC > S_hat^F_OUT
    (situation(role=k.F_OUT, region=k.REG_T), 10, "F_IN"),
    (situation(role=k.R, region=k.REG_T), 11, "F_IN"),
    (situation(role=k.R, region=k.REG_T, soc=0.3, s_hat=[0.0, 0.0, 0.4]), 0, None),   # needs SOC > S_hat^R
    (situation(role=k.F_OUT, region=k.REG_N), 0, None),                           # F_OUT in N: nothing
]


@pytest.mark.parametrize("case, row, after", CASES)
def test_role_transition_rows_in_tiny_situations(case, row, after):
    assert k.choose_row(**case) == row
    if row:
        table, _ = role_table()
        states = np.array([[STATES[STATE_OF[(case["role"], case["mode"])]]]], dtype=np.int64)
        assert k.take(table, states, 0, k.ROW_EVENT[row])
        assert states[0, 0] == STATES[after]


def test_first_matching_row_wins():
    # out of range AND low SOC: row 1 (becomes a beacon), not row 2
    assert k.choose_row(**situation(n_in_range=0, soc=0.1, s_hat=[0.5, 0.5, 0.5])) == 1
    # low SOC at T: row 2 before row 10
    assert k.choose_row(**situation(region=k.REG_T, soc=0.1, s_hat=[0.5, 0.0, 0.0])) == 2
    # no R guidance is tested before the load (A15): row 5 even when loaded
    assert k.choose_row(**situation(role=k.R, mode=k.CHARGING, region=k.REG_R, full=True, loaded=True,
                                    no_r_guidance=True)) == 5


# ------------------------------------------------------------------ beacon knowledge (section 6)

RHO = dict(rho_w=0.1, rho_v=0.1, rho_p=0.1, phi_soc=1.25, eta_w=1e-4)


def memory(omega=(0.0, 0.0, 0.0), v=((0.0, 0.0),) * 3, soc=(0.0, 0.0, 0.0), init=(False, False, False)):
    v = np.array(v, dtype=np.float64)
    return (np.array(omega, dtype=np.float64), v[:, 0].copy(), v[:, 1].copy(), np.array(soc, dtype=np.float64),
            np.array(init, dtype=np.bool_))


def inbox(messages, robots=5):
    """Inbox arrays (robots,) from {robot: (key, Delta, -v_m x, -v_m y, u)}."""
    key = np.full(robots, -1, dtype=np.int64)
    delta, mx, my, used = (np.zeros(robots) for _ in range(4))
    for j, (x, d, vx, vy, u) in messages.items():
        key[j], delta[j], mx[j], my[j], used[j] = x, d, vx, vy, u
    return key, delta, mx, my, used


def test_beacon_update_from_passing_robots():
    omega, vx, vy, soc, init = memory(omega=(0.5, 0.4, 0.0), v=((1.0, 0.0), (0.0, 2.0), (0.0, 0.0)),
                                      soc=(0.2, 0.3, 0.0), init=(True, True, False))
    # robots 0 and 3 last completed T (key F_OUT), robot 1 R; nobody reports key F_IN
    key, delta, mx, my, used = inbox({0: (k.F_OUT, 1.0, -1.25, 0.0, 0.04), 3: (k.F_OUT, 0.6, 0.0, -1.25, 0.08),
                                      1: (k.R, 0.8, 1.25, 0.0, 0.5)})
    assert not k.beacon_update(omega, vx, vy, soc, init, key, delta, mx, my, used, **RHO)
    # key F_OUT: smoothed with rho_w, rho_v over the mean message; S smoothed with rho_p
    assert omega[k.F_OUT] == pytest.approx(0.9 * 0.5 + 0.1 * 0.8)
    assert (vx[k.F_OUT], vy[k.F_OUT]) == pytest.approx((0.9 * 1.0 + 0.1 * -0.625, 0.1 * -0.625))
    assert soc[k.F_OUT] == pytest.approx(0.9 * 0.2 + 0.1 * 1.25 * 0.06)
    # key F_IN: no message, only the weight evaporates (A21)
    assert omega[k.F_IN] == pytest.approx(0.9 * 0.4)
    assert (vx[k.F_IN], vy[k.F_IN], soc[k.F_IN]) == (0.0, 2.0, 0.3)
    # key R: first input initialises S to phi_SOC * mean u (A22)
    assert init[k.R] and soc[k.R] == pytest.approx(1.25 * 0.5)
    assert omega[k.R] == pytest.approx(0.08) and (vx[k.R], vy[k.R]) == pytest.approx((0.125, 0.0))


def test_beacon_cost_is_clipped_to_one():
    omega, vx, vy, soc, init = memory()
    key, delta, mx, my, used = inbox({2: (k.R, 0.0, 0.0, 0.0, 0.9)})
    k.beacon_update(omega, vx, vy, soc, init, key, delta, mx, my, used, **RHO)
    assert soc[k.R] == 1.0                                   # 1.25 * 0.9 > 1
    k.beacon_update(omega, vx, vy, soc, init, key, delta, mx, my, used, **RHO)
    assert soc[k.R] == 1.0                                   # 0.9 * 1 + 0.1 * 1.125 > 1


def test_beacon_decays_only_without_messages_and_below_eta_w():
    omega, vx, vy, soc, init = memory(omega=(5e-5, 0.0, 0.0), v=((1.0, 1.0), (0.0, 0.0), (0.0, 0.0)),
                                      soc=(0.4, 0.0, 0.0), init=(True, False, False))
    silent = inbox({})
    assert k.beacon_update(omega, vx, vy, soc, init, *silent, **RHO)
    assert omega[0] == pytest.approx(4.5e-5) and (vx[0], vy[0], soc[0]) == (1.0, 1.0, 0.4)
    # a message with zero potential keeps it: the window was not empty
    omega, vx, vy, soc, init = memory(omega=(5e-5, 0.0, 0.0))
    assert not k.beacon_update(omega, vx, vy, soc, init, *inbox({4: (k.F_IN, 0.0, 0.0, 0.0, 0.0)}), **RHO)
    # silent but the summed weight still at least eta_w after evaporation
    omega, vx, vy, soc, init = memory(omega=(6e-5, 6e-5, 0.0))
    assert not k.beacon_update(omega, vx, vy, soc, init, *silent, **RHO)


def test_broadcast_is_the_reversed_planned_velocity_and_motion_option_the_deflected_one():
    # planned heading +x; this tick deflected to +y by the avoidance reflex
    assert k.broadcast_velocity(False, False, 1.25, 1.0, 0.0, 0.0, 1.0) == (-1.25, -0.0)
    assert k.broadcast_velocity(False, True, 1.25, 1.0, 0.0, 0.0, 1.0) == (-0.0, -1.25)
    assert k.broadcast_velocity(True, False, 1.25, 1.0, 0.0, 0.0, 1.0) == (0.0, 0.0)     # charging: v_m = 0
    # a robot leaving T eastwards teaches "to T" = west to the beacon it passes
    mx, my = k.broadcast_velocity(False, False, 1.25, 1.0, 0.0, 1.0, 0.0)
    omega, vx, vy, soc, init = memory()
    k.beacon_update(omega, vx, vy, soc, init, *inbox({0: (k.F_OUT, 1.0, mx, my, 0.0)}), **RHO)
    assert vx[k.F_OUT] < 0.0 and vy[k.F_OUT] == 0.0


# ------------------------------------------------------------------ heading decisions (7.1)


def beacons_in_range(omega, soc, init, v, key):
    """Weight, vx, vy arrays (beacons, 3) with the given values under ``key``, the exponent form."""
    m = len(omega)
    weight, vx, vy = np.zeros((m, 3)), np.zeros((m, 3)), np.zeros((m, 3))
    for b in range(m):
        weight[b, key] = k.beacon_weight(omega[b], soc[b], init[b], 1.0, 3.0, k.W_EXPONENT)
        vx[b, key], vy[b, key] = v[b]
    return np.arange(m, dtype=np.int64), weight, vx, vy


def test_heading_decision_follows_the_weighted_sum_of_two_beacons():
    ids, weight, vx, vy = beacons_in_range([0.5, 0.2], [0.1, 0.4], [True, True], [(1.0, 0.0), (0.0, 1.0)], k.F_OUT)
    w0, w1 = 0.5 * 0.9 ** 3, 0.2 * 0.6 ** 3
    assert weight[:, k.F_OUT] == pytest.approx([w0, w1])
    gx, gy = k.guidance(ids, 2, weight, vx, vy, k.F_OUT)
    assert (gx, gy) == pytest.approx((w0, w1))
    theta, followed = k.follow_or_search(gx, gy, 0.3, 0.5, 1.0, 0.05)
    assert followed and theta == pytest.approx(math.atan2(w1, w0), abs=1e-15)
    # another key of the same beacons is empty: no guidance
    assert k.guidance(ids, 2, weight, vx, vy, k.R) == (0.0, 0.0)


def test_heading_decision_eps_and_empty_guidance_use_the_random_offset():
    theta, followed = k.follow_or_search(1.0, 1.0, 3.0, 0.01, 0.5, 0.05)      # u < eps
    assert not followed and theta == pytest.approx(3.5 - 2 * PI)
    theta, followed = k.follow_or_search(0.0, 0.0, 0.2, 0.9, -0.5, 0.05)      # |G| = 0
    assert not followed and theta == pytest.approx(-0.3)
    theta, followed = k.follow_or_search(0.0, -2.0, 0.2, 0.05, -0.5, 0.05)    # u = eps follows
    assert followed and theta == pytest.approx(-PI / 2)


def test_weight_forms():
    assert k.beacon_weight(0.5, 0.2, True, 1.0, 3.0, k.W_EXPONENT) == pytest.approx(0.5 * 0.8 ** 3)
    assert k.beacon_weight(0.5, 0.2, False, 1.0, 3.0, k.W_EXPONENT) == 0.5            # S read as 0
    assert k.beacon_weight(0.25, 0.0, True, 2.0, 3.0, k.W_EXPONENT) == pytest.approx(0.0625)
    assert k.beacon_weight(0.5, 0.2, True, 1.0, 3.0, k.W_BRACKET) == pytest.approx(0.5 * 0.4)
    assert k.beacon_weight(0.5, 0.4, True, 1.0, 3.0, k.W_BRACKET) == 0.0               # S >= 1/rho_c
    assert k.beacon_weight(0.5, 0.2, True, 1.0, 3.0, k.W_LITERAL) == pytest.approx(0.4)
    assert k.power(0.3, 1.5) == pytest.approx(0.3 ** 1.5, rel=1e-15)


# ------------------------------------------------------------------ avoidance (7.4)


def rays(**hit):
    """Hit distances by ray bearing in eighths of pi (``p1`` = +pi/8, ``m3`` = -3pi/8, ``z`` = 0)."""
    names = ("z", "p1", "m1", "p2", "m2", "p3", "m3")
    out = np.full(7, np.inf)
    for name, d in hit.items():
        out[names.index(name)] = d
    return out


@pytest.mark.parametrize("name", ["p1", "m1", "p2", "m2", "p3", "m3"])
def test_avoidance_turns_until_the_hit_is_abeam(name):
    active, offset = k.avoidance_offset(rays(**{name: 0.3}), 0.45)
    beta = k.RAY_ANGLES[("z", "p1", "m1", "p2", "m2", "p3", "m3").index(name)]
    assert active
    # the obstacle at bearing beta from the plan is at +-pi/2 from the motion heading theta_a + offset
    assert beta - offset == pytest.approx(math.copysign(PI / 2, beta))
    assert math.copysign(1.0, offset) == -math.copysign(1.0, beta)        # away from the obstacle


def test_avoidance_uses_the_nearest_hit_and_the_freer_side_straight_ahead():
    assert k.avoidance_offset(rays(p1=0.3, m2=0.2), 0.45) == (True, pytest.approx(PI / 4))
    assert k.avoidance_offset(rays(z=0.2, m1=0.3, m2=0.35), 0.45) == (True, PI / 2)     # right blocked: turn left
    assert k.avoidance_offset(rays(z=0.2, p1=0.3, p2=0.35), 0.45) == (True, -PI / 2)    # left blocked: turn right
    assert k.avoidance_offset(rays(z=0.2), 0.45) == (True, PI / 2)                       # tie: left
    assert k.avoidance_offset(rays(), 0.45) == (False, 0.0)


def test_ray_casts_against_bodies_walls_and_the_hard_obstacle():
    assert k.ray_disc(0.0, 0.0, 1.0, 0.0, 0.4, 0.0, 0.15) == pytest.approx(0.25)
    assert k.ray_disc(0.0, 0.0, 1.0, 0.0, 0.4, 0.2, 0.15) == np.inf
    assert k.ray_walls(0.2, 5.0, -1.0, 0.0, 12.6, 10.8) == pytest.approx(0.2)
    g = kernel_geometry(build(LunarParams(layout="HARD-RT")))     # x in [6.75, 10.35], y in [4.95, 5.85]
    corners = g[k.G_CORNERS:k.G_CORNERS + 8].reshape(4, 2)
    hits = [k.ray_segment(8.0, 4.7, 0.0, 1.0, *corners[e], *corners[(e + 1) % 4]) for e in range(4)]
    assert min(hits) == pytest.approx(0.25)
    assert k.segment_blocked(8.0, 4.0, 8.0, 6.5, g) and not k.segment_blocked(6.0, 4.0, 6.0, 6.5, g)
    assert k.disc_hits_quad(8.0, 4.85, 0.15, g) and not k.disc_hits_quad(8.0, 4.75, 0.15, g)


# ------------------------------------------------------------------ energy (section 8)


def test_energy_balance():
    _, pars, _ = kernel_inputs(LunarParams())
    tau, e = 0.064, 20_000.0
    # mobile, translating on normal ground outside R, two links: 1 + 0.1 + 1 + 58 W
    assert k.tick_energy(e, pars, False, True, 2, True, 1.0, False, False)[0] == pytest.approx(e - 60.1 * tau)
    # the same robot inside R harvests P_solar
    assert k.tick_energy(e, pars, True, True, 2, True, 1.0, False, False)[0] == \
        pytest.approx(e + (102.075 - 60.1) * tau)
    # beacons: no scanning, no motion; solar input inside R too
    assert k.tick_energy(e, pars, False, False, 3, False, 1.0, False, False)[0] == pytest.approx(e - 1.15 * tau)
    assert k.tick_energy(e, pars, True, False, 3, False, 1.0, False, False)[0] == \
        pytest.approx(e + (102.075 - 1.15) * tau)
    # the soft patch multiplies locomotion power by kappa_soft; avoidance and loading add theirs
    new, gross = k.tick_energy(e, pars, False, True, 0, True, 3.0, True, True)
    assert gross == pytest.approx((1.0 + 1.0 + 3 * 58.0 + 2.0) * tau + 100.0)
    assert new == pytest.approx(e - gross)
    # clipped to [0, E_cap]: a charging robot stops at exactly E_cap, an empty one at exactly 0 (death)
    assert k.tick_energy(36_000.0 - 1.0, pars, True, True, 0, False, 1.0, False, False)[0] == 36_000.0
    assert k.tick_energy(1.0, pars, False, True, 0, True, 1.0, False, False)[0] == 0.0


def test_robots_die_at_zero_energy_and_stay_as_obstacles():
    # a battery of 18 J: a robot driving at ~60 W empties it within a few ticks of leaving the nest
    out = simulate(LunarParams(n_robots=5, runs=1, duration_s=20.0, battery_wh=0.005, snapshot_every_s=1e4))
    end = out["snapshots"].to_pandas().query("label == 'end'")
    dead = end[end.status == "dead"]
    assert len(dead) >= 1 and (dead.soc == 0.0).all()
    assert (end[end.status == "alive"].soc > 0.0).all()
    assert out["summary"]["deaths"][0].as_py() == len(dead)
    # a dead robot never moves again: its position is the same in every later frame
    frames = simulate(LunarParams(n_robots=5, runs=1, duration_s=20.0, battery_wh=0.005, frames=True,
                                  update_interval_s=0.64, snapshot_every_s=1e4))["snapshots"].to_pandas()
    for robot, rows in frames[frames.status == "dead"].groupby("robot"):
        assert rows.x.nunique() == 1 and rows.y.nunique() == 1, robot


# ------------------------------------------------------------------ trip records (section 12)


def trip_state(n=2):
    return (np.full(n, k.NO_REGION, dtype=np.int64), np.zeros(n, dtype=np.bool_), np.zeros(n, dtype=np.int64),
            np.zeros(n, dtype=np.int64), np.zeros((n, 3)), np.empty((4, k.N_TRIP)))


def test_trip_record_from_leaving_one_region_to_entering_another():
    last_left, voided, tick_left, role_left, acc, trips = trip_state()
    used = k.region_change(1, 10, k.REG_N, k.NO_REGION, k.F_OUT, last_left, voided, tick_left, role_left, acc,
                           trips, 0, 7)
    acc[1] += (5.0, 300.0, 0.9)                      # driven, used, of which in the soft patch
    used = k.region_change(1, 90, k.NO_REGION, k.REG_T, k.F_OUT, last_left, voided, tick_left, role_left, acc,
                           trips, used, 7)
    assert used == 1
    row = trips[0]
    assert (row[k.TR_RUN], row[k.TR_ORIGIN], row[k.TR_DEST], row[k.TR_TICK_LEFT], row[k.TR_TICK_ENTERED]) == \
        (7, k.REG_N, k.REG_T, 10, 90)
    assert (row[k.TR_LENGTH], row[k.TR_ENERGY], row[k.TR_SOFT], row[k.TR_ROBOT]) == (5.0, 300.0, 0.9, 1)
    # coming back into the region it left is not a trip
    used = k.region_change(1, 95, k.REG_T, k.NO_REGION, k.F_IN, last_left, voided, tick_left, role_left, acc,
                           trips, used, 7)
    used = k.region_change(1, 99, k.NO_REGION, k.REG_T, k.F_IN, last_left, voided, tick_left, role_left, acc,
                           trips, used, 7)
    assert used == 1


def beacon_spell(robot, n=2):
    """become_beacon on fresh memory arrays of ``n`` robots (all ones): (countdown, memory arrays)."""
    countdown = np.zeros(n, dtype=np.int64)
    omega, bvx, bvy, bsoc, weight = (np.ones((n, 3)) for _ in range(5))
    binit, ikey = np.ones((n, 3), dtype=np.bool_), np.zeros((n, n), dtype=np.int64)
    return countdown, omega, bvx, bvy, bsoc, binit, weight, ikey


def test_a_beacon_spell_voids_the_trip_in_progress():
    last_left, voided, tick_left, role_left, acc, trips = trip_state()
    countdown, omega, bvx, bvy, bsoc, binit, weight, ikey = beacon_spell(0)
    used = k.region_change(0, 10, k.REG_N, k.NO_REGION, k.F_OUT, last_left, voided, tick_left, role_left, acc,
                           trips, 0, 0)
    k.become_beacon(0, 156, countdown, last_left, voided, omega, bvx, bvy, bsoc, binit, weight, ikey)
    assert countdown[0] == 156
    assert not omega[0].any() and not binit[0].any() and (ikey[0] == -1).all() and omega[1].all()
    # ... decays later and drives on into T: no N -> T trip spanning the beacon spell
    used = k.region_change(0, 900, k.NO_REGION, k.REG_T, k.F_OUT, last_left, voided, tick_left, role_left, acc,
                           trips, used, 0)
    assert used == 0


def test_a_beacon_spell_inside_a_region_leaves_no_region_to_start_a_trip_from():
    # a beacon in T decays and drives out of T into R: it has not "last left" T (section 12);
    # the next trip starts when it leaves R, the region it entered after the spell
    last_left, voided, tick_left, role_left, acc, trips = trip_state()
    countdown, omega, bvx, bvy, bsoc, binit, weight, ikey = beacon_spell(0)
    k.become_beacon(0, 156, countdown, last_left, voided, omega, bvx, bvy, bsoc, binit, weight, ikey)
    used = k.region_change(0, 900, k.REG_T, k.NO_REGION, k.F_OUT, last_left, voided, tick_left, role_left, acc,
                           trips, 0, 0)
    used = k.region_change(0, 990, k.NO_REGION, k.REG_R, k.R, last_left, voided, tick_left, role_left, acc,
                           trips, used, 0)
    assert used == 0
    used = k.region_change(0, 995, k.REG_R, k.NO_REGION, k.R, last_left, voided, tick_left, role_left, acc,
                           trips, used, 0)
    used = k.region_change(0, 999, k.NO_REGION, k.REG_T, k.F_IN, last_left, voided, tick_left, role_left, acc,
                           trips, used, 0)
    assert used == 1 and (trips[0, k.TR_ORIGIN], trips[0, k.TR_TICK_LEFT]) == (k.REG_R, 995)


# ------------------------------------------------------------------ alignment diagnostic (section 12)


def test_alignment_positive_on_a_straight_corridor():
    g = kernel_geometry(build(LunarParams(layout="OPEN")))
    (nx, ny), (tx, ty) = (g[k.G_CX + k.REG_N], g[k.G_CY + k.REG_N]), (g[k.G_CX + k.REG_T], g[k.G_CY + k.REG_T])
    ux, uy = (tx - nx) / math.hypot(tx - nx, ty - ny), (ty - ny) / math.hypot(tx - nx, ty - ny)
    n = 6
    status = np.full(n, k.ALIVE, dtype=np.int64)
    role = np.full(n, k.B, dtype=np.int64)
    role[5] = k.F_OUT                                 # a mobile robot's stale memory is not counted
    fractions = np.linspace(0.3, 0.7, n)
    x, y = nx + fractions * (tx - nx) - 0.3 * uy, ny + fractions * (ty - ny) + 0.3 * ux   # beside the line
    omega, bvx, bvy = np.ones((n, 3)), np.zeros((n, 3)), np.zeros((n, 3))
    bvx[:, k.F_OUT], bvy[:, k.F_OUT] = 0.5 * ux, 0.5 * uy        # learned "to T": along the corridor
    bvx[:, k.F_IN], bvy[:, k.F_IN] = -0.2 * ux, -0.2 * uy         # learned "to N": back along it
    bvx[5], bvy[5] = -1.0, 0.0
    bvx[0, k.F_OUT], bvy[0, k.F_OUT] = 0.0, 0.0                  # no experience: left out
    out, weighted = np.empty(3), np.empty(3)
    k.alignment(n, status, role, x, y, omega, bvx, bvy, g, out, weighted)
    assert out[k.REG_T] > 0.9 and out[k.REG_N] > 0.9 and math.isnan(out[k.REG_R])
    assert weighted[k.REG_T] == pytest.approx(out[k.REG_T])
    bvx[:, k.F_IN], bvy[:, k.F_IN] = 0.2 * ux, 0.2 * uy          # reversed: pointing away from N
    k.alignment(n, status, role, x, y, omega, bvx, bvy, g, out, weighted)
    assert out[k.REG_N] < -0.9


# ------------------------------------------------------------------ a small whole run


def test_small_run_tables_are_consistent():
    params = LunarParams(n_robots=8, runs=2, duration_s=120.0)
    out = simulate(params)
    summary = out["summary"].to_pandas()
    assert list(summary.run) == [0, 1] and list(summary.seed) == [0, 1]
    assert (summary.interruptions == summary.row2).all() and (summary.sessions == summary.row4).all()
    assert (summary.nest_recharges == summary.row3).all()
    series = out["timeseries"].to_pandas()
    assert len(series) == 2 * (params.ticks // params.n_T)
    counted = series.n_mobile + series.n_beacons + series.n_dead + series.n_unspawned
    assert (counted == params.n_robots).all()
    last = series.groupby("run").last()
    assert (last.resources.to_numpy() <= summary.resources.to_numpy()).all()
    trips = out["trips"].to_pandas()
    assert (trips.origin != trips.dest).all() and (trips.tick_entered > trips.tick_left).all()
    assert np.allclose(trips.duration_s, (trips.tick_entered - trips.tick_left) * params.tau)
    assert (trips.length_m <= trips.duration_s * params.v0 + 1e-9).all()
    snaps = out["snapshots"].to_pandas()
    assert set(snaps.label) <= {"first_T", "first_R", "first_row5", "periodic", "end"}
    assert (snaps.groupby(["run", "label", "t"]).size() == params.n_robots).all()
    others = snaps[snaps.role != "B"]
    assert (others[["omega_T", "omega_N", "omega_R", "S_T", "S_N", "S_R"]] == 0.0).all().all()


def test_a_row_the_supervisor_forbids_does_not_fire():
    from dronefleet.lunar.simulate import run_seeds

    params = LunarParams(n_robots=6, runs=1, duration_s=30.0)
    opts, pars, geometry = kernel_inputs(params)
    runs, seeds = run_seeds(params)
    table = role_table()[0].copy()
    stop = np.zeros(1, np.int8)
    summary = k.run_runs(opts, pars, geometry, seeds, runs, table, np.empty((0, k.N_STATE)), stop)[0]
    # the first robot to leave the nest has no beacon in range anywhere: row 1 fires
    assert summary[0, k.SM_ROWS + 0] > 0 and summary[0, k.SM_BEACONS] > 0
    table[0, :, k.EV_BECOME_BEACON] = -1
    summary, series = k.run_runs(opts, pars, geometry, seeds, runs, table, np.empty((0, k.N_STATE)), stop)[:2]
    assert summary[0, k.SM_ROWS + 0] == 0 and (series[0, :, k.TS_BEACONS] == 0).all()


# ------------------------------------------------------------------ the readings of the second review (section 21)


def test_at_kappa_soft_5_crossing_the_soft_patch_costs_more_than_the_detour_at_3_about_the_same():
    """SOFT-RT: the straight R-T way (region edge to edge) against the shortest way round the
    obstacle kept r_body clear of it, each in joules per v0 at the kernel's powers of a driving robot."""
    layout = build(LunarParams())
    g = kernel_geometry(layout)
    r_body = LunarParams().r_body
    r, t, radius = np.array(layout.centres["R"]), np.array(layout.centres["T"]), layout.radii["R"]
    length = math.dist(r, t)
    gap = length - 2 * radius
    points = 10_000                                  # the soft part of the straight way, by sampling
    along = [(radius + gap * (j + 0.5) / points) / length for j in range(points)]
    soft = gap * sum(k.inside_quad(*(r + (t - r) * f), g) for f in along) / points
    corners = np.asarray(layout.obstacle, dtype=float)
    middle = corners.mean(axis=0)
    out = corners - middle
    clear = middle + out * (1 + r_body / np.linalg.norm(out, axis=1)[:, None])   # r_body off each corner
    left = (t - r)[0] * (clear - r)[:, 1] - (t - r)[1] * (clear - r)[:, 0] > 0
    ways = []
    for side in (left, ~left):                       # round either end: R, the two corners, T
        a, b = sorted(clear[side], key=lambda c: math.dist(r, c))
        ways.append(math.dist(r, a) + math.dist(a, b) + math.dist(b, t) - 2 * radius)
    detour = min(ways)
    pars = kernel_inputs(LunarParams())[1]

    def power(kappa):                                # a mobile robot driving, no link, no avoidance
        return k.power_out(pars[k.P_COMP], pars[k.P_COMM], 0, True, pars[k.P_SCAN], True, pars[k.P_MOVE], kappa,
                           False, pars[k.P_AVOID])

    def crossing(kappa):
        return (gap - soft) * power(1.0) + soft * power(kappa)

    assert soft == pytest.approx(0.9, abs=0.01) and gap < detour
    # in metres at normal-ground power: straight 3.3 m, crossing 5.0 (kappa 3), 6.8 (5); detour 4.6
    assert detour * power(1.0) < crossing(3.0) < 1.15 * detour * power(1.0)   # about the same (A6/A7)
    assert crossing(5.0) > 1.4 * detour * power(1.0)                          # clearly dearer


def test_the_summary_counts_depletions_fatal_or_recorded():
    small = dict(n_robots=12, duration_s=120.0, runs=1, battery_wh=0.05)
    fatal = simulate(LunarParams(**small))["summary"].to_pylist()[0]
    recorded = simulate(LunarParams(**small, depletion="recorded"))
    summary = recorded["summary"].to_pylist()[0]
    assert fatal["depletions"] == fatal["deaths"] > 0
    assert summary["deaths"] == 0 and summary["depletions"] > 0
    assert recorded["timeseries"]["n_dead"].to_pylist()[-1] == 0


def test_soc0_low_draws_each_robots_initial_soc_from_a_stream_of_its_own():
    def start(**changes):
        """The end snapshot of a 1-s run: robots not yet spawned still hold their initial SOC."""
        snaps = simulate(LunarParams(n_robots=20, duration_s=1.0, runs=2, frames=False, **changes))["snapshots"]
        rows = [r for r in snaps.to_pylist() if r["label"] == "end"]
        return {(r["run"], r["robot"]): (r["status"], r["soc"], r["heading"]) for r in rows}

    drawn, full, other = start(soc0_low=0.8), start(), start(soc0_low=0.8, layout="OPEN")
    waiting = [key for key, (status, _, _) in drawn.items() if status == "unspawned"]
    socs = [drawn[key][1] for key in waiting]
    assert len(waiting) > 20 and all(0.8 <= soc < 1.0 for soc in socs) and len(set(socs)) == len(socs)
    assert all(full[key][1] == 1.0 for key in waiting)
    assert [drawn[(0, i)][1] for i in range(10, 20)] != [drawn[(1, i)][1] for i in range(10, 20)]  # per run
    assert all(other[key][1] == drawn[key][1] for key in waiting)           # the same in every layout
    spawned = [key for key in drawn if key not in waiting]
    assert spawned and all(drawn[key][2] == full[key][2] for key in spawned)  # the robots' own draws unchanged
