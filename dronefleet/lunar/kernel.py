"""Compiled kernel of the lunar foraging-with-recharging model (spec LUNAR-FORAGING.md, sections 2-13).

One call of :func:`run_runs` runs every run of one configuration; each run seeds one xoshiro
stream per robot from the run's root seed and the robot's id (section 13: the same streams in
every scenario), and steps ticks k = 1..K in the order of section 11. State is a structure of
plain arrays indexed by robot id (spawn order), allocated once per call. Roles are the states of
the role supervisor (``dronefleet/data/lunar-roles.yaml``): a row of section 9 fires only through
:func:`dronefleet.supervisor.take` on its transition table.

A tick is a call of each phase, the steps of section 11 in order, each a kernel of its own over
those arrays (some passed in groups: ``heading``, ``motion``, ``memory``, ``inbox``, ``sensed``,
``trip``; ``tally`` holds the run's counts): :func:`spawn` (1), :func:`sense_and_communicate` (2),
:func:`roles_and_region_actions` (3), :func:`heading_decisions` (4), :func:`avoidance` and
:func:`translation` (5), :func:`energy_and_deaths` (6), :func:`bookkeeping` (7),
:func:`beacon_windows` (8), :func:`records` (9). :func:`run_ticks` loops over the ticks with the
phases inlined and without reference counts (a tick allocates nothing); :func:`run_runs` allocates,
resets each run, makes room for a tick's trips and snapshots before calling it, and summarises.
Geometry (walls, obstacle, rays, regions) is in :mod:`dronefleet.lunar.geometry`.

Only + - * / sqrt, floor and :mod:`dronefleet.fpmath` (sincos, atan2, exp, log) touch the
trajectory, so a run is bit-identical on any CPU. The rules the tests pin are small functions
of plain arrays: :func:`beacon_update` (section 6), :func:`beacon_weight`, :func:`guidance` and
:func:`follow_or_search` (7.1), :func:`avoidance_offset` (7.4), :func:`tick_energy` (section 8),
:func:`choose_row` (section 9), :func:`broadcast_velocity` (section 5), :func:`become_beacon` and
:func:`region_change` (section 12).

Details the spec leaves to the implementation, as read here:
- Sensing (links, S_hat, guidance, the IR rays) sees the section-5 snapshot: the positions at the
  end of tick k-1. Only translation (7.5) sees the positions already updated this tick (A29).
- A robot spawned at tick k did not exist at the end of k-1: in that tick it senses nothing (no
  links, no rays), broadcasts nothing and is not sensed (only its body blocks others' steps), and
  its first decision is a random search (both draws taken, A33).
- The countdown is a per-robot clock: at 0 it restarts at n_T whatever the mode; only NORMAL and
  BACKTRACK robots decide then (a robot leaving R after charging keeps its 7.2 turn until its
  next due decision). Immediate decisions (7.3, A41) do not restart it.
- The RECONNECT contact test runs just before the decisions of step 4 (section 11 lists it after
  them), so that the contact's decision is "immediate" (7.3) in the same tick, not the next.
  Reaching d_rc without contact gives NORMAL and a random search (no guidance, both draws) at
  the next tick's step 4. Any completion (section 10, rows 9, 11) ends RECONNECT and BACKTRACK.
- Row 3 also matches a robot already in role R (nothing changes, but row 9 cannot fire before
  it has charged); it is not counted: the row-3 count (``nest_recharges``, ``row3``) counts the
  changes of role F_OUT/F_IN -> R in N only.
- A new beacon counts its window down from the tick it became one (section 11 step 8 literally):
  its first window ends at k + n_T - 1 and holds the n_T - 1 snapshots of ticks k+1 .. k+n_T-1.
- ``turn_on = "any"`` (A26 "every role change") adds the turn of row 2. Row 1 does not turn:
  a beacon does not move, and the decay turn (7.3) reverses the heading it stopped with, which
  points out of the network it left; turning at row 1 too would make that reversal send the
  reconnecting robot out of coverage instead of back into it.
- The beacon spell voids the trip in progress: a reverted robot has left no region until it
  next enters one, even if it reverted inside a region.
- SOC_ref is refreshed inside region(s_c) in any role (section 10), beacons included.
- P_in (section 8) is judged at the centre after the move, kappa at the centre before it.
- Among equally near IR hits the first in ray order wins (0, then left before right).
- ``broadcast = "update"``: a robot broadcasts in the tick after each of its heading decisions
  (7.1 and the immediate ones of 7.3); not after a 7.2 turn or a blocked-turn.
- A trip's length and energy are those of the ticks after the one it left its region in, up
  to the one it entered the other in; its duration is (tick entered - tick left) tau.
- The heading alignment of section 12 uses the motion heading of the last tick.
- A spawned robot starts with E = soc0 E_cap (soc0 = 1 by default, A39), or with 0 < soc0_low < soc0
  at a SOC drawn per robot from U(soc0_low, soc0) at the start of the run, in robot order from a
  stream of the run's own (SOC0_STREAM); an unspawned robot counts as soc0 in SOC_sum.
"""

import numpy as np

from ..fpmath import atan2, exp, log, sincos
from ..jit import borrowing, njit
from ..rng import seed_stream, uniform
from ..supervisor import take
from .geometry import G_CORNERS, G_H, G_KIND, G_SPAWN, G_W, KIND_HARD, KIND_NONE, KIND_SOFT, NO_REGION
from .geometry import G_CX, G_CY  # noqa: F401 (the geometry columns the tests read, as before the split)
from .geometry import (disc_hits_quad, heading_alignment, inside_quad, near_box, ray_disc, ray_segment, ray_walls,
                       region_of, segment_blocked, segment_point_dist2)

# Roles (= keys for mobile roles: key F_OUT <-> region T, F_IN <-> N, R <-> R), statuses, modes.
F_OUT, F_IN, R, B = 0, 1, 2, 3
REG_T, REG_N, REG_R = 0, 1, 2
UNSPAWNED, ALIVE, DEAD = 0, 1, 2
NORMAL, CHARGING, RECONNECT, BACKTRACK = 0, 1, 2, 3
# States of the role supervisor (lunar-roles.yaml) and the role each one is.
S_F_OUT, S_F_IN, S_R, S_R_CHARGING, S_B_F_OUT, S_B_F_IN, S_B_R, S_DEAD = range(8)
# Columns of the transition table the kernel is given (simulate.EVENTS, in this order).
(EV_BECOME_BEACON, EV_GO_CHARGE, EV_CHARGE, EV_GO_OUT, EV_GO_IN, EV_LOAD, EV_UNLOAD, EV_REVERT,
 EV_TURN_AROUND, EV_DEPLETED) = range(10)
#: Role of each supervisor state (-1: DEAD keeps the last role); a beacon state remembers s_prev.
ROLE_OF_STATE = np.array([F_OUT, F_IN, R, R, B, B, B, -1])
#: Supervisor event of each row 1..11 of section 9 (index 0 unused).
ROW_EVENT = np.array([-1, EV_BECOME_BEACON, EV_GO_CHARGE, EV_GO_CHARGE, EV_CHARGE, EV_GO_IN, EV_GO_OUT, EV_GO_IN,
                      EV_GO_OUT, EV_GO_OUT, EV_GO_IN, EV_GO_IN])
# Weight forms (A12), redecide options (A41).
W_EXPONENT, W_BRACKET, W_LITERAL = 0, 1, 2
REDECIDE_NONE, REDECIDE_AVOID_CLEAR, REDECIDE_BEACON_CHANGE = 0, 1, 2

# Integer options and float parameters: indices into ``opts`` and ``pars``.
(O_ROBOTS, O_TICKS, O_NT, O_RMAX, O_BLOCKED, O_RATE_W, O_SNAP_EVERY, O_FRAMES, O_AVOID_TURN,
 O_BCAST_MOTION, O_BCAST_UPDATE, O_WFORM, O_FALLBACK_LITERAL, O_TURN_ANY, O_LOS_BODIES, O_REDECIDE,
 O_COMPLETION_LAST, O_INIT_STATE, O_DEPLETION_RECORDED, O_EXPERIENCE_LEAVING, O_BASELINE) = range(21)
N_OPTS = 21
(P_TAU, P_RHO_W, P_RHO_V, P_RHO_P, P_RHO_F, P_RHO_C, P_COMM_R, P_ETA_W, P_PHI, P_V0, P_EPS, P_REWARD,
 P_LAMBDA, P_KAPPA, P_ECAP, P_SOC0, P_MOVE, P_COMP, P_COMM, P_SCAN, P_AVOID, P_EXPLOIT, P_SOLAR,
 P_RBODY, P_IR, P_DECISION_STEP, P_SOC0_LOW) = range(27)
N_PARS = 27
#: Key of the stream the initial SOCs are drawn from (0 < soc0_low < soc0, A39): apart from the robots'
#: streams (keys 0 .. N_a - 1), so that drawing them changes no robot's draws.
SOC0_STREAM = 2**40

PI = 3.141592653589793
TWO_PI = 6.283185307179586
HALF_PI = 1.5707963267948966
#: IR rays (7.4): bearings from the plan, left positive, in the order ties are broken.
RAY_ANGLES = np.array([0.0, PI / 8, -PI / 8, PI / 4, -PI / 4, 3 * PI / 8, -3 * PI / 8])
N_RAYS = 7
#: "No R guidance" (section 5): |v^R| <= 1e-12 for every beacon in range.
NO_GUIDANCE2 = 1e-24

# Summary columns (per run).
(SM_RESOURCES, SM_TRIPS, SM_INTERRUPTIONS, SM_NEST_RECHARGES, SM_SESSIONS, SM_DEATHS, SM_BEACONS,
 SM_MOBILE, SM_UNITS_BEACONS, SM_ALIGN, SM_ALIGN_W, SM_HEAD_ALIGN, SM_T_FIRST_T, SM_T_FIRST_R,
 SM_T_FIRST_ROW5, SM_T_BEACONS_90, SM_ROWS) = (0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 12, 15, 18, 19, 20, 21, 22)
N_ROW_COUNTS = 12          # rows 1..11, then D (index 11)
ROW_D = 12
SM_DEPLETIONS = SM_ROWS + N_ROW_COUNTS
N_SUMMARY = SM_DEPLETIONS + 1
# Time-series columns (per record, every n_T ticks).
(TS_K, TS_RESOURCES, TS_TRIPS, TS_INTERRUPTIONS, TS_NEST_RECHARGES, TS_SESSIONS, TS_RATE, TS_MOBILE,
 TS_BEACONS, TS_DEAD, TS_UNSPAWNED, TS_F_OUT, TS_F_IN, TS_R, TS_SOC_SUM, TS_SOC_BEACONS, TS_SOC_MOBILE,
 TS_SOC_MIN_BEACON, TS_UNITS_BEACONS, TS_ALIGN) = range(20)
N_SERIES = TS_ALIGN + 3
# Trip record columns.
(TR_RUN, TR_ORIGIN, TR_DEST, TR_TICK_LEFT, TR_TICK_ENTERED, TR_LENGTH, TR_ENERGY, TR_SOFT,
 TR_ROLE_LEFT, TR_ROLE_ENTERED, TR_ROBOT) = range(11)
N_TRIP = 11
# Snapshot columns and labels.
(SN_RUN, SN_LABEL, SN_K, SN_ROBOT, SN_STATUS, SN_ROLE, SN_MODE, SN_X, SN_Y, SN_HEADING, SN_SOC,
 SN_LOAD, SN_OMEGA, SN_VX, SN_VY, SN_S) = (0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 15, 18, 21)
N_SNAP = 24
LABEL_FIRST_T, LABEL_FIRST_R, LABEL_FIRST_ROW5, LABEL_PERIODIC, LABEL_END, LABEL_FRAME = range(6)
#: The most snapshots one tick can take per robot: one per label, LABEL_FRAME being the last (the
#: tick loop has no bounds checks: run_runs makes room for this many before each tick).
SNAPS_PER_TICK = LABEL_FRAME + 1
# A run's tallies (``tally``, int64): units deposited, unloads, deaths, the milestone labels
# reached this tick (a bit per label), the tick, and depletions (E reaching 0 from above, fatal or not).
TL_RESOURCES, TL_UNLOADS, TL_DEATHS, TL_MILESTONES, TL_TICK, TL_DEPLETIONS = range(6)
N_TALLY = 6
# A robot's record of a run (``ledger``, a row per robot, float64; section 19): its run and id (set at
# the run's end), ticks it moved, gross energy used [J], charging sessions (row 4), loads, unloads,
# ticks alive in each role (F_OUT, F_IN, R, B: LG_TICKS + role), and its death: the tick (-1: none),
# then, written at the run's end (no phase touches a dead robot), where it lies, its role, mode and region.
(LG_RUN, LG_ROBOT, LG_MOVES, LG_ENERGY, LG_RECHARGES, LG_LOADS, LG_UNLOADS, LG_TICKS, LG_DIED_K, LG_DIED_X,
 LG_DIED_Y, LG_DIED_ROLE, LG_DIED_MODE, LG_DIED_REGION) = (0, 1, 2, 3, 4, 5, 6, 7, 11, 12, 13, 14, 15, 16)
N_LEDGER = 17
# Columns of a row-2 trigger record (A42): the robot's SOC, the S_hat of its key and of R it compared
# with, and where it was (the section-5 snapshot); the run is set at the run's end.
TG_RUN, TG_ROBOT, TG_K, TG_ROLE, TG_SOC, TG_S_HAT_DEST, TG_S_HAT_R, TG_X, TG_Y = range(9)
N_TRIGGER = 9
# Columns of a robot's state in ``run_runs(..., start)`` (a hand-built start, read back at the end).
(ST_STATUS, ST_SUP, ST_MODE, ST_X, ST_Y, ST_THETA_A, ST_THETA, ST_ENERGY, ST_LOAD, ST_S_C, ST_SOC_REF,
 ST_VISITED_R, ST_N_FAILED, ST_COUNTDOWN, ST_ROLE_K1, ST_ROLE_K2, ST_BLOCKED, ST_BT_BUDGET, ST_BT_TRAVEL,
 ST_RC_TRAVEL, ST_LINKS, ST_AVOIDING, ST_OMEGA, ST_VX, ST_VY, ST_S, ST_INIT, ST_IMMEDIATE, ST_SEARCH) = (
    0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16, 17, 18, 19, 20, 21, 22, 25, 28, 31, 34, 37, 38)
N_STATE = 39


# ------------------------------------------------------------------ small rules (tested alone)


@njit(cache=True, inline='always')
def wrap(a):
    """Angle ``a`` [rad] wrapped into [-pi, pi)."""
    return a - TWO_PI * np.floor((a + PI) / TWO_PI)


@njit(cache=True)
def power(x, y):
    """x ** y for x >= 0 with + - * / and fpmath: repeated squaring for integer 0 <= y <= 64,
    else exp(y log x); 0 ** y = 0 for y > 0, x ** 0 = 1."""
    if y == 0.0:
        return 1.0
    if x <= 0.0:
        return 0.0
    n = int(y)
    if n == y and 0 < n <= 64:
        result = 1.0
        base = x
        while n > 0:
            if n & 1:
                result *= base
            base *= base
            n >>= 1
        return result
    return exp(y * log(x))


@njit(cache=True)
def beacon_weight(omega, soc_cost, init, rho_f, rho_c, form):
    """Weight w_b^X of a beacon's vector in Eq 5-14 (A12): ``omega`` its potential weight,
    ``soc_cost`` S_b^X (read as 0 when not ``init``); form W_EXPONENT omega^rho_f (1 - S)^rho_c,
    W_BRACKET omega max(0, 1 - rho_c S), W_LITERAL omega (1 - S)."""
    s = soc_cost if init else 0.0
    if form == W_EXPONENT:
        return power(omega, rho_f) * power(1.0 - s, rho_c)
    if form == W_BRACKET:
        return omega * max(0.0, 1.0 - rho_c * s)
    return omega * (1.0 - s)


@njit(cache=True)
def guidance(beacons, count, weight, vx, vy, key):
    """G^X = sum over the ``count`` beacons ``beacons[:count]`` of w_b^X v_b^X (section 5), in
    list order; ``weight``, ``vx``, ``vy`` (robots, 3) by beacon and key. Returns (Gx, Gy)."""
    gx = 0.0
    gy = 0.0
    for q in range(count):
        b = beacons[q]
        w = weight[b, key]
        gx += w * vx[b, key]
        gy += w * vy[b, key]
    return gx, gy


@njit(cache=True)
def follow_or_search(gx, gy, theta, u, o, eps):
    """Heading decision (7.1) from the guidance (gx, gy), this tick's heading ``theta`` and the
    decision's two draws u ~ U(0, 1), o ~ U(-pi, pi): (new planned heading, followed)."""
    if (gx != 0.0 or gy != 0.0) and u >= eps:
        return atan2(gy, gx), True
    return wrap(theta + o), False


@njit(cache=True)
def beacon_update(omega, vx, vy, soc_cost, init, key, delta, mx, my, used, rho_w, rho_v, rho_p, phi_soc, eta_w):
    """One beacon's window end (section 6, Alg 3): update its memory in place and say if it decays.

    ``omega``, ``vx``, ``vy``, ``soc_cost`` (3,) float64 and ``init`` (3,) bool: the beacon's
    memory by key. ``key`` (robots,) int64: the key s_c of the last message heard from each robot
    in this window (-1: none); ``delta``, ``mx``, ``my``, ``used``: that message's Delta, reversed
    velocity -v_m and used SOC u. Returns True when sum omega < eta_w after the update and no
    message was heard at all (row D).
    """
    heard = False
    for x in range(3):
        count = 0
        sd = 0.0
        sx = 0.0
        sy = 0.0
        su = 0.0
        for j in range(key.shape[0]):
            if key[j] == x:
                count += 1
                sd += delta[j]
                sx += mx[j]
                sy += my[j]
                su += used[j]
        if count == 0:
            omega[x] = (1.0 - rho_w) * omega[x]
            continue
        heard = True
        omega[x] = (1.0 - rho_w) * omega[x] + rho_w * (sd / count)
        vx[x] = (1.0 - rho_v) * vx[x] + rho_v * (sx / count)
        vy[x] = (1.0 - rho_v) * vy[x] + rho_v * (sy / count)
        if init[x]:
            soc_cost[x] = min(1.0, (1.0 - rho_p) * soc_cost[x] + rho_p * phi_soc * (su / count))
        else:
            soc_cost[x] = min(1.0, phi_soc * (su / count))
            init[x] = True
    return (omega[0] + omega[1] + omega[2]) < eta_w and not heard


@njit(cache=True)
def avoidance_offset(hits, ray_length):
    """theta_avoidance of 7.4 from the 7 rays' hit distances ``hits`` (RAY_ANGLES order; np.inf
    where a ray hits nothing within ``ray_length``): (active, offset [rad]).

    The nearest hit (first in ray order on a tie) at bearing beta != 0 gives -sign(beta)
    (pi/2 - |beta|) (turn until it is abeam); straight ahead, +pi/2 when the left rays' summed
    free length is at least the right rays', else -pi/2."""
    nearest = -1
    best = np.inf
    for r in range(N_RAYS):
        if hits[r] < best:
            best = hits[r]
            nearest = r
    if nearest < 0:
        return False, 0.0
    beta = RAY_ANGLES[nearest]
    if beta > 0.0:
        return True, -(HALF_PI - beta)
    if beta < 0.0:
        return True, HALF_PI + beta
    left = 0.0
    right = 0.0
    for r in range(1, N_RAYS):
        free = min(hits[r], ray_length)
        if RAY_ANGLES[r] > 0.0:
            left += free
        else:
            right += free
    return True, HALF_PI if left >= right else -HALF_PI


@njit(cache=True)
def power_out(p_comp, p_comm, links, mobile, p_scan, moved, p_move, kappa, avoiding, p_avoid):
    """P_out of section 8 [W]: computation, links, scanning (mobile roles), locomotion (times
    kappa where the centre before the move is in the soft obstacle) and avoidance."""
    p = p_comp + p_comm * links
    if mobile:
        p += p_scan
    if moved:
        p += p_move * kappa
    if avoiding:
        p += p_avoid
    return p


@njit(cache=True)
def energy_step(energy, e_cap, p_in, p_out, tau, exploit):
    """E <- clip(E + (P_in - P_out) tau - exploit, 0, E_cap) [J] (section 8)."""
    e = energy + (p_in - p_out) * tau - exploit
    if e < 0.0:
        return 0.0
    if e > e_cap:
        return e_cap
    return e


@njit(cache=True)
def tick_energy(energy, pars, in_r, mobile, links, moved, kappa, avoiding, loaded):
    """One tick of section 8 for an alive robot: (new E [J], gross energy used [J]). Solar input
    P_solar whenever the centre is in R (``in_r``, any role), locomotion times ``kappa`` (the
    soft patch), E_exploit when it loaded this tick; E = 0 afterwards means death (row X)."""
    p_out = power_out(pars[P_COMP], pars[P_COMM], links, mobile, pars[P_SCAN], moved, pars[P_MOVE], kappa,
                      avoiding, pars[P_AVOID])
    p_in = pars[P_SOLAR] if in_r else 0.0
    exploit = pars[P_EXPLOIT] if loaded else 0.0
    return energy_step(energy, pars[P_ECAP], p_in, p_out, pars[P_TAU], exploit), p_out * pars[P_TAU] + exploit


@njit(cache=True)
def choose_row(role, mode, region, n_in_range, role_k1, role_k2, soc, s_hat, visited_r, full, loaded, no_r_guidance,
               baseline=False):
    """The row of section 9 (1..11; 0: none) that fires for an alive mobile robot: the first whose
    guard holds, from the robot's role and mode, its region (REG_* or NO_REGION), the number of
    beacons in range, its roles at k-1 and k-2, SOC, S_hat by key (3,), visited_R, E = E_cap,
    l > 0 and "no R guidance" (all from the section-5 snapshot). Row 3 also fires in role R (a
    no-op there: the robot already goes to charge, which keeps row 9 from firing). ``baseline``
    (the Ch 4 model, Eq 4-5): rows 2 and 3, the only ways into role R, never fire."""
    charging = mode == CHARGING
    if n_in_range == 0 and role_k1 != B and role_k2 != B and region != REG_N and mode != RECONNECT:
        return 1
    if not baseline and role != R and (soc < s_hat[role] or soc < s_hat[R]):
        return 2
    if not baseline and region == REG_N and not visited_r:
        return 3
    if role == R and not charging and region == REG_R:
        return 4
    if charging and full:
        if no_r_guidance:
            return 5
        return 7 if loaded else 6
    if role == F_IN and region == REG_N:
        return 8
    if role == R and not charging and region == REG_N and soc > s_hat[F_OUT] and soc > s_hat[R]:
        return 9
    if role == F_OUT and region == REG_T:
        return 10
    if role == R and not charging and region == REG_T and soc > s_hat[F_IN] and soc > s_hat[R]:
        return 11
    return 0


@njit(cache=True)
def broadcast_velocity(charging, motion, v0, pcx, pcy, mdx, mdy):
    """The reversed velocity -v_m a mobile robot broadcasts (section 5, A28): its planned
    velocity v0 (pcx, pcy), or with ``motion`` this tick's motion v0 (mdx, mdy); 0 while charging."""
    if charging:
        return 0.0, 0.0
    if motion:
        return -v0 * mdx, -v0 * mdy
    return -v0 * pcx, -v0 * pcy


@njit(cache=True)
def clear_memory(i, omega, bvx, bvy, bsoc, binit, weight):
    """Beacon memory of robot i back to omega = 0, v = 0, S = 0, init = false (L621)."""
    for q in range(3):
        omega[i, q] = 0.0
        bvx[i, q] = 0.0
        bvy[i, q] = 0.0
        bsoc[i, q] = 0.0
        binit[i, q] = False
        weight[i, q] = 0.0


@njit(cache=True)
def become_beacon(i, n_t, countdown, last_left, voided, omega, bvx, bvy, bsoc, binit, weight, ikey):
    """Robot i becomes a beacon (row 1): fresh memory and inbox, window countdown n_T (counted
    down from this tick on, section 11 step 8), and the trip in progress voided: no region counts
    as left until the robot next enters one (section 12)."""
    countdown[i] = n_t
    last_left[i] = NO_REGION
    voided[i] = True
    clear_memory(i, omega, bvx, bvy, bsoc, binit, weight)
    ikey[i, :] = -1


@njit(cache=True)
def region_change(i, k, old, new, role, last_left, voided, tick_left, role_left, acc, trips, n_trips, run_id):
    """Trip bookkeeping (section 12) of robot i whose region went from ``old`` to ``new`` at tick k:
    leaving a region starts a trip (``acc[i]`` = length, energy, soft length reset) unless a beacon
    spell ``voided[i]`` it, entering a region Y other than the last one left appends a trip record
    (and ends the voiding) to ``trips``, which has room for it (the kernel makes room for a trip per
    robot before each tick: no allocation in its tick loop). Returns the new n_trips, never the
    array: compiled without reference counts (inside ``run_ticks``), a returned array would be a
    reference its caller releases once too often."""
    if old != NO_REGION and not voided[i]:
        last_left[i] = old
        tick_left[i] = k
        role_left[i] = role
        acc[i, 0] = 0.0
        acc[i, 1] = 0.0
        acc[i, 2] = 0.0
    if new != NO_REGION:
        if last_left[i] != NO_REGION and last_left[i] != new:
            row = trips[n_trips]
            row[TR_RUN] = run_id
            row[TR_ORIGIN] = last_left[i]
            row[TR_DEST] = new
            row[TR_TICK_LEFT] = tick_left[i]
            row[TR_TICK_ENTERED] = k
            row[TR_LENGTH] = acc[i, 0]
            row[TR_ENERGY] = acc[i, 1]
            row[TR_SOFT] = acc[i, 2]
            row[TR_ROLE_LEFT] = role_left[i]
            row[TR_ROLE_ENTERED] = role
            row[TR_ROBOT] = i
            n_trips += 1
        last_left[i] = NO_REGION
        voided[i] = False
    return n_trips


@njit(cache=True)
def complete(i, key, s_c, n_failed, mode):
    """Robot i completes the region of ``key`` (Eq 5-7, section 10): s_c <- key, n_failed <- 0, and
    a RECONNECT or BACKTRACK robot is back in NORMAL (its failed attempts are over)."""
    s_c[i] = key
    n_failed[i] = 0
    if mode[i] == RECONNECT or mode[i] == BACKTRACK:
        mode[i] = NORMAL


# ------------------------------------------------------------------ outputs


@njit(cache=True)
def _room(rows, used, more):
    """``rows`` with room for ``more`` rows after ``used`` (doubled when full)."""
    if used + more <= rows.shape[0]:
        return rows
    bigger = np.empty((max(2 * rows.shape[0], used + more), rows.shape[1]))
    bigger[:used] = rows[:used]
    return bigger


@njit(cache=True)
def _snapshot(snaps, used, run, label, k, n, status, role, mode, x, y, theta, energy, e_cap, load,
              omega, bvx, bvy, bsoc):
    """Append one network snapshot (a row per robot) to ``snaps``, which has room for it; returns
    the rows used."""
    for i in range(n):
        row = snaps[used]
        row[SN_RUN] = run
        row[SN_LABEL] = label
        row[SN_K] = k
        row[SN_ROBOT] = i
        row[SN_STATUS] = status[i]
        row[SN_ROLE] = role[i]
        row[SN_MODE] = mode[i]
        row[SN_X] = x[i]
        row[SN_Y] = y[i]
        row[SN_HEADING] = theta[i]
        row[SN_SOC] = energy[i] / e_cap
        row[SN_LOAD] = load[i]
        beacon = status[i] == ALIVE and role[i] == B
        for q in range(3):
            row[SN_OMEGA + q] = omega[i, q] if beacon else 0.0
            row[SN_VX + q] = bvx[i, q] if beacon else 0.0
            row[SN_VY + q] = bvy[i, q] if beacon else 0.0
            row[SN_S + q] = bsoc[i, q] if beacon else 0.0
        used += 1
    return used


@njit(cache=True)
def alignment(n, status, role, x, y, omega, bvx, bvy, g, out, weighted):
    """Guidance alignment per key (section 12) over alive beacons with |v^X| > 0 into
    ``out[0:3]`` (mean cos) and ``weighted[0:3]`` (omega-weighted); NaN where none."""
    for q in range(3):
        total = 0.0
        count = 0
        wsum = 0.0
        wtotal = 0.0
        for i in range(n):
            if status[i] != ALIVE or role[i] != B:
                continue
            vx = bvx[i, q]
            vy = bvy[i, q]
            if vx == 0.0 and vy == 0.0:
                continue
            c = heading_alignment(x[i], y[i], vx, vy, g, q)
            if c != c:
                continue
            total += c
            count += 1
            wsum += omega[i, q] * c
            wtotal += omega[i, q]
        out[q] = total / count if count > 0 else np.nan
        weighted[q] = wsum / wtotal if wtotal > 0.0 else np.nan


# ------------------------------------------------------------------ the phases of a tick (section 11)
# Each phase is one step of section 11 over the plain arrays of run_runs (indexed by robot id);
# run_runs allocates them once per call and calls the phases in order every tick.


@njit(cache=True, inline='always')
def spawn(opts, pars, g, spawned, status, x, y, energy, soc_ref, search):
    """Step 1 (A33): the lowest-id unspawned robot spawns (ALIVE, E = SOC_ref E_cap, a random first
    decision) when no robot disc lies within 2 r_body of the spawn point; until then its SOC_ref is
    its initial SOC (soc0, or drawn from U(soc0_low, soc0), A39). Returns (spawned, new): the
    robots that exist now and the one spawned this tick (-1: none)."""
    n = opts[O_ROBOTS]
    r_body = pars[P_RBODY]
    touch2 = 4.0 * r_body * r_body
    spawn_x, spawn_y = g[G_SPAWN], g[G_SPAWN + 1]
    if spawned >= n:
        return spawned, -1
    for j in range(spawned):
        dx = x[j] - spawn_x
        dy = y[j] - spawn_y
        if dx * dx + dy * dy < touch2:
            return spawned, -1
    status[spawned] = ALIVE
    energy[spawned] = soc_ref[spawned] * pars[P_ECAP]
    search[spawned] = True             # its first heading is random (A33)
    return spawned + 1, spawned


@njit(cache=True, inline='always')
def sense_and_communicate(opts, pars, g, box, spawned, new, status, role, mode, x, y, energy, s_c, soc_ref, reg,
                          decided, immediate, heading, memory, sensed, inbox):
    """Step 2 (section 5): the snapshot of the end of tick k-1 (``sx``, ``sy``, distances ``d2`` of the
    mobile robots), links (``nb_list``: the beacons in range of each mobile robot, ``links``), S_hat,
    "no R guidance", the nearest beacon, and the mobile broadcasts written into the inboxes of the
    beacons in range. The robot spawned this tick (``new``) senses nothing, is not sensed, is silent.
    With ``experience = "leaving"`` a beacon takes a message only from a robot moving away from
    region(s_c): its broadcast velocity has a positive component along centre -> robot (Sec 4-1-3)."""
    _, _, pcx, pcy, mdx, mdy = heading
    omega, bvx, bvy, bsoc, binit, _ = memory
    sx, sy, d2, nb_cnt, nb_list, mb_cnt, beacons, links, s_hat, no_r_guidance, nearest = sensed
    ikey, idelta, ivx, ivy, iu = inbox
    comm = pars[P_COMM_R]
    comm2 = comm * comm
    r_body = pars[P_RBODY]
    reward, lam, v0, e_cap = pars[P_REWARD], pars[P_LAMBDA], pars[P_V0], pars[P_ECAP]
    hard = int(g[G_KIND]) == KIND_HARD
    los_bodies = opts[O_LOS_BODIES] != 0
    redecide = opts[O_REDECIDE]
    bcast_update = opts[O_BCAST_UPDATE] != 0
    bcast_motion = opts[O_BCAST_MOTION] != 0
    leaving = opts[O_EXPERIENCE_LEAVING] != 0
    for i in range(spawned):                # a loop: a slice copy may allocate (numba's overlap check)
        sx[i] = x[i]
        sy[i] = y[i]
    for i in range(spawned):
        if status[i] != ALIVE or role[i] == B:
            continue                       # only mobile robots sense, link and move
        xi = x[i]
        yi = y[i]
        for j in range(spawned):
            dx = x[j] - xi
            dy = y[j] - yi
            d2[i, j] = dx * dx + dy * dy
    n_beacons = 0
    for i in range(spawned):
        nb_cnt[i] = 0
        mb_cnt[i] = 0
        if status[i] == ALIVE and role[i] == B:
            beacons[n_beacons] = i
            n_beacons += 1
    for i in range(spawned):
        if status[i] != ALIVE or role[i] == B or i == new:
            continue
        for q in range(n_beacons):
            b = beacons[q]
            if d2[i, b] >= comm2:
                continue
            if hard and min(x[i], x[b]) <= box[2] and max(x[i], x[b]) >= box[0] and \
                    min(y[i], y[b]) <= box[3] and max(y[i], y[b]) >= box[1] and \
                    segment_blocked(x[i], y[i], x[b], y[b], g):
                continue
            if los_bodies:
                occluded = False
                for o in range(spawned):
                    if o != i and o != b and o != new and status[o] != UNSPAWNED and \
                            segment_point_dist2(x[i], y[i], x[b], y[b], x[o], y[o]) < r_body * r_body:
                        occluded = True
                        break
                if occluded:
                    continue
            nb_list[i, nb_cnt[i]] = b
            nb_cnt[i] += 1
            mb_cnt[b] += 1
    for i in range(spawned):
        if status[i] != ALIVE:
            continue
        if role[i] == B:
            links[i] = mb_cnt[i]
            continue
        links[i] = nb_cnt[i]
        best_omega = 0.0
        no_r = True
        near = -1
        for x_key in range(3):
            s_hat[i, x_key] = 0.0
        for q in range(nb_cnt[i]):
            b = nb_list[i, q]
            best_omega = max(best_omega, omega[b, s_c[i]])
            for x_key in range(3):
                if binit[b, x_key] and bsoc[b, x_key] > s_hat[i, x_key]:
                    s_hat[i, x_key] = bsoc[b, x_key]
            if bvx[b, R] * bvx[b, R] + bvy[b, R] * bvy[b, R] > NO_GUIDANCE2:
                no_r = False
            if near < 0 or d2[i, b] < d2[i, near]:
                near = b
        no_r_guidance[i] = no_r
        if redecide == REDECIDE_BEACON_CHANGE and near != nearest[i]:
            immediate[i] = True
        nearest[i] = near
        if nb_cnt[i] == 0 or (bcast_update and not decided[i]):
            continue
        # the broadcast (s_c, Delta, -v_m, u) heard by every beacon in range
        gamma = reward if reg[i] == s_c[i] else 0.0
        delta = gamma + lam * best_omega
        mvx, mvy = broadcast_velocity(mode[i] == CHARGING, bcast_motion, v0, pcx[i], pcy[i], mdx[i], mdy[i])
        # -v_m points back at region(s_c) only while the robot moves away from it (Sec 4-1-3)
        if leaving and mvx * (x[i] - g[G_CX + s_c[i]]) + mvy * (y[i] - g[G_CY + s_c[i]]) >= 0.0:
            continue
        used = max(0.0, soc_ref[i] - energy[i] / e_cap)
        for q in range(nb_cnt[i]):
            b = nb_list[i, q]
            ikey[b, i] = s_c[i]
            idelta[b, i] = delta
            ivx[b, i] = mvx
            ivy[b, i] = mvy
            iu[b, i] = used
    decided[:spawned] = False


@njit(cache=True, inline='always')
def roles_and_region_actions(opts, pars, table, k, spawned, sup, status, role, mode, reg, load, loaded_now, s_c,
                             n_failed, role_k1, role_k2, energy, visited_r, countdown, immediate, search, heading,
                             motion, memory, inbox, sensed, trip, row_counts, t_first, tally):
    """Step 3 (sections 9, 10): in ascending id, each alive mobile robot unloads in N, completes its
    region, fires the first row of section 9 whose guard holds (through the role supervisor
    ``table``; row 1 makes it a beacon), loads on rows 10 and 11 and turns on the rows of 7.2.
    Counts the rows in ``row_counts``, the units and unloads in ``tally`` and the first row 5 in
    ``t_first[2]``; each robot's unloads, loads and charging sessions in its ``ledger`` row, and each
    row 2 as a trigger record (``triggers``, which has room for one per robot)."""
    theta_a, theta, pcx, pcy, _, _ = heading
    blocked, avoiding, _, _, _, _ = motion
    omega, bvx, bvy, bsoc, binit, weight = memory
    ikey = inbox[0]
    sx, sy, nb_cnt, s_hat, no_r_guidance = sensed[0], sensed[1], sensed[3], sensed[8], sensed[9]
    last_left, voided, ledger, triggers, n_triggers = trip[0], trip[1], trip[5], trip[6], trip[7]
    n_t = opts[O_NT]
    r_max = opts[O_RMAX]
    completion_last = opts[O_COMPLETION_LAST] != 0
    turn_any = opts[O_TURN_ANY] != 0
    baseline = opts[O_BASELINE] != 0
    e_cap = pars[P_ECAP]
    for i in range(spawned):
        loaded_now[i] = False
        if status[i] != ALIVE or role[i] == B:
            continue
        r0 = role[i]
        rg = reg[i]
        if rg == REG_N and load[i] > 0 and take(table, sup, i, EV_UNLOAD):
            tally[TL_RESOURCES] += load[i]
            tally[TL_UNLOADS] += 1
            ledger[i, LG_UNLOADS] += 1.0
            load[i] = 0
        if completion_last:
            if rg != NO_REGION:
                complete(i, rg, s_c, n_failed, mode)
        elif rg == r0:                     # F_OUT in T, F_IN in N, R in R
            complete(i, r0, s_c, n_failed, mode)
        row = choose_row(r0, mode[i], rg, nb_cnt[i], role_k1[i], role_k2[i], energy[i] / e_cap, s_hat[i],
                         visited_r[i], energy[i] == e_cap, load[i] > 0, no_r_guidance[i], baseline)
        if row == 0 or (row == 3 and r0 == R):
            continue                       # row 3 in role R: already going to charge
        if not take(table, sup, i, ROW_EVENT[row]):
            continue                       # the supervisor forbids it: the row does not fire
        state = sup[i, 0]
        role[i] = ROLE_OF_STATE[state]     # the role IS the supervisor's state
        if state == S_R_CHARGING:
            mode[i] = CHARGING
        elif mode[i] == CHARGING or row == 1:
            mode[i] = NORMAL
        if row == 1:
            become_beacon(i, n_t, countdown, last_left, voided, omega, bvx, bvy, bsoc, binit, weight, ikey)
            avoiding[i] = False
            blocked[i] = 0
            immediate[i] = False
            search[i] = False
        elif row == 2:
            rec = triggers[n_triggers[0]]
            n_triggers[0] += 1
            rec[TG_ROBOT] = i
            rec[TG_K] = k
            rec[TG_ROLE] = r0
            rec[TG_SOC] = energy[i] / e_cap
            rec[TG_S_HAT_DEST] = s_hat[i, r0]
            rec[TG_S_HAT_R] = s_hat[i, R]
            rec[TG_X] = sx[i]
            rec[TG_Y] = sy[i]
        elif row == 4:
            ledger[i, LG_RECHARGES] += 1.0
        elif row == 5 and t_first[2] < 0:
            t_first[2] = k
            tally[TL_MILESTONES] |= 1 << LABEL_FIRST_ROW5
        if row == 9:                       # A17: rows 9 and 11 complete N and T
            complete(i, F_IN, s_c, n_failed, mode)
        elif row == 11:
            complete(i, F_OUT, s_c, n_failed, mode)
        if (row == 10 or row == 11) and take(table, sup, i, EV_LOAD):
            load[i] = r_max
            loaded_now[i] = True
            ledger[i, LG_LOADS] += 1.0
        # 7.2 (A26): turn on the role changes inside a region (rows 3, 5-11); "any": row 2 too
        if (row == 3 or row >= 5 or (row == 2 and turn_any)) and take(table, sup, i, EV_TURN_AROUND):
            theta_a[i] = wrap(theta[i] + PI)
            theta[i] = theta_a[i]
            pcy[i], pcx[i] = sincos(theta_a[i])
        row_counts[row - 1] += 1


@njit(cache=True, inline='always')
def heading_decisions(opts, pars, rng, spawned, status, role, mode, n_failed, bt_budget, bt_travel, immediate,
                      countdown, search, s_c, visited_r, decided, heading, memory, sensed, motion):
    """Step 4 (7.1, 7.3): the RECONNECT contact test (-> BACKTRACK, an immediate decision), the
    countdown of every mobile robot (restarted at n_T when at 0), and the heading decision of each
    NORMAL or BACKTRACK robot that is due or decides immediately: guidance by its key (with the
    fallbacks of A18) or a random search, two draws of its stream either way. A decision restarts
    the distance driven towards the next one (``decision_step_m``, A1)."""
    theta_a, theta, pcx, pcy, _, _ = heading
    driven = motion[5]
    _, bvx, bvy, _, _, weight = memory
    nb_cnt, nb_list = sensed[3], sensed[4]
    n_t = opts[O_NT]
    fallback_literal = opts[O_FALLBACK_LITERAL] != 0
    baseline = opts[O_BASELINE] != 0     # Ch 4 (Eq 4-11): no R key to fall back on
    comm = pars[P_COMM_R]
    eps = pars[P_EPS]
    for i in range(spawned):
        if status[i] != ALIVE or role[i] == B:
            continue
        if mode[i] == RECONNECT and nb_cnt[i] > 0:
            mode[i] = BACKTRACK
            bt_budget[i] = n_failed[i] * 0.5 * comm
            bt_travel[i] = 0.0
            immediate[i] = True
        due = countdown[i] <= 0
        if due:
            countdown[i] = n_t
        countdown[i] -= 1
        if not (due or immediate[i]):
            continue
        immediate[i] = False
        if mode[i] == BACKTRACK:
            gx, gy = guidance(nb_list[i], nb_cnt[i], weight, bvx, bvy, s_c[i])
            if gx == 0.0 and gy == 0.0:
                mode[i] = NORMAL
        elif mode[i] != NORMAL:
            search[i] = False              # charging since: no decision left to make random
            continue
        if search[i]:                      # a random search: no guidance, both draws taken
            search[i] = False
            gx, gy = 0.0, 0.0
        elif mode[i] == NORMAL:
            key = role[i]
            gx, gy = guidance(nb_list[i], nb_cnt[i], weight, bvx, bvy, key)
            if gx == 0.0 and gy == 0.0:
                if key == F_IN and not baseline:
                    gx, gy = guidance(nb_list[i], nb_cnt[i], weight, bvx, bvy, R)
                elif key == R and (visited_r[i] or fallback_literal):
                    gx, gy = guidance(nb_list[i], nb_cnt[i], weight, bvx, bvy, F_IN)
        u = uniform(rng, 0, i)
        o = (2.0 * uniform(rng, 0, i) - 1.0) * PI
        theta_a[i] = follow_or_search(gx, gy, theta[i], u, o, eps)[0]
        theta[i] = theta_a[i]
        pcy[i], pcx[i] = sincos(theta_a[i])
        decided[i] = True
        driven[i] = 0.0


@njit(cache=True, inline='always')
def avoidance(opts, pars, g, box, ray_c, ray_s, spawned, new, status, role, mode, x, y, immediate, heading, motion,
              sensed, hits, close, n_near):
    """Step 5, first half (7.4): for each robot about to translate, theta <- theta_a and the 7 IR
    rays of length r_body + d_IR against the walls, the hard obstacle and the snapshot's bodies; a hit
    turns this tick's motion heading by :func:`avoidance_offset` (and the plan with ``avoidance =
    "turn"``). Sets the motion direction (``mdx``, ``mdy``) translation takes and each robot's
    bodies within reach of a ray or a step (``close[i, :n_near[i]]``)."""
    theta_a, theta, pcx, pcy, mdx, mdy = heading
    _, avoiding, was_avoiding, _, _, _ = motion
    sx, sy, d2 = sensed[0], sensed[1], sensed[2]
    avoid_turn = opts[O_AVOID_TURN] != 0
    redecide = opts[O_REDECIDE]
    r_body = pars[P_RBODY]
    ray_len = r_body + pars[P_IR]
    margin = 2.0 * (pars[P_V0] * pars[P_TAU]) + 1e-9   # how far two robots can close in within a tick
    ray_reach = ray_len + r_body + margin
    ray_reach2 = ray_reach * ray_reach
    field_w, field_h = g[G_W], g[G_H]
    hard = int(g[G_KIND]) == KIND_HARD
    for i in range(spawned):
        was_avoiding[i] = avoiding[i]
        avoiding[i] = False
        if status[i] != ALIVE or role[i] == B or mode[i] == CHARGING:
            continue
        xi = x[i]
        yi = y[i]
        theta[i] = theta_a[i]
        cx = pcx[i]
        cy = pcy[i]
        any_hit = False
        near_wall = xi < ray_len or yi < ray_len or xi > field_w - ray_len or yi > field_h - ray_len
        near_obstacle = hard and near_box(xi, yi, ray_len, box)
        count = 0                          # bodies a ray or this tick's step can reach
        for j in range(spawned):
            if d2[i, j] < ray_reach2 and j != i and status[j] != UNSPAWNED:
                close[i, count] = j
                count += 1
        n_near[i] = count
        for r in range(N_RAYS if i != new else 0):
            hits[r] = np.inf
            rdx = cx * ray_c[r] - cy * ray_s[r]
            rdy = cy * ray_c[r] + cx * ray_s[r]
            best = np.inf
            if near_wall:
                best = min(best, ray_walls(xi, yi, rdx, rdy, field_w, field_h))
            if near_obstacle:
                c = G_CORNERS
                for e in range(4):
                    f = (e + 1) % 4
                    best = min(best, ray_segment(xi, yi, rdx, rdy, g[c + 2 * e], g[c + 2 * e + 1],
                                                 g[c + 2 * f], g[c + 2 * f + 1]))
            for q in range(count):
                j = close[i, q]
                if j != new:               # the rays see the snapshot (section 5, A29)
                    best = min(best, ray_disc(xi, yi, rdx, rdy, sx[j], sy[j], r_body))
            if best <= ray_len:
                hits[r] = best
                any_hit = True
        if any_hit:
            active, offset = avoidance_offset(hits, ray_len)
            avoiding[i] = active
            theta[i] = wrap(theta_a[i] + offset)
            cy, cx = sincos(theta[i])
            if avoid_turn:
                theta_a[i] = theta[i]
                pcx[i] = cx
                pcy[i] = cy
        elif redecide == REDECIDE_AVOID_CLEAR and was_avoiding[i]:
            immediate[i] = True
        mdx[i] = cx
        mdy[i] = cy


@njit(cache=True, inline='always')
def translation(opts, pars, g, box, rng, spawned, status, role, mode, x, y, immediate, search, rc_travel, bt_travel,
                bt_budget, heading, motion, sensed, trip, close, n_near):
    """Step 5, second half (7.5): in ascending id, each robot about to translate steps v0 tau along
    (``mdx``, ``mdy``) unless the disc there leaves the field, overlaps the hard obstacle or a
    body at its position already updated this tick (A29); ``blocked_limit`` blocked ticks in a row
    give a new random plan. Accumulates the trip's length (soft part, with kappa), the ticks moved
    (``ledger``), the RECONNECT and BACKTRACK distances (their ends: NORMAL, an immediate decision)
    and, with ``decision_step_m`` > 0, the distance driven since the last decision (at the step: an
    immediate decision, A1)."""
    theta_a, theta, pcx, pcy, mdx, mdy = heading
    blocked, _, _, moved, kappa, driven = motion
    d2 = sensed[2]
    acc, ledger = trip[4], trip[5]
    blocked_limit = opts[O_BLOCKED]
    r_body = pars[P_RBODY]
    step = pars[P_V0] * pars[P_TAU]
    d_rc = 2.0 * pars[P_COMM_R]
    margin = 2.0 * step + 1e-9
    touch2 = 4.0 * r_body * r_body
    touch_reach = 2.0 * r_body + margin
    touch_reach2 = touch_reach * touch_reach
    field_w, field_h = g[G_W], g[G_H]
    kind = int(g[G_KIND])
    hard = kind == KIND_HARD
    soft = kind == KIND_SOFT
    kappa_soft = pars[P_KAPPA]
    decision_step = pars[P_DECISION_STEP]
    for i in range(spawned):
        moved[i] = False
        if status[i] != ALIVE or role[i] == B or mode[i] == CHARGING:
            continue
        xi = x[i]
        yi = y[i]
        nx = xi + step * mdx[i]
        ny = yi + step * mdy[i]
        ok = r_body <= nx <= field_w - r_body and r_body <= ny <= field_h - r_body
        if ok and hard and near_box(nx, ny, r_body, box):
            ok = not disc_hits_quad(nx, ny, r_body, g)
        if ok:
            for q in range(n_near[i]):
                j = close[i, q]
                if d2[i, j] < touch_reach2:
                    dx = nx - x[j]
                    dy = ny - y[j]
                    if dx * dx + dy * dy < touch2:
                        ok = False
                        break
        if ok:
            kappa[i] = 1.0
            if soft and inside_quad(xi, yi, g):
                kappa[i] = kappa_soft
                acc[i, 2] += step
            x[i] = nx
            y[i] = ny
            moved[i] = True
            blocked[i] = 0
            acc[i, 0] += step
            ledger[i, LG_MOVES] += 1.0
            if mode[i] == RECONNECT:
                rc_travel[i] += step
                if rc_travel[i] >= d_rc:
                    mode[i] = NORMAL
                    immediate[i] = True
                    search[i] = True
            elif mode[i] == BACKTRACK:
                bt_travel[i] += step
                if bt_travel[i] >= bt_budget[i]:
                    mode[i] = NORMAL
                    immediate[i] = True
            if decision_step > 0.0 and (mode[i] == NORMAL or mode[i] == BACKTRACK):
                driven[i] += step
                if driven[i] >= decision_step:
                    immediate[i] = True
        else:
            blocked[i] += 1
            if blocked[i] >= blocked_limit:
                theta_a[i] = wrap(theta[i] + (2.0 * uniform(rng, 0, i) - 1.0) * PI)
                theta[i] = theta_a[i]
                pcy[i], pcx[i] = sincos(theta_a[i])
                blocked[i] = 0


@njit(cache=True, inline='always')
def energy_and_deaths(opts, pars, g, table, spawned, sup, status, role, x, y, here, loaded_now, energy, motion, sensed,
                      trip, tally):
    """Step 6 (section 8): each alive robot's energy by :func:`tick_energy` (solar input where its
    centre is in R after the move, ``here``: its region now), the gross energy added to its trip,
    and death at E = 0 (row X), counted in ``tally``; in the robot's ``ledger`` row its energy, the
    tick in its role and the tick it died. With ``depletion = "recorded"`` a robot at E = 0 lives on
    (E stays clipped at 0) and a forager takes role R (goCharge) as a robot in role R would go on;
    either way each E reaching 0 from above counts as a depletion."""
    _, avoiding, _, moved, kappa, _ = motion
    links = sensed[7]
    acc, ledger = trip[4], trip[5]
    recorded = opts[O_DEPLETION_RECORDED] != 0
    for i in range(spawned):
        if status[i] != ALIVE:
            continue
        before = energy[i]
        here[i] = region_of(x[i], y[i], g)
        energy[i], used = tick_energy(energy[i], pars, here[i] == REG_R, role[i] != B, links[i], moved[i], kappa[i],
                                      avoiding[i], loaded_now[i])
        acc[i, 1] += used
        ledger[i, LG_ENERGY] += used
        ledger[i, LG_TICKS + role[i]] += 1.0
        if energy[i] != 0.0:
            continue
        if not recorded:
            if take(table, sup, i, EV_DEPLETED):
                status[i] = DEAD
                tally[TL_DEATHS] += 1
                tally[TL_DEPLETIONS] += 1
                ledger[i, LG_DIED_K] = tally[TL_TICK]
        elif before > 0.0:
            tally[TL_DEPLETIONS] += 1
            if (role[i] == F_OUT or role[i] == F_IN) and take(table, sup, i, EV_GO_CHARGE):
                role[i] = ROLE_OF_STATE[sup[i, 0]]


@njit(cache=True, inline='always')
def bookkeeping(pars, k, run_id, spawned, status, role, s_c, energy, here, reg, soc_ref, visited_r, trip, trips,
                n_trips, t_first, tally):
    """Step 7 (sections 10, 12): for each robot alive after step 6, SOC_ref inside region(s_c),
    visited_R, and the region it entered or left (``here`` against ``reg``): trip records, the
    first entries into T and R. Returns n_trips (``trips`` has room for a trip per robot)."""
    last_left, voided, tick_left, role_left, acc = trip[0], trip[1], trip[2], trip[3], trip[4]
    e_cap = pars[P_ECAP]
    for i in range(spawned):
        if status[i] != ALIVE:
            continue
        newreg = here[i]
        if newreg == s_c[i]:
            soc_ref[i] = energy[i] / e_cap
        if newreg == REG_R:
            visited_r[i] = True
        old = reg[i]
        if old != newreg:
            n_trips = region_change(i, k, old, newreg, role[i], last_left, voided, tick_left, role_left,
                                    acc, trips, n_trips, run_id)
            if newreg != NO_REGION:
                if newreg == REG_T and t_first[0] < 0:
                    t_first[0] = k
                    tally[TL_MILESTONES] |= 1 << LABEL_FIRST_T
                elif newreg == REG_R and t_first[1] < 0:
                    t_first[1] = k
                    tally[TL_MILESTONES] |= 1 << LABEL_FIRST_R
            reg[i] = newreg
    return n_trips


@njit(cache=True, inline='always')
def beacon_windows(opts, pars, table, spawned, sup, status, role, mode, countdown, n_failed, rc_travel, heading, memory,
                   inbox, row_counts):
    """Step 8 (section 6, 7.3): each alive beacon counts its window down; at 0 (restarted at n_T) it
    updates its memory from its inbox (:func:`beacon_update`), empties the inbox, recomputes its
    weights and, when it decays, reverts (row D): role s_prev, RECONNECT, n_failed + 1, memory
    cleared, the 7.3 turn."""
    theta_a, theta, pcx, pcy, _, _ = heading
    omega, bvx, bvy, bsoc, binit, weight = memory
    ikey, idelta, ivx, ivy, iu = inbox
    n_t = opts[O_NT]
    wform = opts[O_WFORM]
    rho_w, rho_v, rho_p = pars[P_RHO_W], pars[P_RHO_V], pars[P_RHO_P]
    rho_f, rho_c = pars[P_RHO_F], pars[P_RHO_C]
    for i in range(spawned):
        if status[i] != ALIVE or role[i] != B:
            continue
        countdown[i] -= 1
        if countdown[i] > 0:
            continue
        countdown[i] = n_t
        decays = beacon_update(omega[i], bvx[i], bvy[i], bsoc[i], binit[i], ikey[i], idelta[i],
                               ivx[i], ivy[i], iu[i], rho_w, rho_v, rho_p, pars[P_PHI], pars[P_ETA_W])
        ikey[i, :] = -1
        for q in range(3):
            weight[i, q] = beacon_weight(omega[i, q], bsoc[i, q], binit[i, q], rho_f, rho_c, wform)
        if decays and take(table, sup, i, EV_REVERT):
            role[i] = ROLE_OF_STATE[sup[i, 0]]     # s_prev, remembered by the beacon state
            mode[i] = RECONNECT
            n_failed[i] += 1
            rc_travel[i] = 0.0
            clear_memory(i, omega, bvx, bvy, bsoc, binit, weight)
            if take(table, sup, i, EV_TURN_AROUND):
                theta_a[i] = wrap(theta[i] + PI)
                theta[i] = theta_a[i]
                pcy[i], pcx[i] = sincos(theta_a[i])
            row_counts[ROW_D - 1] += 1


@njit(cache=True, inline='always')
def records(opts, pars, g, k, run, run_id, spawned, status, role, role_k1, role_k2, mode, x, y, energy, load, heading,
            memory, row_counts, f_hist, nb_hist, series, align, align_w, counts, tally, snaps, n_snaps):
    """Step 9 (section 12): the roles at k-1 and k-2, F and n_B of tick k, the time-series record
    every n_T ticks (``series[run]``) and the snapshots due this tick (the milestones reached,
    periodic, frames, the end; ``snaps`` has room for them). ``counts`` (8,) int64: scratch.
    Returns n_snaps."""
    theta = heading[1]
    omega, bvx, bvy, bsoc, _, _ = memory
    resources = tally[TL_RESOURCES]
    milestones = tally[TL_MILESTONES]
    n = opts[O_ROBOTS]
    n_ticks = opts[O_TICKS]
    n_t = opts[O_NT]
    rate_w = opts[O_RATE_W]
    snap_every = opts[O_SNAP_EVERY]
    frame_every = opts[O_FRAMES]
    e_cap = pars[P_ECAP]
    soc0 = pars[P_SOC0]
    n_rec = n_ticks // n_t
    n_b = 0
    for i in range(spawned):
        role_k2[i] = role_k1[i]
        role_k1[i] = role[i]
        if status[i] == ALIVE and role[i] == B:
            n_b += 1
    f_hist[k] = resources
    nb_hist[k] = n_b
    if k % n_t == 0 and k // n_t <= n_rec:
        rec = series[run, k // n_t - 1]
        rec[TS_K] = k
        rec[TS_RESOURCES] = resources
        rec[TS_TRIPS] = tally[TL_UNLOADS]
        rec[TS_INTERRUPTIONS] = row_counts[1]
        rec[TS_NEST_RECHARGES] = row_counts[2]
        rec[TS_SESSIONS] = row_counts[3]
        rec[TS_RATE] = resources - (f_hist[k - rate_w] if k >= rate_w else 0)
        counts[:] = 0
        soc_sum = 0.0
        soc_b = 0.0
        soc_m = 0.0
        soc_min = np.inf
        units_b = 0
        for i in range(n):
            soc = energy[i] / e_cap
            if status[i] == UNSPAWNED:
                counts[3] += 1
                soc_sum += soc0
                continue
            soc_sum += soc
            if status[i] == DEAD:
                counts[2] += 1
            elif role[i] == B:
                counts[1] += 1
                soc_b += soc
                soc_min = min(soc_min, soc)
                units_b += load[i]
            else:
                counts[0] += 1
                counts[4 + role[i]] += 1
                soc_m += soc
        rec[TS_MOBILE] = counts[0]
        rec[TS_BEACONS] = counts[1]
        rec[TS_DEAD] = counts[2]
        rec[TS_UNSPAWNED] = counts[3]
        rec[TS_F_OUT] = counts[4 + F_OUT]
        rec[TS_F_IN] = counts[4 + F_IN]
        rec[TS_R] = counts[4 + R]
        rec[TS_SOC_SUM] = soc_sum
        rec[TS_SOC_BEACONS] = soc_b
        rec[TS_SOC_MOBILE] = soc_m
        rec[TS_SOC_MIN_BEACON] = soc_min if counts[1] > 0 else np.nan
        rec[TS_UNITS_BEACONS] = units_b
        alignment(n, status, role, x, y, omega, bvx, bvy, g, align, align_w)
        for q in range(3):
            rec[TS_ALIGN + q] = align[q]
    for label in (LABEL_FIRST_T, LABEL_FIRST_R, LABEL_FIRST_ROW5):
        if milestones & (1 << label):
            n_snaps = _snapshot(snaps, n_snaps, run_id, label, k, n, status, role, mode, x, y,
                                       theta, energy, e_cap, load, omega, bvx, bvy, bsoc)
    if k % snap_every == 0:
        n_snaps = _snapshot(snaps, n_snaps, run_id, LABEL_PERIODIC, k, n, status, role, mode, x,
                                   y, theta, energy, e_cap, load, omega, bvx, bvy, bsoc)
    if frame_every > 0 and k % frame_every == 0:
        n_snaps = _snapshot(snaps, n_snaps, run_id, LABEL_FRAME, k, n, status, role, mode, x,
                                   y, theta, energy, e_cap, load, omega, bvx, bvy, bsoc)
    if k == n_ticks:
        n_snaps = _snapshot(snaps, n_snaps, run_id, LABEL_END, k, n, status, role, mode, x,
                                   y, theta, energy, e_cap, load, omega, bvx, bvy, bsoc)
    return n_snaps


# ------------------------------------------------------------------ the kernel


@borrowing
def run_ticks(opts, pars, g, box, ray_c, ray_s, table, stop, rng, run, run_id, first, spawned, status, sup, role, mode,
              role_k1, role_k2, x, y, energy, load, s_c, soc_ref, visited_r, n_failed, bt_budget, bt_travel, rc_travel,
              countdown, immediate, search, decided, reg, loaded_now, here, heading, motion, memory, inbox, sensed,
              trip, hits, close, n_near, counts, row_counts, t_first, tally, f_hist, nb_hist, series, align, align_w,
              trips, n_trips, snaps, n_snaps):
    """Ticks ``first``, ``first`` + 1, ... K of run ``run`` (section 11: a call of each phase per tick, in
    order) over the arrays :func:`run_runs` allocated, until the end, Ctrl-C (``stop``) or a tick that
    might not find room for its trips (a row per robot) or snapshots (SNAPS_PER_TICK per robot) in
    ``trips``, ``snaps`` and the row-2 triggers (a row per robot; ``trip[6]``, its rows used ``trip[7][0]``).
    Returns (next tick, robots spawned, n_trips, n_snaps); run_runs makes room and calls
    again. Compiled without reference counts (it borrows every array and allocates nothing), with
    every phase inlined: a tick costs what the single loop it was cost."""
    n = opts[O_ROBOTS]
    n_ticks = opts[O_TICKS]
    for k in range(first, n_ticks + 1):
        if stop[0] != 0 or n_trips + n > trips.shape[0] or n_snaps + SNAPS_PER_TICK * n > snaps.shape[0] or \
                trip[7][0] + n > trip[6].shape[0]:
            return k, spawned, n_trips, n_snaps
        tally[TL_MILESTONES] = 0
        tally[TL_TICK] = k
        spawned, new = spawn(opts, pars, g, spawned, status, x, y, energy, soc_ref, search)
        sense_and_communicate(opts, pars, g, box, spawned, new, status, role, mode, x, y, energy, s_c, soc_ref, reg,
                              decided, immediate, heading, memory, sensed, inbox)
        roles_and_region_actions(opts, pars, table, k, spawned, sup, status, role, mode, reg, load, loaded_now,
                                 s_c, n_failed, role_k1, role_k2, energy, visited_r, countdown, immediate, search,
                                 heading, motion, memory, inbox, sensed, trip, row_counts, t_first, tally)
        heading_decisions(opts, pars, rng, spawned, status, role, mode, n_failed, bt_budget, bt_travel, immediate,
                          countdown, search, s_c, visited_r, decided, heading, memory, sensed, motion)
        avoidance(opts, pars, g, box, ray_c, ray_s, spawned, new, status, role, mode, x, y, immediate, heading,
                  motion, sensed, hits, close, n_near)
        translation(opts, pars, g, box, rng, spawned, status, role, mode, x, y, immediate, search, rc_travel,
                    bt_travel, bt_budget, heading, motion, sensed, trip, close, n_near)
        energy_and_deaths(opts, pars, g, table, spawned, sup, status, role, x, y, here, loaded_now, energy, motion,
                          sensed, trip, tally)
        n_trips = bookkeeping(pars, k, run_id, spawned, status, role, s_c, energy, here, reg, soc_ref, visited_r, trip,
                              trips, n_trips, t_first, tally)
        beacon_windows(opts, pars, table, spawned, sup, status, role, mode, countdown, n_failed, rc_travel,
                       heading, memory, inbox, row_counts)
        n_snaps = records(opts, pars, g, k, run, run_id, spawned, status, role, role_k1, role_k2, mode, x, y, energy,
                          load, heading, memory, row_counts, f_hist, nb_hist, series, align, align_w, counts, tally,
                          snaps, n_snaps)
    return n_ticks + 1, spawned, n_trips, n_snaps


@njit(cache=True, nogil=True)
def run_runs(opts, pars, g, seeds, runs, table, start, stop):
    """Every run of one configuration.

    Parameters
    ----------
    opts : (N_OPTS,) int64, pars : (N_PARS,) float64
        Options and parameters (O_* and P_* indices).
    g : (22,) float64
        Geometry (layout.kernel_geometry).
    seeds, runs : (n_runs,) int64
        Root seed and index of each run.
    table : (1, states, 10) int64
        The role supervisor's transition table over the EV_* columns.
    start : (0, N_STATE) or (robots, N_STATE) float64
        Empty: every run starts as section 11 says (all robots unspawned). Else (tests): every run
        starts from this hand-built state (ST_* columns; the robots that exist come first, the
        role is the supervisor state ST_SUP; beacon weights follow from the memory; inboxes
        empty), and the state at the end of the last run is written back into it (ST_LINKS,
        ST_AVOIDING: of the last tick).
    stop : (1,) int8
        Ctrl-C flag, checked every tick.

    Returns
    -------
    summary (n_runs, N_SUMMARY), series (n_runs, K // n_T, N_SERIES), trips (rows, N_TRIP),
    snapshots (rows, N_SNAP), robots (n_runs * robots, N_LEDGER: each robot's record of each run),
    row-2 triggers (rows, N_TRIGGER), all float64 (integers stored exactly).
    """
    n = opts[O_ROBOTS]
    n_ticks = opts[O_TICKS]
    n_t = opts[O_NT]
    wform = opts[O_WFORM]
    init_state = opts[O_INIT_STATE]
    tau = pars[P_TAU]
    rho_f, rho_c = pars[P_RHO_F], pars[P_RHO_C]
    e_cap = pars[P_ECAP]
    soc0 = pars[P_SOC0]
    soc0_low = pars[P_SOC0_LOW]
    kind = int(g[G_KIND])
    box = np.empty(4)
    if kind != KIND_NONE:
        box[0] = min(g[G_CORNERS + 0], g[G_CORNERS + 2], g[G_CORNERS + 4], g[G_CORNERS + 6])
        box[1] = min(g[G_CORNERS + 1], g[G_CORNERS + 3], g[G_CORNERS + 5], g[G_CORNERS + 7])
        box[2] = max(g[G_CORNERS + 0], g[G_CORNERS + 2], g[G_CORNERS + 4], g[G_CORNERS + 6])
        box[3] = max(g[G_CORNERS + 1], g[G_CORNERS + 3], g[G_CORNERS + 5], g[G_CORNERS + 7])
    spawn_x, spawn_y = g[G_SPAWN], g[G_SPAWN + 1]
    ray_c = np.empty(N_RAYS)
    ray_s = np.empty(N_RAYS)
    for r in range(N_RAYS):
        ray_s[r], ray_c[r] = sincos(RAY_ANGLES[r])

    n_runs = seeds.shape[0]
    n_rec = n_ticks // n_t
    summary = np.full((n_runs, N_SUMMARY), np.nan)
    series = np.full((n_runs, n_rec, N_SERIES), np.nan)
    trips = np.empty((256, N_TRIP))
    n_trips = 0
    snaps = np.empty((max(1, n) * 16, N_SNAP))
    n_snaps = 0
    robots = np.full((n_runs * n, N_LEDGER), np.nan)
    ledger = np.zeros((n, N_LEDGER))
    triggers = np.empty((max(1, n) * 16, N_TRIGGER))
    n_triggers = np.zeros(1, dtype=np.int64)

    rng = np.empty((1, n, 4), dtype=np.uint64)
    rng_soc0 = np.empty((1, 1, 4), dtype=np.uint64)
    sup = np.zeros((n, 1), dtype=np.int64)
    status = np.zeros(n, dtype=np.int64)
    role = np.zeros(n, dtype=np.int64)
    mode = np.zeros(n, dtype=np.int64)
    role_k1 = np.zeros(n, dtype=np.int64)
    role_k2 = np.zeros(n, dtype=np.int64)
    x = np.zeros(n)
    y = np.zeros(n)
    sx = np.zeros(n)          # positions at the end of tick k-1 (the section-5 snapshot)
    sy = np.zeros(n)
    theta_a = np.zeros(n)
    pcx = np.ones(n)          # plan direction (cos, sin) of theta_a
    pcy = np.zeros(n)
    theta = np.zeros(n)
    mdx = np.ones(n)          # motion direction of the last tick
    mdy = np.zeros(n)
    blocked = np.zeros(n, dtype=np.int64)
    avoiding = np.zeros(n, dtype=np.bool_)
    was_avoiding = np.zeros(n, dtype=np.bool_)
    energy = np.zeros(n)
    load = np.zeros(n, dtype=np.int64)
    s_c = np.zeros(n, dtype=np.int64)
    soc_ref = np.zeros(n)
    visited_r = np.zeros(n, dtype=np.bool_)
    n_failed = np.zeros(n, dtype=np.int64)
    bt_budget = np.zeros(n)
    bt_travel = np.zeros(n)
    rc_travel = np.zeros(n)
    countdown = np.zeros(n, dtype=np.int64)
    immediate = np.zeros(n, dtype=np.bool_)
    search = np.zeros(n, dtype=np.bool_)      # the next decision is a random search (spawn, 7.3)
    decided = np.zeros(n, dtype=np.bool_)
    nearest = np.zeros(n, dtype=np.int64)
    reg = np.zeros(n, dtype=np.int64)
    last_left = np.zeros(n, dtype=np.int64)
    voided = np.zeros(n, dtype=np.bool_)
    tick_left = np.zeros(n, dtype=np.int64)
    role_left = np.zeros(n, dtype=np.int64)
    acc = np.zeros((n, 3))            # trip accumulators: length, gross energy, soft length
    moved = np.zeros(n, dtype=np.bool_)
    kappa = np.ones(n)
    driven = np.zeros(n)              # distance driven since the last heading decision (decision_step_m)
    loaded_now = np.zeros(n, dtype=np.bool_)
    links = np.zeros(n, dtype=np.int64)
    omega = np.zeros((n, 3))
    bvx = np.zeros((n, 3))
    bvy = np.zeros((n, 3))
    bsoc = np.zeros((n, 3))
    binit = np.zeros((n, 3), dtype=np.bool_)
    weight = np.zeros((n, 3))
    ikey = np.full((n, n), -1, dtype=np.int64)
    idelta = np.zeros((n, n))
    ivx = np.zeros((n, n))
    ivy = np.zeros((n, n))
    iu = np.zeros((n, n))
    d2 = np.zeros((n, n))
    nb_cnt = np.zeros(n, dtype=np.int64)
    nb_list = np.zeros((n, n), dtype=np.int64)
    mb_cnt = np.zeros(n, dtype=np.int64)
    beacons = np.zeros(n, dtype=np.int64)
    s_hat = np.zeros((n, 3))
    no_r_guidance = np.zeros(n, dtype=np.bool_)
    hits = np.empty(N_RAYS)
    close = np.zeros((n, n), dtype=np.int64)  # bodies near each moving robot (avoidance -> translation)
    n_near = np.zeros(n, dtype=np.int64)
    here = np.zeros(n, dtype=np.int64)  # region after the move (energy -> bookkeeping)
    f_hist = np.zeros(n_ticks + 1, dtype=np.int64)
    nb_hist = np.zeros(n_ticks + 1, dtype=np.int64)
    row_counts = np.zeros(ROW_D, dtype=np.int64)
    align = np.empty(3)
    align_w = np.empty(3)
    tally = np.zeros(N_TALLY, dtype=np.int64)
    counts = np.zeros(8, dtype=np.int64)      # scratch of the time-series records
    # the phases' groups of arrays (section 11): the plan and motion heading, the avoidance and
    # blocked state, the beacon memory and inbox, what step 2 sensed, the trip in progress (with each
    # robot's record of the run and the row-2 triggers: what section 19 records per robot and event)
    heading = (theta_a, theta, pcx, pcy, mdx, mdy)
    motion = (blocked, avoiding, was_avoiding, moved, kappa, driven)
    memory = (omega, bvx, bvy, bsoc, binit, weight)
    inbox = (ikey, idelta, ivx, ivy, iu)
    sensed = (sx, sy, d2, nb_cnt, nb_list, mb_cnt, beacons, links, s_hat, no_r_guidance, nearest)
    trip = (last_left, voided, tick_left, role_left, acc, ledger, triggers, n_triggers)

    for run in range(n_runs):
        if stop[0] != 0:
            break
        for i in range(n):
            seed_stream(rng, 0, i, seeds[run], i)
        status[:] = UNSPAWNED
        sup[:, 0] = init_state
        role[:] = R
        role_k1[:] = R
        role_k2[:] = R
        mode[:] = NORMAL
        x[:] = spawn_x
        y[:] = spawn_y
        theta_a[:] = 0.0
        theta[:] = 0.0
        pcx[:] = 1.0
        pcy[:] = 0.0
        mdx[:] = 1.0
        mdy[:] = 0.0
        blocked[:] = 0
        avoiding[:] = False
        energy[:] = soc0 * e_cap
        load[:] = 0
        s_c[:] = F_IN
        soc_ref[:] = soc0
        if 0.0 < soc0_low < soc0:     # A39 option: initial SOCs from a stream of their own (none drawn else)
            seed_stream(rng_soc0, 0, 0, seeds[run], SOC0_STREAM)
            for i in range(n):
                soc_ref[i] = soc0_low + (soc0 - soc0_low) * uniform(rng_soc0, 0, 0)
                energy[i] = soc_ref[i] * e_cap
        visited_r[:] = False
        n_failed[:] = 0
        countdown[:] = 0
        immediate[:] = False
        search[:] = False
        decided[:] = False
        nearest[:] = -1
        reg[:] = REG_N
        last_left[:] = NO_REGION
        voided[:] = False
        bt_budget[:] = 0.0
        bt_travel[:] = 0.0
        rc_travel[:] = 0.0
        driven[:] = 0.0
        acc[:] = 0.0
        ledger[:] = 0.0
        ledger[:, LG_DIED_K] = -1.0
        run_triggers = n_triggers[0]
        omega[:] = 0.0
        bvx[:] = 0.0
        bvy[:] = 0.0
        bsoc[:] = 0.0
        binit[:] = False
        weight[:] = 0.0
        ikey[:] = -1
        row_counts[:] = 0
        f_hist[:] = 0
        nb_hist[:] = 0
        spawned = 0
        if start.shape[0] > 0:
            for i in range(n):
                st = start[i]
                if int(st[ST_STATUS]) == UNSPAWNED:
                    continue
                spawned = i + 1
                status[i] = int(st[ST_STATUS])
                sup[i, 0] = int(st[ST_SUP])
                role[i] = ROLE_OF_STATE[sup[i, 0]] if ROLE_OF_STATE[sup[i, 0]] >= 0 else int(st[ST_ROLE_K1])
                mode[i] = int(st[ST_MODE])
                x[i] = st[ST_X]
                y[i] = st[ST_Y]
                theta_a[i] = st[ST_THETA_A]
                pcy[i], pcx[i] = sincos(theta_a[i])
                theta[i] = st[ST_THETA]
                mdy[i], mdx[i] = sincos(theta[i])
                energy[i] = st[ST_ENERGY]
                load[i] = int(st[ST_LOAD])
                s_c[i] = int(st[ST_S_C])
                soc_ref[i] = st[ST_SOC_REF]
                visited_r[i] = st[ST_VISITED_R] != 0.0
                n_failed[i] = int(st[ST_N_FAILED])
                countdown[i] = int(st[ST_COUNTDOWN])
                role_k1[i] = int(st[ST_ROLE_K1])
                role_k2[i] = int(st[ST_ROLE_K2])
                blocked[i] = int(st[ST_BLOCKED])
                avoiding[i] = st[ST_AVOIDING] != 0.0
                immediate[i] = st[ST_IMMEDIATE] != 0.0
                search[i] = st[ST_SEARCH] != 0.0
                bt_budget[i] = st[ST_BT_BUDGET]
                bt_travel[i] = st[ST_BT_TRAVEL]
                rc_travel[i] = st[ST_RC_TRAVEL]
                reg[i] = region_of(x[i], y[i], g)
                for q in range(3):
                    omega[i, q] = st[ST_OMEGA + q]
                    bvx[i, q] = st[ST_VX + q]
                    bvy[i, q] = st[ST_VY + q]
                    bsoc[i, q] = st[ST_S + q]
                    binit[i, q] = st[ST_INIT + q] != 0.0
                    weight[i, q] = beacon_weight(omega[i, q], bsoc[i, q], binit[i, q], rho_f, rho_c, wform)
        tally[:] = 0
        t_first = np.full(3, -1, dtype=np.int64)      # first entry into T, R; first row 5 [tick]
        run_id = runs[run]

        k = 1
        while k <= n_ticks and stop[0] == 0:
            trips = _room(trips, n_trips, n)
            snaps = _room(snaps, n_snaps, SNAPS_PER_TICK * n)
            triggers = _room(triggers, n_triggers[0], n)
            trip = (last_left, voided, tick_left, role_left, acc, ledger, triggers, n_triggers)
            k, spawned, n_trips, n_snaps = run_ticks(
                opts, pars, g, box, ray_c, ray_s, table, stop, rng, run, run_id, k, spawned, status, sup, role, mode,
                role_k1, role_k2, x, y, energy, load, s_c, soc_ref, visited_r, n_failed, bt_budget, bt_travel,
                rc_travel, countdown, immediate, search, decided, reg, loaded_now, here, heading, motion, memory,
                inbox, sensed, trip, hits, close, n_near, counts, row_counts, t_first, tally, f_hist, nb_hist, series,
                align, align_w, trips, n_trips, snaps, n_snaps)

        if start.shape[0] > 0:
            for i in range(n):
                st = start[i]
                st[ST_STATUS] = status[i]
                st[ST_SUP] = sup[i, 0]
                st[ST_MODE] = mode[i]
                st[ST_X] = x[i]
                st[ST_Y] = y[i]
                st[ST_THETA_A] = theta_a[i]
                st[ST_THETA] = theta[i]
                st[ST_ENERGY] = energy[i]
                st[ST_LOAD] = load[i]
                st[ST_S_C] = s_c[i]
                st[ST_SOC_REF] = soc_ref[i]
                st[ST_VISITED_R] = visited_r[i]
                st[ST_N_FAILED] = n_failed[i]
                st[ST_COUNTDOWN] = countdown[i]
                st[ST_ROLE_K1] = role_k1[i]
                st[ST_ROLE_K2] = role_k2[i]
                st[ST_BLOCKED] = blocked[i]
                st[ST_BT_BUDGET] = bt_budget[i]
                st[ST_BT_TRAVEL] = bt_travel[i]
                st[ST_RC_TRAVEL] = rc_travel[i]
                st[ST_LINKS] = links[i]
                st[ST_AVOIDING] = avoiding[i]
                st[ST_IMMEDIATE] = immediate[i]
                st[ST_SEARCH] = search[i]
                for q in range(3):
                    st[ST_OMEGA + q] = omega[i, q]
                    st[ST_VX + q] = bvx[i, q]
                    st[ST_VY + q] = bvy[i, q]
                    st[ST_S + q] = bsoc[i, q]
                    st[ST_INIT + q] = binit[i, q]

        for r in range(run_triggers, n_triggers[0]):
            triggers[r, TG_RUN] = run_id
        for i in range(n):
            row = robots[run * n + i]
            row[:] = ledger[i]
            row[LG_RUN] = run_id
            row[LG_ROBOT] = i
            if ledger[i, LG_DIED_K] >= 0.0:       # a dead robot lies as it died
                row[LG_DIED_X] = x[i]
                row[LG_DIED_Y] = y[i]
                row[LG_DIED_ROLE] = role[i]
                row[LG_DIED_MODE] = mode[i]
                row[LG_DIED_REGION] = region_of(x[i], y[i], g)

        # per-run summary
        sm = summary[run]
        sm[SM_RESOURCES] = tally[TL_RESOURCES]
        sm[SM_TRIPS] = tally[TL_UNLOADS]
        sm[SM_INTERRUPTIONS] = row_counts[1]
        sm[SM_NEST_RECHARGES] = row_counts[2]
        sm[SM_SESSIONS] = row_counts[3]
        sm[SM_DEATHS] = tally[TL_DEATHS]
        sm[SM_DEPLETIONS] = tally[TL_DEPLETIONS]
        n_b = 0
        n_m = 0
        units_b = 0
        for i in range(n):
            if status[i] == ALIVE:
                if role[i] == B:
                    n_b += 1
                    units_b += load[i]
                else:
                    n_m += 1
        sm[SM_BEACONS] = n_b
        sm[SM_MOBILE] = n_m
        sm[SM_UNITS_BEACONS] = units_b
        alignment(n, status, role, x, y, omega, bvx, bvy, g, align, align_w)
        for q in range(3):
            sm[SM_ALIGN + q] = align[q]
            sm[SM_ALIGN_W + q] = align_w[q]
            total = 0.0
            count = 0
            for i in range(n):
                if status[i] == ALIVE and role[i] == q and mode[i] == NORMAL:
                    c = heading_alignment(x[i], y[i], mdx[i], mdy[i], g, q)
                    if c == c:
                        total += c
                        count += 1
            sm[SM_HEAD_ALIGN + q] = total / count if count > 0 else np.nan
        for q in range(3):
            sm[SM_T_FIRST_T + q] = t_first[q] * tau if t_first[q] >= 0 else np.nan
        peak = 0
        for k in range(n_ticks + 1):
            peak = max(peak, nb_hist[k])
        if peak > 0:
            for k in range(n_ticks + 1):
                if nb_hist[k] >= 0.9 * peak:
                    sm[SM_T_BEACONS_90] = k * tau
                    break
        for r in range(ROW_D):
            sm[SM_ROWS + r] = row_counts[r]
    return (summary, series, trips[:n_trips].copy(), snaps[:n_snaps].copy(), robots,
            triggers[:n_triggers[0]].copy())
