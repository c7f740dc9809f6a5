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


def run(robots, ticks=1, n_t=156, **changes):
    """Run ``ticks`` ticks from the rows ``robots`` (layout SOFT-RT unless changed; ``changes``:
    LunarParams fields): (state after (robots, N_STATE), summary row (N_SUMMARY,))."""
    params = LunarParams(**{"n_robots": len(robots), **changes})
    opts, pars, geometry = kernel_inputs(params)
    opts[k.O_TICKS], opts[k.O_NT] = ticks, n_t
    state = np.array(robots, dtype=np.float64)
    summary = k.run_runs(opts, pars, geometry, np.array([SEED]), np.array([0]), role_table()[0], state,
                         np.zeros(1, np.int8))[0]
    return state, summary[0]


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


def test_the_ir_rays_see_the_snapshot_not_a_robot_that_moved_this_tick():
    # robot 0 drives towards robot 1: 0.65 m apart at the end of k-1 (rays reach 0.45 + 0.15),
    # 0.57 m after robot 0's step; robot 1's rays see the 0.65 m and it does not avoid
    robots = [mobile(FREE[0] + 0.65, FREE[1], heading=PI), mobile(FREE[0], FREE[1])]
    after, _ = run(robots)
    assert after[0, k.ST_X] == pytest.approx(FREE[0] + 0.65 - STEP)
    assert after[1, k.ST_AVOIDING] == 0 and after[1, k.ST_THETA] == 0.0
    assert after[1, k.ST_X] == pytest.approx(FREE[0] + STEP)


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


def test_a_completion_ends_backtrack():
    # a backtracking F_OUT robot reaches T: row 10, and its failed attempts are over
    after, _ = run([mobile(*T_C, role=k.F_OUT, mode=k.BACKTRACK, n_failed=2, bt_budget=2.0)])
    assert after[0, k.ST_MODE] == k.NORMAL and after[0, k.ST_N_FAILED] == 0
    assert k.ROLE_OF_STATE[int(after[0, k.ST_SUP])] == k.F_IN


# ------------------------------------------------------------------ energy (section 8)


def test_a_beacon_refreshes_soc_ref_inside_region_s_c():
    row = beacon(*R_C, was=k.R, s_c=k.R, soc_ref=0.2)
    after, _ = run([row])
    assert after[0, k.ST_SOC_REF] == after[0, k.ST_ENERGY] / E_CAP


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
