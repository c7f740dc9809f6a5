"""The wiring of the lunar tick loop (spec LUNAR-FORAGING.md sections 5-11, 17): 2-5 robots put by
hand into a chosen state (``run_runs``'s ``start`` array), run for 1-3 ticks, and read back. Each
test builds the precondition of one rule into that state, so a rule wired wrongly in the loop (the
order of a tick, what is sensed from where, which key, which draw) fails here even though the
small functions of ``test_lunar_rules.py`` are right."""

import math

import numpy as np
import pytest

from dronefleet.lunar import kernel as k
from dronefleet.lunar.params import LunarParams
from dronefleet.lunar.simulate import kernel_inputs, role_table
from dronefleet.rng import seed_stream, uniform

PI = math.pi
DEFAULTS = LunarParams()
E_CAP = DEFAULTS.e_cap_j
TAU = DEFAULTS.tau
STEP = DEFAULTS.v0 * DEFAULTS.tau
SUP_OF = {k.F_OUT: k.S_F_OUT, k.F_IN: k.S_F_IN, k.R: k.S_R}
BEACON_OF = {k.F_OUT: k.S_B_F_OUT, k.F_IN: k.S_B_F_IN, k.R: k.S_B_R}
# Points of the section-2 layout (scale 0.75): region centres, a free spot, both sides of the RT obstacle.
N_C, T_C, R_C = (2.25, 5.4), (8.55, 8.55), (8.55, 2.25)
FREE = (5.5, 5.4)
SEED = 7


def mobile(x, y, role=k.F_OUT, heading=0.0, motion=None, soc=0.5, countdown=100, k1=k.B, **fields):
    """A robot's state row: alive, ``role`` (NORMAL), at (x, y) with planned heading ``heading`` and
    last motion heading ``motion`` (default the plan); no decision due; R visited; s_c = F_IN. It
    was a beacon at k-1 and k-2 (``k1``), so row 1 cannot fire unless a test says so. ``fields``:
    other ST_* columns by lower-case name (``mode=k.CHARGING``, ``omega=(...)``)."""
    row = np.zeros(k.N_STATE)
    row[k.ST_STATUS] = k.ALIVE
    row[k.ST_SUP] = SUP_OF[role]
    row[k.ST_MODE] = k.NORMAL
    row[k.ST_X], row[k.ST_Y] = x, y
    row[k.ST_THETA_A] = heading
    row[k.ST_THETA] = heading if motion is None else motion
    row[k.ST_ENERGY] = soc * E_CAP
    row[k.ST_S_C] = k.F_IN
    row[k.ST_SOC_REF] = soc
    row[k.ST_VISITED_R] = 1
    row[k.ST_COUNTDOWN] = countdown
    row[k.ST_ROLE_K1] = row[k.ST_ROLE_K2] = k1
    for name, value in fields.items():
        column = getattr(k, "ST_" + name.upper())
        if np.ndim(value):
            row[column:column + len(value)] = value
        else:
            row[column] = value
    return row


def beacon(x, y, was=k.F_OUT, countdown=100, **fields):
    """A beacon's state row (was ``was``), window end ``countdown`` ticks ahead, memory from ``fields``
    (``omega=(T, N, R)``, ``vx=...``, ``vy=...``, ``s=...``, ``init=...``)."""
    row = mobile(x, y, role=was, countdown=countdown, soc=0.9, **fields)
    row[k.ST_SUP] = BEACON_OF[was]
    return row


def unspawned():
    row = np.zeros(k.N_STATE)
    row[k.ST_STATUS] = k.UNSPAWNED
    row[k.ST_SUP] = k.S_R
    row[k.ST_ENERGY] = E_CAP
    return row


def outputs(robots, ticks=1, n_t=156, **changes):
    """Run ``ticks`` ticks from the rows ``robots`` (layout SOFT-RT unless changed; ``changes``:
    LunarParams fields): (state after (robots, N_STATE), the kernel's outputs (``run_runs``))."""
    params = LunarParams(**{"n_robots": len(robots), **changes})
    opts, pars, geometry = kernel_inputs(params)
    opts[k.O_TICKS], opts[k.O_NT] = ticks, n_t
    state = np.array(robots, dtype=np.float64)
    return state, k.run_runs(opts, pars, geometry, np.array([SEED]), np.array([0]), role_table()[0], state,
                             np.zeros(1, np.int8))


def run(robots, ticks=1, n_t=156, **changes):
    """:func:`outputs`' (state after, summary row (N_SUMMARY,))."""
    state, out = outputs(robots, ticks, n_t, **changes)
    return state, out[0][0]


def draws(robot, count):
    """The first ``count`` uniforms of ``robot``'s stream in the run of :data:`SEED` (section 13)."""
    rng = np.empty((1, robot + 1, 4), dtype=np.uint64)
    seed_stream(rng, 0, robot, SEED, robot)
    return [uniform(rng, 0, robot) for _ in range(count)]


def offset(u):
    """The random-search offset o of a draw (A27)."""
    return (2.0 * u - 1.0) * PI


def memory(row, key):
    """(omega, vx, vy, S, init) of a state row for ``key``."""
    return (row[k.ST_OMEGA + key], row[k.ST_VX + key], row[k.ST_VY + key], row[k.ST_S + key],
            row[k.ST_INIT + key])


# ------------------------------------------------------------------ sensing and messages (section 5)


def test_one_tick_latency_a_robot_arriving_in_range_is_heard_next_tick():
    # the robot starts 2.05 m from the beacon and drives at it: after tick 1 it is within 2 m
    robots = [mobile(FREE[0], FREE[1]), beacon(FREE[0] + 2.05, FREE[1])]
    after, _ = run(robots)
    assert after[0, k.ST_X] - FREE[0] == pytest.approx(STEP) and 2.05 - STEP < 2.0
    assert after[0, k.ST_LINKS] == 0 and after[1, k.ST_LINKS] == 0
    after, _ = run(robots, ticks=2)
    assert after[0, k.ST_LINKS] == 1 and after[1, k.ST_LINKS] == 1


@pytest.mark.parametrize("gap, linked", [(2.0, False), (1.999, True)])
def test_a_pair_exactly_comm_radius_apart_is_not_linked(gap, linked):
    after, _ = run([mobile(FREE[0], FREE[1], heading=PI), beacon(FREE[0] + gap, FREE[1])])
    assert after[0, k.ST_LINKS] == after[1, k.ST_LINKS] == int(linked)


@pytest.mark.parametrize("layout, linked", [("HARD-RT", False), ("SOFT-RT", True), ("OPEN", True)])
def test_a_hard_obstacle_between_two_robots_blocks_their_link_a_soft_one_does_not(layout, linked):
    # 1.8 m apart, one on each side of the RT obstacle (y in [4.95, 5.85])
    after, _ = run([mobile(8.0, 4.5, heading=-PI / 2), beacon(8.0, 6.3)], layout=layout)
    assert after[0, k.ST_LINKS] == after[1, k.ST_LINKS] == int(linked)


@pytest.mark.parametrize("place, inside", [(T_C, True), (N_C, False), (FREE, False)])
def test_the_message_a_beacon_stores_delta_u_and_reversed_plan(place, inside):
    # robot 0 (F_IN, s_c = F_OUT, SOC_ref 0.8, SOC 0.5) among three beacons: beacon 1 closes its window
    # this tick; beacons 2 and 3 know omega^F_OUT 0.5 and 0.3 (the max counts); gamma = r in T only
    # (region(s_c)), not in another region
    x, y = place
    heading = 0.7
    robots = [mobile(x, y, role=k.F_IN, heading=heading, s_c=k.F_OUT, soc_ref=0.8),
              beacon(x - 1.0, y, countdown=1), beacon(x, y - 1.0, omega=(0.5, 0.9, 0.0)),
              beacon(x, y + 1.0, omega=(0.3, 0.0, 0.0))]
    after, _ = run(robots)
    p = DEFAULTS
    delta = (p.reward if inside else 0.0) + p.diffusion * 0.5
    omega, vx, vy, soc_cost, init = memory(after[1], k.F_OUT)
    assert omega == pytest.approx(p.rho_w * delta)
    assert (vx, vy) == pytest.approx((-p.rho_v * p.v0 * math.cos(heading), -p.rho_v * p.v0 * math.sin(heading)))
    assert soc_cost == pytest.approx(p.phi_soc * (0.8 - 0.5)) and init == 1
    assert memory(after[1], k.F_IN)[0] == 0.0 and memory(after[1], k.R)[4] == 0


def test_a_charging_robot_broadcasts_zero_velocity():
    robots = [mobile(R_C[0], R_C[1], role=k.R, heading=1.0, s_c=k.R, soc_ref=0.9, mode=k.CHARGING),
              beacon(R_C[0] + 1.0, R_C[1], countdown=1)]
    robots[0][k.ST_SUP] = k.S_R_CHARGING
    after, _ = run(robots)
    omega, vx, vy, soc_cost, init = memory(after[1], k.R)
    assert init == 1 and omega == pytest.approx(DEFAULTS.rho_w * DEFAULTS.reward)
    assert vx == 0.0 and vy == 0.0
    assert after[0, k.ST_X] == R_C[0] and after[0, k.ST_MODE] == k.CHARGING


def test_the_ir_rays_see_the_snapshot_not_a_robot_that_moved_this_tick():
    # robot 0 drives towards robot 1: 0.65 m apart at the end of k-1 (rays reach 0.45 + 0.15),
    # 0.57 m after robot 0's step; robot 1's rays see the 0.65 m and it does not avoid
    robots = [mobile(FREE[0] + 0.65, FREE[1], heading=PI), mobile(FREE[0], FREE[1])]
    after, _ = run(robots)
    assert after[0, k.ST_X] == pytest.approx(FREE[0] + 0.65 - STEP)
    assert after[1, k.ST_AVOIDING] == 0 and after[1, k.ST_THETA] == 0.0
    assert after[1, k.ST_X] == pytest.approx(FREE[0] + STEP)


# ------------------------------------------------------------------ heading decisions (7.1, A18, A27)


def guided(role, vx=(0.0, 0.0, 0.0), vy=(0.0, 0.0, 0.0), visited=1, **robot):
    """Robot 0 of ``role`` deciding this tick beside a beacon with vectors ``vx, vy`` by key (weight 1)."""
    return [mobile(*FREE, role=role, countdown=0, visited_r=visited, **robot),
            beacon(FREE[0] + 1.0, FREE[1] + 1.0, omega=(1.0, 1.0, 1.0), vx=vx, vy=vy)]


def test_a_decision_takes_two_draws_u_then_o():
    u1, u2, u3, u4 = draws(0, 4)
    # guidance along +y: u1 >= eps follows it, u1 < eps searches with o = the second draw
    follow, _ = run(guided(k.F_OUT, vy=(1.0, 0.0, 0.0)), eps=u1)
    assert follow[0, k.ST_THETA_A] == pytest.approx(PI / 2)
    search, _ = run(guided(k.F_OUT, vy=(1.0, 0.0, 0.0), heading=0.3), eps=math.nextafter(u1, 1.0))
    assert search[0, k.ST_THETA_A] == k.wrap(0.3 + offset(u2))
    # two decisions in a row (n_T = 1) with no guidance: the second uses the fourth draw
    alone = [mobile(*FREE, countdown=0, heading=0.3)]
    twice, _ = run(alone, ticks=2, n_t=1)
    assert twice[0, k.ST_THETA_A] == k.wrap(k.wrap(0.3 + offset(u2)) + offset(u4))


@pytest.mark.parametrize("role, key, visited, fallback, follows", [
    (k.F_IN, k.R, 0, "visited", True),          # F_IN without N guidance follows R
    (k.R, k.F_IN, 1, "visited", True),          # R without R guidance follows N once R was visited
    (k.R, k.F_IN, 0, "visited", False),         # ... not before
    (k.R, k.F_IN, 0, "literal", True),          # the printed Eq 5-16: always
    (k.F_OUT, k.F_IN, 1, "visited", False),     # F_OUT has no fallback
    (k.F_OUT, k.R, 1, "literal", False),
])
def test_the_a18_fallbacks(role, key, visited, fallback, follows):
    vy = [0.0, 0.0, 0.0]
    vy[key] = 1.0
    after, _ = run(guided(role, vy=vy, visited=visited, heading=0.3), eps=0.0, fallback=fallback)
    u2 = draws(0, 2)[1]
    assert after[0, k.ST_THETA_A] == (pytest.approx(PI / 2) if follows else k.wrap(0.3 + offset(u2)))


@pytest.mark.parametrize("form, wa", [("exponent", 0.125), ("bracket", 0.0), ("literal", 0.5)])
def test_weight_form_changes_the_followed_heading(form, wa):
    # beacon A (S = 0.5) points +x, beacon B (S = 0) points +y, both omega 1
    robots = [mobile(*FREE, countdown=0, soc=0.9),
              beacon(FREE[0] + 1.0, FREE[1], omega=(1.0, 0, 0), vx=(1.0, 0, 0), s=(0.5, 0, 0), init=(1, 0, 0)),
              beacon(FREE[0] - 1.0, FREE[1], omega=(1.0, 0, 0), vy=(1.0, 0, 0), init=(1, 0, 0))]
    after, _ = run(robots, eps=0.0, weight_form=form)
    assert after[0, k.ST_THETA_A] == pytest.approx(math.atan2(1.0, wa))


# ------------------------------------------------------------------ roles, regions, turns (7.2, 9, 10)


@pytest.mark.parametrize("case, turn_on, turns", [
    ("row8", "region", True), ("row10", "region", True), ("row3", "region", True),
    ("row2", "region", False), ("row2", "any", True), ("row1", "any", False),
])
def test_which_role_changes_turn(case, turn_on, turns):
    heading = 0.4
    if case == "row8":
        robots = [mobile(*N_C, role=k.F_IN, heading=heading)]
    elif case == "row10":
        robots = [mobile(*T_C, role=k.F_OUT, heading=heading)]
    elif case == "row3":
        robots = [mobile(N_C[0] + 0.5, N_C[1], role=k.F_OUT, heading=heading, visited_r=0)]
    elif case == "row2":                         # SOC 0.5 below the cost 0.6 to T a beacon knows
        robots = [mobile(*FREE, heading=heading),
                  beacon(FREE[0] - 1.0, FREE[1], s=(0.6, 0, 0), init=(1, 0, 0))]
    else:                                        # no beacon in range, mobile at k-1 and k-2
        robots = [mobile(*FREE, heading=heading, k1=k.F_OUT)]
    after, summary = run(robots, turn_on=turn_on)
    row = int(case[3:])
    assert summary[k.SM_ROWS + row - 1] == 1
    expected = k.wrap(heading + PI) if turns else heading
    assert after[0, k.ST_THETA_A] == pytest.approx(expected)


def test_completion_uses_the_role_at_the_start_of_the_tick_and_any_role_unloads():
    # robot 0: F_IN in N (s_c R) with a load -> row 8 makes it F_OUT; it completes N all the same.
    # robot 1: R in N, R visited, SOC fine -> row 9; it unloads too.  robot 2: F_OUT in N: unloads,
    # completes nothing
    robots = [mobile(N_C[0], N_C[1] + 0.5, role=k.F_IN, s_c=k.R, load=6),
              mobile(N_C[0], N_C[1] - 0.5, role=k.R, s_c=k.R, load=6, heading=PI),
              mobile(N_C[0] - 0.5, N_C[1], role=k.F_OUT, s_c=k.R, load=6, heading=PI)]
    after, summary = run(robots)
    assert summary[k.SM_RESOURCES] == 18 and summary[k.SM_TRIPS] == 3
    assert list(after[:, k.ST_LOAD]) == [0, 0, 0]
    assert [k.ROLE_OF_STATE[int(s)] for s in after[:, k.ST_SUP]] == [k.F_OUT, k.F_OUT, k.F_OUT]
    assert list(after[:, k.ST_S_C]) == [k.F_IN, k.F_IN, k.R]
    assert summary[k.SM_ROWS + 7] == 1 and summary[k.SM_ROWS + 8] == 1


@pytest.mark.parametrize("completion, s_c", [("role", k.R), ("last_region", k.F_OUT)])
def test_completion_last_region_completes_any_region(completion, s_c):
    after, _ = run([mobile(*T_C, role=k.F_IN, s_c=k.R)], completion=completion)
    assert after[0, k.ST_S_C] == s_c


def test_a_completion_ends_backtrack():
    # a backtracking F_OUT robot reaches T: row 10, and its failed attempts are over
    after, _ = run([mobile(*T_C, role=k.F_OUT, mode=k.BACKTRACK, n_failed=2, bt_budget=2.0)])
    assert after[0, k.ST_MODE] == k.NORMAL and after[0, k.ST_N_FAILED] == 0
    assert k.ROLE_OF_STATE[int(after[0, k.ST_SUP])] == k.F_IN


def test_loading_charges_e_exploit_in_the_load_tick():
    after, _ = run([mobile(*T_C, role=k.F_OUT, soc=0.5)])
    p = DEFAULTS
    assert after[0, k.ST_LOAD] == p.r_max
    drawn = (p.p_comp + p.p_scan + p.p_move) * p.tau + p.e_exploit
    assert after[0, k.ST_ENERGY] == pytest.approx(0.5 * E_CAP - drawn)


# ------------------------------------------------------------------ energy (section 8)


@pytest.mark.parametrize("y, heading, kappa", [(5.84, PI / 2, 3.0), (4.90, PI / 2, 1.0)])
def test_kappa_is_judged_at_the_centre_before_the_move(y, heading, kappa):
    # leaving the soft patch (y in [4.95, 5.85]) pays kappa, entering it does not
    after, _ = run([mobile(8.0, y, heading=heading)])
    p = DEFAULTS
    assert after[0, k.ST_Y] == pytest.approx(y + STEP)
    drawn = (p.p_comp + p.p_scan + kappa * p.p_move) * p.tau
    assert after[0, k.ST_ENERGY] == pytest.approx(0.5 * E_CAP - drawn)


def test_solar_input_only_in_r_for_every_role():
    p = DEFAULTS
    robots = [mobile(*R_C, role=k.F_OUT), beacon(R_C[0] + 0.8, R_C[1], was=k.R), mobile(*FREE)]
    after, _ = run(robots)
    moving = (p.p_comp + p.p_scan + p.p_move + p.p_comm) * p.tau
    assert after[0, k.ST_ENERGY] == pytest.approx(0.5 * E_CAP + p.p_solar * p.tau - moving)
    assert after[1, k.ST_ENERGY] == pytest.approx(0.9 * E_CAP + (p.p_solar - p.p_comp - p.p_comm) * p.tau)
    assert after[2, k.ST_ENERGY] == pytest.approx(0.5 * E_CAP - (p.p_comp + p.p_scan + p.p_move) * p.tau)


def test_a_beacon_refreshes_soc_ref_inside_region_s_c():
    row = beacon(*R_C, was=k.R, s_c=k.R, soc_ref=0.2)
    after, _ = run([row])
    assert after[0, k.ST_SOC_REF] == after[0, k.ST_ENERGY] / E_CAP


# ------------------------------------------------------------------ avoidance and translation (7.4, 7.5)


@pytest.mark.parametrize("avoidance", ["offset", "turn"])
def test_avoidance_offsets_the_plan_and_keeps_it_unless_turn(avoidance):
    # facing the east wall 0.3 m away; the last motion heading (1.0) is not what is offset
    x = 12.6 - 0.3
    after, _ = run([mobile(x, FREE[1], heading=0.0, motion=1.0)], avoidance=avoidance)
    assert after[0, k.ST_AVOIDING] == 1
    assert after[0, k.ST_THETA] == pytest.approx(PI / 2)
    assert after[0, k.ST_THETA_A] == (0.0 if avoidance == "offset" else pytest.approx(PI / 2))
    assert after[0, k.ST_Y] == pytest.approx(FREE[1] + STEP)


@pytest.mark.parametrize("velocity, heading", [("planned", 0.0), ("motion", 1.0)])
def test_broadcast_velocity_motion_sends_the_last_motion_heading(velocity, heading):
    robots = [mobile(*FREE, heading=0.0, motion=1.0), beacon(FREE[0] - 1.0, FREE[1], countdown=1)]
    after, _ = run(robots, broadcast_velocity=velocity)
    _, vx, vy, _, _ = memory(after[1], k.F_IN)
    scale = -DEFAULTS.rho_v * DEFAULTS.v0
    assert (vx, vy) == pytest.approx((scale * math.cos(heading), scale * math.sin(heading)))


@pytest.mark.parametrize("ahead, blocked", [(0, False), (1, True)])
def test_translation_in_ascending_id_sees_the_moves_already_made(ahead, blocked):
    # two robots 0.31 m apart in a file driving +y (no IR range: only bodies matter). When the
    # lower id is ahead it moves first and the other follows; when it is behind it meets the old
    # position of the one ahead and stays
    x, y = FREE
    robots = [None, None]
    robots[ahead] = mobile(x, y + 0.31, heading=PI / 2)
    robots[1 - ahead] = mobile(x, y, heading=PI / 2)
    after, _ = run(robots, ir_range=0.0)
    behind = 1 - ahead
    assert after[ahead, k.ST_Y] == pytest.approx(y + 0.31 + STEP)
    assert after[behind, k.ST_Y] == (y if blocked else pytest.approx(y + STEP))
    assert after[behind, k.ST_BLOCKED] == int(blocked)


@pytest.mark.parametrize("blocked, turns", [(8, False), (9, True)])
def test_a_random_turn_after_blocked_ticks(blocked, turns):
    x = 12.6 - 0.16                              # against the east wall, no IR range
    after, _ = run([mobile(x, FREE[1], heading=0.2, blocked=blocked)], ir_range=0.0)
    assert after[0, k.ST_X] == x
    expected = k.wrap(0.2 + offset(draws(0, 1)[0])) if turns else 0.2
    assert after[0, k.ST_THETA_A] == expected
    assert after[0, k.ST_BLOCKED] == (0 if turns else blocked + 1)


# ------------------------------------------------------------------ spawning (section 11 step 1, A33)


def test_spawn_only_when_clear_lowest_id_first_one_per_tick_and_unseen():
    # robot 0 drives away from the spawn point, 0.29 m off at the start: robot 1 spawns in tick 2.
    # A beacon near N with R guidance (+y) and eps = 0: the newcomer does not use it (A33)
    robots = [mobile(N_C[0] + 0.29, N_C[1], role=k.F_OUT),
              beacon(N_C[0] + 0.5, N_C[1] + 1.0, omega=(0, 0, 1.0), vy=(0, 0, 1.0)),
              unspawned(), unspawned()]
    after, _ = run(robots, eps=0.0)
    assert list(after[:, k.ST_STATUS]) == [k.ALIVE, k.ALIVE, k.UNSPAWNED, k.UNSPAWNED]
    after, _ = run(robots, ticks=2, eps=0.0)
    assert list(after[:, k.ST_STATUS]) == [k.ALIVE, k.ALIVE, k.ALIVE, k.UNSPAWNED]
    assert after[2, k.ST_LINKS] == 0 and after[1, k.ST_LINKS] == 1      # not heard, not hearing
    assert after[2, k.ST_THETA_A] == k.wrap(0.0 + offset(draws(2, 2)[1]))
    assert k.ROLE_OF_STATE[int(after[2, k.ST_SUP])] == k.R and after[2, k.ST_ENERGY] < E_CAP


# ------------------------------------------------------------------ decay, reconnect, backtrack (6, 7.3)


def test_a_new_beacons_first_window_ends_n_t_minus_1_ticks_later():
    # row 1 at tick 1 with n_T = 3: no message, so the first window end (tick 3) decays it
    robots = [mobile(*FREE, k1=k.F_OUT)]
    after, _ = run(robots, ticks=2, n_t=3)
    assert k.ROLE_OF_STATE[int(after[0, k.ST_SUP])] == k.B
    after, summary = run(robots, ticks=3, n_t=3)
    assert summary[k.SM_ROWS + k.ROW_D - 1] == 1
    assert after[0, k.ST_MODE] == k.RECONNECT and after[0, k.ST_N_FAILED] == 1


def test_reconnect_contact_starts_backtrack_with_a_decision_for_s_c():
    # F_OUT in RECONNECT after 3 failures, beacon in range knows R (s_c) guidance +y only
    robots = [mobile(*FREE, mode=k.RECONNECT, n_failed=3, s_c=k.R, heading=PI),
              beacon(FREE[0] - 1.0, FREE[1], omega=(0, 0, 1.0), vy=(0, 0, 1.0))]
    after, _ = run(robots, eps=0.0)
    assert after[0, k.ST_MODE] == k.BACKTRACK
    assert after[0, k.ST_BT_BUDGET] == 3 * 0.5 * DEFAULTS.comm_radius
    assert after[0, k.ST_THETA_A] == pytest.approx(PI / 2)
    assert after[0, k.ST_BT_TRAVEL] == pytest.approx(STEP)


def test_reconnect_without_contact_ends_after_2_comm_radius_in_a_random_search():
    # 3.95 m done: the step of tick 1 reaches d_rc = 4 m; in tick 2 a beacon with F_OUT guidance
    # is in range, and eps = 0: the decision is a random search all the same (7.3)
    robots = [mobile(*FREE, mode=k.RECONNECT, rc_travel=3.95, heading=0.0, countdown=50),
              beacon(FREE[0] + 2.05, FREE[1], omega=(1.0, 0, 0), vy=(1.0, 0, 0))]
    after, _ = run(robots, eps=0.0)
    assert after[0, k.ST_MODE] == k.NORMAL and after[0, k.ST_THETA_A] == 0.0
    after, _ = run(robots, ticks=2, eps=0.0)
    assert after[0, k.ST_LINKS] == 1
    assert after[0, k.ST_THETA_A] == k.wrap(0.0 + offset(draws(0, 2)[1]))


def test_a_random_search_due_is_dropped_with_the_immediate_decision_it_belonged_to():
    # a robot whose reconnect ended (immediate random search pending) but which is charging by
    # the time it could decide: the decision is dropped, and after charging (row 6 at tick 2)
    # its next due decision follows the F_OUT guidance again
    robots = [mobile(*R_C, role=k.R, mode=k.CHARGING, soc=1.0, countdown=1, immediate=1, search=1),
              beacon(R_C[0] + 1.0, R_C[1], omega=(1.0, 0, 1.0), vy=(1.0, 0, 0), vx=(0, 0, 1.0))]
    robots[0][k.ST_ENERGY] = E_CAP - 1.0
    robots[0][k.ST_SUP] = k.S_R_CHARGING
    after, summary = run(robots, ticks=2, eps=0.0)
    assert summary[k.SM_ROWS + 5] == 1
    assert after[0, k.ST_THETA_A] == pytest.approx(PI / 2) and after[0, k.ST_SEARCH] == 0


# ------------------------------------------------------------------ section-17 options


@pytest.mark.parametrize("broadcast, heard", [("tick", True), ("update", False)])
def test_broadcast_update_sends_only_after_a_decision(broadcast, heard):
    robots = [mobile(*FREE), beacon(FREE[0] - 1.0, FREE[1], countdown=1)]
    after, _ = run(robots, broadcast=broadcast)
    assert memory(after[1], k.F_IN)[4] == int(heard)
    # unheard, the beacon's summed weight stays below eta_w: it decays (row D)
    assert (k.ROLE_OF_STATE[int(after[1, k.ST_SUP])] == k.B) == heard


@pytest.mark.parametrize("los_bodies, linked", [(False, True), (True, False)])
def test_los_bodies_lets_a_robot_between_block_the_link(los_bodies, linked):
    robots = [mobile(*FREE, heading=PI), beacon(FREE[0] + 1.5, FREE[1]), beacon(FREE[0] + 0.75, FREE[1] + 0.05)]
    after, _ = run(robots, los_bodies=los_bodies)
    assert after[1, k.ST_LINKS] == int(linked)


@pytest.mark.parametrize("redecide, decides", [("none", False), ("beacon_change", True)])
def test_redecide_beacon_change_decides_when_the_nearest_beacon_changes(redecide, decides):
    robots = [mobile(*FREE), beacon(FREE[0] - 1.0, FREE[1], omega=(1.0, 0, 0), vy=(1.0, 0, 0))]
    after, _ = run(robots, eps=0.0, redecide=redecide)
    assert after[0, k.ST_THETA_A] == (pytest.approx(PI / 2) if decides else 0.0)


@pytest.mark.parametrize("redecide, decides", [("none", False), ("avoid_clear", True)])
def test_redecide_avoid_clear_decides_when_the_reflex_clears(redecide, decides):
    robots = [mobile(*FREE, heading=0.3, avoiding=1)]
    after, _ = run(robots, ticks=2, redecide=redecide)
    assert after[0, k.ST_THETA_A] == (k.wrap(0.3 + offset(draws(0, 2)[1])) if decides else 0.3)


# ------------------------------------------------------------------ diagnostics (section 12)


def test_alignment_weighted_by_omega():
    # beacon 1 points at T with omega 3, beacon 2 away from it with omega 1
    x, y = T_C[0] - 1.5, T_C[1] - 1.5
    robots = [mobile(*FREE),
              beacon(x, y, omega=(3.0, 0, 0), vx=(1.0, 0, 0), vy=(1.0, 0, 0)),
              beacon(x - 0.5, y - 0.5, omega=(1.0, 0, 0), vx=(-1.0, 0, 0), vy=(-1.0, 0, 0))]
    _, summary = run(robots)
    assert summary[k.SM_ALIGN + k.REG_T] == pytest.approx(0.0, abs=1e-12)
    assert summary[k.SM_ALIGN_W + k.REG_T] == pytest.approx(0.5)


# ------------------------------------------------------------------ what a run records per robot (section 19)


def test_a_robot_at_soc_near_0_dies_where_it_stands_and_its_record_says_where_and_as_what():
    robots = [beacon(*T_C, was=k.R, energy=1e-9),                 # a beacon in T: it does not move
              mobile(*FREE, role=k.R, heading=0.0, soc=1e-12),     # steps once, then dies
              mobile(*N_C, role=k.F_IN, soc=0.5, countdown=100)]
    after, out = outputs(robots, ticks=3)
    ledger = out[4]
    assert [row[k.LG_DIED_K] for row in ledger] == [1.0, 1.0, -1.0]
    dead = ledger[:2, [k.LG_DIED_X, k.LG_DIED_Y, k.LG_DIED_ROLE, k.LG_DIED_MODE, k.LG_DIED_REGION]]
    assert dead.tolist() == [[T_C[0], T_C[1], k.B, k.NORMAL, k.REG_T],
                             [FREE[0] + STEP, FREE[1], k.R, k.NORMAL, k.NO_REGION]]
    assert (after[1, k.ST_X], after[1, k.ST_STATUS]) == (FREE[0] + STEP, k.DEAD)
    assert [row[k.LG_TICKS + k.B] + row[k.LG_TICKS + k.R] for row in ledger[:2]] == [1.0, 1.0]   # alive 1 tick


def test_a_robot_alive_throughout_spends_the_run_in_its_roles_and_moves_every_tick():
    ticks = 20                            # 1.6 m east of FREE, the beacon within 2 m all along (no row 1)
    robots = [mobile(*FREE, role=k.F_OUT, heading=0.0, soc=0.5), beacon(FREE[0] + 0.8, FREE[1] + 1.0)]
    after, out = outputs(robots, ticks=ticks)
    robot, lit = out[4]
    assert robot[k.LG_TICKS:k.LG_TICKS + 4].tolist() == [ticks, 0, 0, 0]
    assert lit[k.LG_TICKS:k.LG_TICKS + 4].tolist() == [0, 0, 0, ticks]
    assert (robot[k.LG_MOVES], lit[k.LG_MOVES]) == (ticks, 0)
    assert after[0, k.ST_X] - FREE[0] == pytest.approx(ticks * STEP)
    assert robot[k.LG_ENERGY] == pytest.approx(0.5 * E_CAP - after[0, k.ST_ENERGY])   # no solar outside R
    assert [robot[k.LG_RUN], robot[k.LG_ROBOT], lit[k.LG_ROBOT]] == [0, 0, 1]
