"""Compiled kernel of the energy-replenishment model, vectorised over trials.

One call advances every trial of one configuration through all ticks
(docs/replenishment-model.md sections 4-7, in the tick order of section 6). State is a
structure of arrays indexed ``[trial, robot]``; robots are the workers
(indices ``0 .. n_w - 1``) then the mobile chargers (``n_w .. n_w + n_m - 1``).
Trials never read each other's state, and each has its own random streams, so
a trial's outcome does not depend on which other trials run beside it.

Only + - * / sqrt and the project's own transcendental functions
(:mod:`dronefleet.fpmath`) touch the trajectory, so it is bit-identical on any
CPU. Random numbers come from xoshiro256** streams (``rng[trial, stream]``, :mod:`dronefleet.rng`).

Most robots stand still most ticks, so work whose inputs did not change is
reused rather than redone, never approximated: pair geometry only for pairs
with a robot that moved, neighbour lists only when a pair crossed a range,
obstacle rays only after the robot or one within ray reach moved, and a
control step not at all when the last one changed no state and commanded no
motion and none of its inputs changed since. Any such change must leave
tests/test_replenishment_fingerprints.py passing.

Decisions go through a supervisor VM that executes the loaded tables
(section 5.1); the only hand-written parts are the event conditions (5.2) and
the controllable events' actions (5.3).
"""

import numpy as np

from ..fpmath import atan2, sincos
from ..jit import njit
from ..rng import normal_pair, uniform

# Event codes: the columns of the kernel's transition tables (names without EV_).
EVENT_NAMES = ("moveToWork", "work", "moveToCharge", "charge", "shareEnergy",
               "atWork", "notAtWork", "atCharger", "notAtCharger", "lowEnergy", "highEnergy")
EV_MOVE_TO_WORK, EV_WORK, EV_MOVE_TO_CHARGE, EV_CHARGE, EV_SHARE = 0, 1, 2, 3, 4
EV_AT_WORK, EV_NOT_AT_WORK, EV_AT_CHARGER, EV_NOT_AT_CHARGER = 5, 6, 7, 8
EV_LOW, EV_HIGH = 9, 10
N_EVENTS = 11

# Roles (rows of the tables), floor colours, message states, turning modes.
ROLE_WORKER, ROLE_CHARGER = 0, 1
WHITE, BASE, TRANSFER, WORK = 0, 1, 2, 3
MSG_NONE, MSG_WORKER, MSG_CHARGER = 0, 1, 2
TURN_NO, TURN_SOFT, TURN_HARD = 0, 1, 2

# Random streams per trial.
STREAM_PLACEMENT, STREAM_NOISE, STREAM_VM = 0, 1, 2
N_STREAMS = 3

# Trace flag bits (one int per robot per tick).
FLAG_MOVING, FLAG_CHARGING, FLAG_WORKING, FLAG_SHARING = 1, 2, 4, 8
FLAG_REQUESTING, FLAG_DEPLETED, FLAG_TO_WORK = 16, 32, 64

# Time-series columns: robots per phase P0..P3 (workers, then chargers),
# stored energy (sum of batteries), cumulative work (points).
TS_WORKER_PHASE, TS_CHARGER_PHASE, TS_STORED, TS_WORK = 0, 4, 8, 9
#: The controller phases P0..P3 of each role, in the order of their time-series columns.
PHASES = {"workers": ("charging", "to_work", "working", "to_charge"),
          "chargers": ("charging", "to_transfer", "sharing", "to_base")}
N_TS = 10

# Rates passed in ``rates`` (float64 array).
R_V_MIN, R_V_MOVE, R_V_WORK, R_V_CHARGE, R_LOSS, R_CAP_W, R_CAP_M = range(7)

PI = np.pi
DT = 0.1                 # s per tick
RADIUS = 0.035           # m
AXLE = 0.053             # interwheel distance [m]
V_MAX = 12.0             # cm/s, also the clamp of a, n, o
R_RAB = 0.5333333333     # m, strict <
SHARE_CM = 14.0          # cm
RAY_LENGTH = 0.1         # m
WALL = 0.8               # inner wall faces [m]
SAFE = 0.765             # position clamp [m]
# Pairs with d^2 above this are out of range of everything (R_RAB is the largest reach);
# the margin keeps the exact test sqrt(d^2) < R_RAB for those below.
RANGE2_FILTER = R_RAB * R_RAB * (1.0 + 1e-9)
FAR = 1e3                # distance recorded for pairs beyond RANGE2_FILTER [m]
# A ray (0.035 + 0.1 m from the centre) can only reach discs whose centre is this close.
RAY_REACH = RADIUS + RAY_LENGTH + RADIUS
# LJ magnitude cap: (10 / rho)^24 overflows to inf for overlapping discs, and an
# infinite vector has no direction; 1e150 keeps squares of sums finite.
LJ_CAP = 1e150
RAY_ANGLE_DIVISORS = (10.5884, 3.5999, 2.0, 1.2, 0.8571, 0.6667, 0.5806, 0.5247)
HARD_TO_SOFT = 70.0 / 180.0 * PI
TO_HARD = 90.0 / 180.0 * PI
NO_TURN = 10.0 / 180.0 * PI
# below tan(10 deg) = 0.17633: |fy| <= this * fx (fx > 0) puts the angle below 9.999 deg
NO_TURN_SLOPE = 0.1763
APPROACH_CM = 8.07       # the worker with MC stops this far from its provider [cm]


# ------------------------------------------------------------------ geometry


@njit(cache=True)
def floor_colour(gx, gy, mobile):
    """Colour under ground-sensor point (gx, gy) [m]; first match wins (section 1)."""
    if -0.825 <= gx <= -0.5 and abs(gy) <= 0.825:
        return BASE
    if mobile and 0.2 <= gx <= 0.5 and abs(gy) <= 0.825:
        return TRANSFER
    if 0.5 <= gx <= 0.825 and abs(gy) <= 0.825:
        return WORK
    return WHITE


@njit(cache=True)
def in_charging_rect(x, y):
    return -0.8 <= x <= -0.5 and abs(y) <= 0.8


@njit(cache=True)
def in_work_rect(x, y):
    return 0.5 <= x <= 0.8 and abs(y) <= 0.8


@njit(cache=True)
def low_threshold(x):
    """E_low(x): return cost at full speed from centre x plus a 10-unit margin."""
    return (x + 0.5) / 0.12 * (10.0 * 0.1) + 10.0


@njit(cache=True)
def _clamp_length(vx, vy, limit):
    """(vx, vy) scaled down to length ``limit`` if longer."""
    length2 = vx * vx + vy * vy
    # sqrt is monotone and sqrt(limit * limit) == limit, so up to here the vector
    # passes unchanged without the sqrt and divisions (a long dependency chain)
    if length2 <= limit * limit:
        return vx, vy
    length = np.sqrt(length2)
    if length > limit:
        return vx * limit / length, vy * limit / length
    return vx, vy


@njit(cache=True)
def _wrap(theta):
    if theta > PI:
        return theta - 2.0 * PI
    if theta <= -PI:
        return theta + 2.0 * PI
    return theta


@njit(cache=True)
def _ray_hit(sx, sy, ux, uy, cx, cy):
    """Distance along the unit ray (s, u) to the disc at c, or 1.0 (no hit within reach).

    A ray starting inside the disc reads 0.
    """
    wx = sx - cx
    wy = sy - cy
    c = wx * wx + wy * wy - RADIUS * RADIUS
    if c <= 0.0:
        return 0.0
    b = wx * ux + wy * uy
    if b >= 0.0:
        return 1.0
    disc = b * b - c
    if disc < 0.0:
        return 1.0
    return -b - np.sqrt(disc)


@njit(cache=True)
def _wall_hit(s, u):
    """Distance along the unit ray (s, u) (one axis) to the inner wall face it heads for."""
    if u > 0.0:
        return max((WALL - s) / u, 0.0)
    if u < 0.0:
        return max((-WALL - s) / u, 0.0)
    return 1.0


@njit(cache=True)
def wheels_from_force(fx, fy, mode):
    """Turning-mode update and wheel speeds (left, right) [cm/s] for force F (section 4)."""
    if mode == TURN_NO and fx > 0.0 and abs(fy) <= NO_TURN_SLOPE * fx:
        # the angle is below NO_TURN by far more than atan2's rounding: the mode stays
        # NO and both wheels get s, so atan2 (the costly part) is not needed
        s = min(np.sqrt(fx * fx + fy * fy), V_MAX)
        return s, s, mode
    angle = atan2(fy, fx)
    s = min(np.sqrt(fx * fx + fy * fy), V_MAX)
    a = abs(angle)
    if mode == TURN_HARD and a <= HARD_TO_SOFT:
        mode = TURN_SOFT
    if mode == TURN_SOFT:
        if a > TO_HARD:
            mode = TURN_HARD
        elif a <= NO_TURN:
            mode = TURN_NO
    elif mode == TURN_NO:
        if a > TO_HARD:
            mode = TURN_HARD
        elif a > NO_TURN:
            mode = TURN_SOFT
    if mode == TURN_NO:
        s1 = s
        s2 = s
    elif mode == TURN_SOFT:
        f = (TO_HARD - a) / TO_HARD
        s1 = s * f
        s2 = s * (2.0 - f)
    else:
        s1 = -V_MAX
        s2 = V_MAX
    if angle > 0.0:
        return s1, s2, mode
    return s2, s1, mode


@njit(cache=True)
def pair_geometry(dx, dy):
    """Distance, unit vector and repulsion magnitude of the offset (dx, dy) [m] from i to j.

    Returns ``(d, ux, uy, magnitude)``: d [m] (FAR beyond RANGE2_FILTER); for
    d < R_RAB also the unit vector (0, 0 for coincident centres) and the
    repulsion magnitude 1000 / rho (10 / rho)^24 with rho = 100 d [cm], capped
    at LJ_CAP (coincident centres are handled by the caller). The reverse pair
    has the negated vector, exactly. Scalars only: array arguments would cost
    reference counting in the pair loop.
    """
    d2 = dx * dx + dy * dy
    if d2 > RANGE2_FILTER:
        return FAR, 0.0, 0.0, 0.0
    d = np.sqrt(d2)
    if not d < R_RAB:
        return d, 0.0, 0.0, 0.0
    inv = 1.0 / d if d > 0.0 else 0.0
    q = 0.1 * inv
    q2 = q * q
    q4 = q2 * q2
    q8 = q4 * q4
    return d, dx * inv, dy * inv, min(10.0 * inv * (q8 * q8 * q8), LJ_CAP)


# ------------------------------------------------------------------ supervisor VM


@njit(cache=True, inline='always')
def apply_uncontrollable(tables, n_sup, role, states, unc_order, n_unc, conditions):
    """Apply each true uncontrollable event in the file's order (section 5.1, step 2).

    Every supervisor with a transition for it moves; one without stays
    (``tables[role, k, s, e] == -1``). ``states`` (K,) is updated in place.
    Returns whether any local state changed.
    """
    changed = False
    for idx in range(n_unc[role]):
        ev = unc_order[role, idx]
        if conditions[ev]:
            for k in range(n_sup[role]):
                target = tables[role, k, states[k], ev]
                if target >= 0 and target != states[k]:
                    states[k] = target
                    changed = True
    return changed


@njit(cache=True, inline='always')
def choose_controllable(tables, n_sup, role, states, ctrl_order, n_ctrl, enabled, rng, tr):
    """The controllable event enabled in every supervisor (uniform pick among several), or -1.

    ``enabled`` is scratch of length N_EVENTS. The VM stream is drawn only when
    more than one event is enabled.
    """
    count = 0
    for idx in range(n_ctrl[role]):
        ev = ctrl_order[role, idx]
        ok = True
        for k in range(n_sup[role]):
            if tables[role, k, states[k], ev] < 0:
                ok = False
                break
        if ok:
            enabled[count] = ev
            count += 1
    if count == 0:
        return -1
    if count == 1:
        return enabled[0]
    pick = int(uniform(rng, tr, STREAM_VM) * count)
    return enabled[pick]


# ------------------------------------------------------------------ energy


@njit(cache=True, inline='always')
def transfer_source(tr, i, nw, sharing, served, mc_rank, dist):
    """The MC that transfers to charging worker i this tick, or -1 (section 7, step 6).

    Among the MCs sharing with ``to == i`` only the last in id-string order
    (highest ``mc_rank``) may transfer, and only if its centre is closer than
    14 cm to the worker's.
    """
    source = -1
    best_rank = -1
    for j in range(nw, sharing.shape[1]):
        if sharing[tr, j] and served[tr, j] == i and mc_rank[j - nw] > best_rank:
            source = j
            best_rank = mc_rank[j - nw]
    if source >= 0 and 100.0 * dist[i, source] < SHARE_CM:
        return source
    return -1


# ------------------------------------------------------------------ the kernel


@njit(cache=True)
def place_robots(rng, tr, x, y, th):
    """Initial placement of trial tr (section 1): rejection sampling in the base."""
    n = x.shape[1]
    for i in range(n):
        for _ in range(100):
            px = -0.8 + 0.3 * uniform(rng, tr, STREAM_PLACEMENT)
            py = -0.8 + 1.6 * uniform(rng, tr, STREAM_PLACEMENT)
            pt = 2.0 * PI * uniform(rng, tr, STREAM_PLACEMENT)
            x[tr, i] = px
            y[tr, i] = py
            th[tr, i] = _wrap(pt)
            ok = abs(px) + RADIUS <= WALL and abs(py) + RADIUS <= WALL
            for j in range(i):
                dx = x[tr, j] - px
                dy = y[tr, j] - py
                if np.sqrt(dx * dx + dy * dy) < 2.0 * RADIUS:
                    ok = False
            if ok:
                break


@njit(cache=True, nogil=True)
def run_trials(rates, n_workers, n_chargers, ticks, sample_every, mobile, wheel_noise,
               tables, n_sup, init_states, unc_order, n_unc, ctrl_order, n_ctrl,
               mc_rank, rng, trace, track, stop):
    """Advance all trials of one configuration through ``ticks`` ticks.

    Without a GIL: it runs while the caller's thread waits for Ctrl-C, which sets ``stop``
    (see :mod:`dronefleet.interrupt`).

    Parameters
    ----------
    rates : float64 (7,)
        v_min, v_move, v_work, v_charge, lambda, c_w, c_m (indices R_*).
    n_workers, n_chargers, ticks, sample_every : int
    mobile, wheel_noise, trace, track : bool
        Mobile-charger strategy; multiply wheels by N(1, 0.1^2); record a per-tick trace;
        record the first trial's track (pose, energy, phase of every robot at each sample).
    tables : int64 (2, K, S, N_EVENTS)
        ``tables[role, k, s, e]``: next state of supervisor k of the role's file, or -1.
    n_sup : int64 (2,)
        Supervisors per role.
    init_states : int64 (2, K)
    unc_order, ctrl_order : int64 (2, N_EVENTS)
        The file's uncontrollable / controllable event codes, in file order.
    n_unc, n_ctrl : int64 (2,)
    mc_rank : int64 (n_m,)
        Rank of each MC in id-string order ("C1" < "C10" < ... < "C2").
    rng : uint64 (trials, N_STREAMS, 4)
        xoshiro256** states; advanced in place.
    stop : int8 (1,)
        Read before every tick: once set, the remaining ticks are skipped and the results
        are incomplete (the caller discards them).

    Returns
    -------
    tuple
        ``(points (trials,), consumed (trials, n), work_energy (trials, n),
        shared (trials,), lost (trials,), depleted (trials, n) bool,
        energy (trials, n), drawn (trials, n), paid (trials, n),
        given (trials, n), received (trials, n), series (trials, samples, N_TS),
        trace arrays, track arrays)``; trace arrays have a tick axis of length ``ticks`` if
        ``trace`` else 0; track arrays ``(x, y, energy, phase)`` are (samples, n) if
        ``track`` else (0, n): the first trial at the ticks of ``series``.
    """
    n_trials = rng.shape[0]
    nw = n_workers
    n = n_workers + n_chargers
    v_min = rates[R_V_MIN]
    v_move = rates[R_V_MOVE]
    v_work = rates[R_V_WORK]
    v_charge = rates[R_V_CHARGE]
    loss = rates[R_LOSS]
    kmax = tables.shape[1]

    # --- state [trial, robot]
    x = np.zeros((n_trials, n))
    y = np.zeros((n_trials, n))
    th = np.zeros((n_trials, n))
    ct = np.zeros((n_trials, n))          # cos / sin of the current heading
    st = np.zeros((n_trials, n))
    energy = np.zeros((n_trials, n))
    cap = np.zeros(n)
    left = np.zeros((n_trials, n))        # wheel command [cm/s], applied next tick
    right = np.zeros((n_trials, n))
    mode = np.zeros((n_trials, n), dtype=np.int64)
    moving = np.zeros((n_trials, n), dtype=np.bool_)
    charging = np.zeros((n_trials, n), dtype=np.bool_)
    working = np.zeros((n_trials, n), dtype=np.bool_)
    sharing = np.zeros((n_trials, n), dtype=np.bool_)
    requesting = np.zeros((n_trials, n), dtype=np.bool_)
    to_work = np.zeros((n_trials, n), dtype=np.bool_)   # move type; TO_CHARGE initially
    ever_counted = np.zeros((n_trials, n), dtype=np.bool_)
    depleted = np.zeros((n_trials, n), dtype=np.bool_)  # the depleted sets (never removed)
    steps = np.zeros((n_trials, n), dtype=np.int64)
    provider = np.full((n_trials, n), -1, dtype=np.int64)   # worker with MC: `from`
    served = np.full((n_trials, n), -1, dtype=np.int64)     # MC: `to`
    phase = np.zeros((n_trials, n), dtype=np.int64)
    sup = np.zeros((n_trials, n, kmax), dtype=np.int64)
    vm_still = np.zeros((n_trials, n), dtype=np.bool_)    # last VM step changed nothing
    vm_mask = np.zeros((n_trials, n), dtype=np.int64)     # ... under these conditions
    # the last control step changed no state and commanded no motion ...
    quiet = np.zeros((n_trials, n), dtype=np.bool_)
    quiet_lh = np.zeros((n_trials, n), dtype=np.int64)    # ... with low + 2 high
    # messages, double-buffered: [tick parity, trial, robot]
    msg_state = np.zeros((2, n_trials, n), dtype=np.int64)
    msg_req = np.zeros((2, n_trials, n), dtype=np.bool_)
    msg_from = np.full((2, n_trials, n), -1, dtype=np.int64)
    msg_to = np.full((2, n_trials, n), -1, dtype=np.int64)
    # accounting
    consumed = np.zeros((n_trials, n))
    work_energy = np.zeros((n_trials, n))
    drawn = np.zeros((n_trials, n))       # actually added by base charging
    paid = np.zeros((n_trials, n))        # actually removed by idle, work, motion
    given = np.zeros((n_trials, n))       # actually removed from an MC by transfers
    received = np.zeros((n_trials, n))    # actually added to a worker by transfers
    points = np.zeros(n_trials, dtype=np.int64)
    shared = np.zeros(n_trials)
    lost = np.zeros(n_trials)
    n_samples = ticks // sample_every + 1
    series = np.zeros((n_trials, n_samples, N_TS))

    tt = ticks if trace else 0
    tr_x = np.zeros((n_trials, tt, n))
    tr_y = np.zeros((n_trials, tt, n))
    tr_energy = np.zeros((n_trials, tt, n))
    tr_consumed = np.zeros((n_trials, tt, n))
    tr_flags = np.zeros((n_trials, tt, n), dtype=np.int64)
    tr_event = np.full((n_trials, tt, n), -1, dtype=np.int64)
    tr_sup = np.zeros((n_trials, tt, n, kmax), dtype=np.int64)
    tr_from = np.full((n_trials, tt, n), -1, dtype=np.int64)
    tr_to = np.full((n_trials, tt, n), -1, dtype=np.int64)
    tr_msg_req = np.zeros((n_trials, tt, n), dtype=np.bool_)
    tr_msg_from = np.full((n_trials, tt, n), -1, dtype=np.int64)
    tr_msg_to = np.full((n_trials, tt, n), -1, dtype=np.int64)
    tr_received = np.zeros((n_trials, tt, n))
    tr_source = np.full((n_trials, tt, n), -1, dtype=np.int64)
    # the first trial's track, sampled with the series: a run of weeks of ticks stays small
    tk = n_samples if track else 0
    tk_x = np.zeros((tk, n))
    tk_y = np.zeros((tk, n))
    tk_energy = np.zeros((tk, n))
    tk_phase = np.zeros((tk, n), dtype=np.int64)

    # --- scratch (per trial, reused every tick)
    dist = np.zeros((n, n))
    ux_pair = np.zeros((n, n))            # unit vector i -> j (world), pairs closer than R_RAB
    uy_pair = np.zeros((n, n))
    rep_x_pair = np.zeros((n, n))         # repulsion of j on i (world), pairs closer than R_RAB
    rep_y_pair = np.zeros((n, n))
    near_n = np.zeros(n, dtype=np.int64)  # robots a ray of i can reach
    near_idx = np.zeros((n, n), dtype=np.int64)
    range_n = np.zeros(n, dtype=np.int64)  # robots closer than R_RAB, ascending index
    range_idx = np.zeros((n, n), dtype=np.int64)
    moved = np.zeros(n, dtype=np.bool_)   # pose changed this tick
    movers = np.zeros(n, dtype=np.int64)  # the robots that moved, ascending
    # a robot in range moved, crossed R_RAB or sent a new message: i's inputs changed
    stirred = np.zeros(n, dtype=np.bool_)
    obs_valid = np.zeros(n, dtype=np.bool_)   # obs_*_last is the current obstacle vector
    obs_x_last = np.zeros(n)
    obs_y_last = np.zeros(n)
    heard = np.zeros(n, dtype=np.bool_)
    low_at = np.zeros(n)                  # low_threshold of the robot's current x
    # the message i sent last tick differs from the one before: its listeners' inputs changed
    msg_changed = np.zeros(n, dtype=np.bool_)
    rho = np.zeros(n)
    conditions = np.zeros(N_EVENTS, dtype=np.bool_)
    enabled = np.zeros(N_EVENTS, dtype=np.int64)
    ray_cos = np.zeros(8)
    ray_sin = np.zeros(8)
    for k in range(8):
        # sincos, the same bits as sin and cos: two functions fewer to compile
        ray_sin[k], ray_cos[k] = sincos(PI / RAY_ANGLE_DIVISORS[k])

    for i in range(n):
        cap[i] = rates[R_CAP_W] if i < nw else rates[R_CAP_M]
    for tr in range(n_trials):
        place_robots(rng, tr, x, y, th)
        for i in range(n):
            st[tr, i], ct[tr, i] = sincos(th[tr, i])
            energy[tr, i] = cap[i]
            role = ROLE_WORKER if i < nw else ROLE_CHARGER
            for k in range(kmax):
                sup[tr, i, k] = init_states[role, k]
            series[tr, 0, TS_STORED] += energy[tr, i]
            series[tr, 0, (TS_WORKER_PHASE if i < nw else TS_CHARGER_PHASE)] += 1.0
            if track and tr == 0:
                tk_x[0, i] = x[tr, i]
                tk_y[0, i] = y[tr, i]
                tk_energy[0, i] = energy[tr, i]

    # Trials never interact, so each runs all its ticks in turn: its state stays in
    # cache (measured 13 % faster than sweeping all trials every tick).
    for tr in range(n_trials):
        for t in range(1, ticks + 1):
            if stop[0] != 0:
                break
            cur = (t - 1) % 2       # messages set at t - 1
            nxt = t % 2             # messages set now, read at t + 1
            # 1. act + physics: last tick's wheel command
            n_movers = 0
            for i in range(n):
                # at tick 1 nothing of this trial's geometry is computed yet
                moved[i] = t == 1 or left[tr, i] != 0.0 or right[tr, i] != 0.0
                if moved[i]:
                    movers[n_movers] = i
                    n_movers += 1
                if left[tr, i] != 0.0 or right[tr, i] != 0.0:
                    v = (left[tr, i] + right[tr, i]) * 0.5 / 100.0
                    omega = (right[tr, i] - left[tr, i]) / 100.0 / AXLE
                    x[tr, i] = min(max(x[tr, i] + v * ct[tr, i] * DT, -SAFE), SAFE)
                    y[tr, i] = min(max(y[tr, i] + v * st[tr, i] * DT, -SAFE), SAFE)
                    th[tr, i] = _wrap(th[tr, i] + omega * DT)
                    # one argument reduction for both (fpmath.sincos: the same bits)
                    st[tr, i], ct[tr, i] = sincos(th[tr, i])
                if moved[i]:
                    # E_low depends on x only: a division per move, not per robot and tick
                    low_at[i] = low_threshold(x[tr, i])
            # pair geometry, shared by neighbours, rays and transfers. Only pairs
            # with a robot that moved change; the others keep last tick's values.
            # A robot's obstacle vector depends on its own pose and the robots within
            # RAY_REACH, so it is recomputed only after it or one of those (before
            # or after the move) moved.
            for mi in range(n_movers):
                i = movers[mi]
                obs_valid[i] = False
                for m in range(near_n[i]):
                    obs_valid[near_idx[i, m]] = False
            # The neighbour lists change only when a pair crosses R_RAB or RAY_REACH.
            crossed = t == 1
            for i in range(n):
                stirred[i] = t == 1
            # pairs with a mover (few per tick), each once, computed as (lower, higher index)
            for mi in range(n_movers):
                mover = movers[mi]
                for other in range(n):
                    if other != mover and not (moved[other] and other < mover):
                        i = min(mover, other)
                        j = max(mover, other)
                        before = dist[i, j]
                        d, ux, uy, magnitude = pair_geometry(x[tr, j] - x[tr, i],
                                                             y[tr, j] - y[tr, i])
                        dist[i, j] = d
                        dist[j, i] = d
                        if d < R_RAB:
                            ux_pair[i, j] = ux
                            uy_pair[i, j] = uy
                            ux_pair[j, i] = -ux
                            uy_pair[j, i] = -uy
                            rep_x_pair[i, j] = magnitude * ux
                            rep_y_pair[i, j] = magnitude * uy
                            rep_x_pair[j, i] = -(magnitude * ux)
                            rep_y_pair[j, i] = -(magnitude * uy)
                        if (before < R_RAB) != (d < R_RAB) \
                                or (before < RAY_REACH) != (d < RAY_REACH):
                            crossed = True
                        if before < R_RAB or d < R_RAB:
                            stirred[i] = True
                            stirred[j] = True
            if crossed:
                for i in range(n):
                    near_n[i] = 0
                    range_n[i] = 0
                for i in range(n):
                    for j in range(i + 1, n):
                        d = dist[i, j]
                        if d < R_RAB:
                            range_idx[i, range_n[i]] = j
                            range_n[i] += 1
                            range_idx[j, range_n[j]] = i
                            range_n[j] += 1
                        if d < RAY_REACH:
                            near_idx[i, near_n[i]] = j
                            near_n[i] += 1
                            near_idx[j, near_n[j]] = i
                            near_n[j] += 1
            for mi in range(n_movers):
                i = movers[mi]
                for m in range(near_n[i]):
                    obs_valid[near_idx[i, m]] = False
            if t > 1:   # (at tick 1 every robot is stirred)
                for i in range(n):
                    if msg_changed[i]:
                        for m in range(range_n[i]):
                            stirred[range_idx[i, m]] = True

            # 3. work count (working as left by step t - 1, current centre)
            n_t = 0
            for i in range(nw):
                if working[tr, i] and in_work_rect(x[tr, i], y[tr, i]):
                    n_t += 1
                    ever_counted[tr, i] = True

            # 4. control steps
            for i in range(n):
                is_worker = i < nw
                role = ROLE_WORKER if is_worker else ROLE_CHARGER
                steps[tr, i] += 1
                e_start = energy[tr, i]
                # e_start / cap <= 0 (energy >= 0, cap > 0), dividing only where the
                # quotient could underflow to 0
                if e_start <= 0.0 or (e_start < 1e-290 * cap[i] and e_start / cap[i] <= 0.0):
                    # depleted: stop; a worker sends a plain WORKER message, an MC its last one
                    left[tr, i] = 0.0
                    right[tr, i] = 0.0
                    moving[tr, i] = False
                    working[tr, i] = False
                    quiet[tr, i] = False
                    if is_worker:
                        msg_changed[i] = (msg_state[cur, tr, i] != MSG_WORKER
                                          or msg_req[cur, tr, i] or msg_from[cur, tr, i] != -1
                                          or msg_to[cur, tr, i] != -1)
                        msg_state[nxt, tr, i] = MSG_WORKER
                        msg_req[nxt, tr, i] = False
                        msg_from[nxt, tr, i] = -1
                        msg_to[nxt, tr, i] = -1
                    else:
                        msg_changed[i] = False
                        msg_state[nxt, tr, i] = msg_state[cur, tr, i]
                        msg_req[nxt, tr, i] = msg_req[cur, tr, i]
                        msg_from[nxt, tr, i] = msg_from[cur, tr, i]
                        msg_to[nxt, tr, i] = msg_to[cur, tr, i]
                    if trace:
                        tr_flags[tr, t - 1, i] = FLAG_DEPLETED
                        for k in range(kmax):
                            tr_sup[tr, t - 1, i, k] = sup[tr, i, k]
                    continue

                low = e_start < low_at[i]
                high = e_start >= 0.99 * cap[i]
                if quiet[tr, i] and not stirred[i] and quiet_lh[tr, i] == low + 2 * high:
                    # The last step changed no state and commanded no motion, and every input
                    # (own pose and state, neighbours' geometry and messages, low, high) is
                    # the same: this step would repeat it exactly, message included.
                    msg_changed[i] = False
                    msg_state[nxt, tr, i] = msg_state[cur, tr, i]
                    msg_req[nxt, tr, i] = msg_req[cur, tr, i]
                    msg_from[nxt, tr, i] = msg_from[cur, tr, i]
                    msg_to[nxt, tr, i] = msg_to[cur, tr, i]
                    if trace:
                        for k in range(kmax):
                            tr_sup[tr, t - 1, i, k] = sup[tr, i, k]
                    continue
                requesting0 = requesting[tr, i]
                provider0 = provider[tr, i]
                served0 = served[tr, i]

                # 2. neighbours (messages one tick old, positions current) and repulsion
                c = ct[tr, i]
                s = st[tr, i]
                # summed in the world frame, rotated into the robot's frame once
                rep_wx = 0.0
                rep_wy = 0.0
                n_heard = 0
                for j in range(n):
                    heard[j] = False
                for m in range(range_n[i]):        # ascending robot index
                    j = range_idx[i, m]
                    if msg_state[cur, tr, j] == MSG_NONE:
                        continue
                    heard[j] = True
                    n_heard += 1
                    r_cm = 100.0 * dist[i, j]
                    if r_cm < 1e-6:
                        # bearing pi (pushed straight ahead), rho = 1e-6 cm: the cap
                        rho[j] = 1e-6
                        rep_wx += LJ_CAP * c
                        rep_wy += LJ_CAP * s
                    else:
                        rho[j] = r_cm
                        rep_wx -= rep_x_pair[i, j]
                        rep_wy -= rep_y_pair[i, j]
                rep_x = 0.0
                rep_y = 0.0
                if n_heard > 0:
                    rep_x, rep_y = _clamp_length((rep_wx * c + rep_wy * s) / n_heard,
                                                 (-rep_wx * s + rep_wy * c) / n_heard, V_MAX)

                gx = x[tr, i] + 0.03 * c + 0.009 * s
                gy = y[tr, i] + 0.03 * s - 0.009 * c
                colour = floor_colour(gx, gy, mobile)

                # 3. partners
                dist_mc = 1e5
                if is_worker and mobile:
                    if not requesting[tr, i]:
                        requesting[tr, i] = low
                    else:
                        requesting[tr, i] = not high
                    if requesting[tr, i]:
                        p = provider[tr, i]
                        if p >= 0 and heard[p] and msg_state[cur, tr, p] == MSG_CHARGER \
                                and msg_to[cur, tr, p] == i:
                            dist_mc = rho[p]
                        else:
                            provider[tr, i] = -1
                            for m in range(range_n[i]):     # only those can be heard
                                j = range_idx[i, m]
                                if heard[j] and msg_state[cur, tr, j] == MSG_CHARGER \
                                        and msg_to[cur, tr, j] == i and rho[j] < dist_mc:
                                    provider[tr, i] = j
                                    dist_mc = rho[j]
                elif not is_worker:
                    if not sharing[tr, i]:
                        served[tr, i] = -1
                    else:
                        w = served[tr, i]
                        if w >= 0:
                            if heard[w] and msg_state[cur, tr, w] == MSG_WORKER:
                                if not (msg_req[cur, tr, w] and msg_from[cur, tr, w] == i):
                                    served[tr, i] = -1
                            else:
                                served[tr, i] = -1
                        # pairing happens only while sharing (as in the code's Update())
                        if served[tr, i] < 0 and colour == TRANSFER:
                            best = np.inf
                            for m in range(range_n[i]):
                                j = range_idx[i, m]
                                if heard[j] and msg_state[cur, tr, j] == MSG_WORKER \
                                        and msg_req[cur, tr, j] and msg_from[cur, tr, j] < 0 \
                                        and rho[j] < best:
                                    served[tr, i] = j
                                    best = rho[j]

                # 4. supervisor step (from the 5th control step)
                event = -1
                if trace:
                    for k in range(kmax):
                        tr_sup[tr, t - 1, i, k] = sup[tr, i, k]
                if steps[tr, i] > 4:
                    if is_worker:
                        at_work = colour == WORK
                        at_charger = dist_mc <= SHARE_CM if mobile else colour == BASE
                    else:
                        at_work = colour == TRANSFER
                        at_charger = colour == BASE
                    conditions[EV_AT_WORK] = at_work
                    conditions[EV_NOT_AT_WORK] = not at_work
                    conditions[EV_AT_CHARGER] = at_charger
                    conditions[EV_NOT_AT_CHARGER] = not at_charger
                    conditions[EV_LOW] = low
                    conditions[EV_HIGH] = high
                    # The VM step is a function of (states, conditions): after a step that
                    # changed no state and took no event, it is skipped while the
                    # conditions repeat (it would again do nothing).
                    mask = at_work + 2 * at_charger + 4 * low + 8 * high
                    if not (vm_still[tr, i] and vm_mask[tr, i] == mask):
                        states = sup[tr, i]
                        changed = apply_uncontrollable(tables, n_sup, role, states, unc_order,
                                                       n_unc, conditions)
                        if trace:
                            for k in range(kmax):
                                tr_sup[tr, t - 1, i, k] = states[k]
                        event = choose_controllable(tables, n_sup, role, states, ctrl_order,
                                                    n_ctrl, enabled, rng, tr)
                        vm_still[tr, i] = not changed and event < 0
                        vm_mask[tr, i] = mask
                    if event >= 0:
                        for k in range(n_sup[role]):
                            sup[tr, i, k] = tables[role, k, sup[tr, i, k], event]
                        # actions (section 5.3)
                        if event == EV_MOVE_TO_WORK:
                            to_work[tr, i] = True
                            charging[tr, i] = False
                            working[tr, i] = False
                            sharing[tr, i] = False
                            if is_worker and mobile:
                                requesting[tr, i] = False
                            phase[tr, i] = 1
                        elif event == EV_MOVE_TO_CHARGE:
                            to_work[tr, i] = False
                            charging[tr, i] = False
                            working[tr, i] = False
                            sharing[tr, i] = False
                            phase[tr, i] = 3
                        elif event == EV_WORK:
                            working[tr, i] = True
                            charging[tr, i] = False
                            phase[tr, i] = 2
                        elif event == EV_SHARE:
                            sharing[tr, i] = True
                            charging[tr, i] = False
                            phase[tr, i] = 2
                        elif event == EV_CHARGE:
                            charging[tr, i] = True
                            working[tr, i] = False
                            sharing[tr, i] = False
                            phase[tr, i] = 0

                # 5. motion
                w = served[tr, i]
                if not is_worker and colour == TRANSFER and w >= 0 and heard[w]:
                    left[tr, i] = 0.0       # wait for the worker; turning mode untouched
                    right[tr, i] = 0.0
                    moving[tr, i] = False
                else:
                    p = provider[tr, i]
                    if is_worker and mobile and requesting[tr, i] and p >= 0 \
                            and not to_work[tr, i]:
                        # approach the provider, stopping APPROACH_CM short of its centre
                        length = min(max(rho[p] - APPROACH_CM, -V_MAX), V_MAX)
                        if dist[i, p] * 100.0 < 1e-6:
                            att_x = -length
                            att_y = 0.0
                        else:       # the provider was heard: closer than R_RAB
                            att_x = length * (ux_pair[i, p] * c + uy_pair[i, p] * s)
                            att_y = length * (-ux_pair[i, p] * s + uy_pair[i, p] * c)
                    else:
                        if is_worker:
                            target = 0.55 if (to_work[tr, i] or mobile) else -0.55
                        else:
                            target = 0.25 if to_work[tr, i] else -0.535
                        a = min(max(100.0 * (target - x[tr, i]), -V_MAX), V_MAX)
                        att_x = a * c
                        att_y = -a * s
                    if not obs_valid[i]:
                        # o of section 4. Rays reach RADIUS + RAY_LENGTH from the centre, so
                        # only walls that close and the near_idx robots are tested; a robot
                        # with neither reads nothing. Written out here: a helper taking the
                        # arrays costs reference counting per call (measured ~5 %).
                        ox = 0.0
                        oy = 0.0
                        near_x_wall = abs(x[tr, i]) >= WALL - (RADIUS + RAY_LENGTH)
                        near_y_wall = abs(y[tr, i]) >= WALL - (RADIUS + RAY_LENGTH)
                        if near_x_wall or near_y_wall or near_n[i] > 0:
                            for k in range(8):
                                ux = c * ray_cos[k] - s * ray_sin[k]
                                uy = s * ray_cos[k] + c * ray_sin[k]
                                sx = x[tr, i] + RADIUS * ux
                                sy = y[tr, i] + RADIUS * uy
                                d = 1.0
                                if near_x_wall:
                                    d = _wall_hit(sx, ux)
                                if near_y_wall:
                                    d = min(d, _wall_hit(sy, uy))
                                for m in range(near_n[i]):
                                    j = near_idx[i, m]
                                    d = min(d, _ray_hit(sx, sy, ux, uy, x[tr, j], y[tr, j]))
                                if d <= RAY_LENGTH:
                                    weight = (RAY_LENGTH - d) / RAY_LENGTH * V_MAX
                                    ox -= weight * ray_cos[k]
                                    oy -= weight * ray_sin[k]
                            ox, oy = _clamp_length(ox / 8.0, oy / 8.0, V_MAX)
                        obs_x_last[i] = ox
                        obs_y_last[i] = oy
                        obs_valid[i] = True
                    obs_x = obs_x_last[i]
                    obs_y = obs_y_last[i]
                    fx = att_x + rep_x + obs_x
                    fy = att_y + rep_y + obs_y
                    force2 = fx * fx + fy * fy
                    # sqrt(force2) > 0.5 needs force2 > 0.25 (monotone, sqrt(0.25) = 0.5)
                    if force2 > 0.25 and np.sqrt(force2) > 0.5:
                        wl, wr, new_mode = wheels_from_force(fx, fy, mode[tr, i])
                        mode[tr, i] = new_mode
                        if wheel_noise and (wl != 0.0 or wr != 0.0):
                            z1, z2 = normal_pair(rng, tr, STREAM_NOISE)
                            wl *= 1.0 + 0.1 * z1
                            wr *= 1.0 + 0.1 * z2
                        left[tr, i] = wl
                        right[tr, i] = wr
                        moving[tr, i] = True
                    else:
                        left[tr, i] = 0.0
                        right[tr, i] = 0.0
                        moving[tr, i] = False

                # 6. message for the next tick (the message writes are spelled out, here and
                # above: a helper taking the arrays costs reference counting, measured 12 %)
                if is_worker:
                    if mobile and high:
                        provider[tr, i] = -1
                    m_state = MSG_WORKER
                    m_req = requesting[tr, i] if mobile else False
                    m_from = provider[tr, i] if mobile else -1
                    m_to = -1
                else:
                    m_state = MSG_CHARGER
                    m_req = low
                    m_from = -1
                    m_to = served[tr, i]
                msg_changed[i] = (m_state != msg_state[cur, tr, i] or m_req != msg_req[cur, tr, i]
                                  or m_from != msg_from[cur, tr, i] or m_to != msg_to[cur, tr, i])
                msg_state[nxt, tr, i] = m_state
                msg_req[nxt, tr, i] = m_req
                msg_from[nxt, tr, i] = m_from
                msg_to[nxt, tr, i] = m_to
                if trace:
                    tr_event[tr, t - 1, i] = event
                # vm_still after a VM step (run or skipped) means no state change, no event
                quiet[tr, i] = (steps[tr, i] > 4 and vm_still[tr, i] and not moving[tr, i]
                                and requesting[tr, i] == requesting0
                                and provider[tr, i] == provider0 and served[tr, i] == served0)
                quiet_lh[tr, i] = low + 2 * high

            # 5. energy (section 7): workers (with work and transfers), then MCs; an MC's own
            # step comes after the transfers that drew on it, as in the code.
            for i in range(n):
                is_worker = i < nw
                e0 = energy[tr, i]
                e = max(e0 - v_min, 0.0)
                consumed[tr, i] += v_min
                if is_worker and working[tr, i] and ever_counted[tr, i]:
                    e = max(e - v_work, 0.0)
                    consumed[tr, i] += v_work
                    work_energy[tr, i] += v_work
                if charging[tr, i] and in_charging_rect(x[tr, i], y[tr, i]):
                    e1 = min(e + v_charge, cap[i])
                    paid[tr, i] += e0 - e
                    drawn[tr, i] += e1 - e
                    e0 = e1
                    e = e1
                if moving[tr, i]:
                    e = max(e - v_move, 0.0)
                    consumed[tr, i] += v_move
                paid[tr, i] += e0 - e
                if e == 0.0:
                    depleted[tr, i] = True
                energy[tr, i] = e
                if is_worker and charging[tr, i]:
                    source = transfer_source(tr, i, nw, sharing, served, mc_rank, dist)
                    if source >= 0:
                        delta = v_charge * (1.0 - loss)
                        excess = max(e + delta - cap[i], 0.0)
                        e1 = min(e + delta, cap[i])
                        received[tr, i] += e1 - e
                        energy[tr, i] = e1
                        shared[tr] += delta - excess
                        lost[tr] += v_charge * loss
                        ej = energy[tr, source]
                        ej1 = max(ej - v_charge + excess, 0.0)
                        given[tr, source] += ej - ej1
                        energy[tr, source] = ej1
                        if trace:
                            tr_received[tr, t - 1, i] = e1 - e
                            tr_source[tr, t - 1, i] = source
            points[tr] += n_t

            if trace:
                for i in range(n):
                    tr_x[tr, t - 1, i] = x[tr, i]
                    tr_y[tr, t - 1, i] = y[tr, i]
                    tr_energy[tr, t - 1, i] = energy[tr, i]
                    tr_consumed[tr, t - 1, i] = consumed[tr, i]
                    tr_flags[tr, t - 1, i] |= (
                        FLAG_MOVING * moving[tr, i] + FLAG_CHARGING * charging[tr, i]
                        + FLAG_WORKING * working[tr, i] + FLAG_SHARING * sharing[tr, i]
                        + FLAG_REQUESTING * requesting[tr, i] + FLAG_TO_WORK * to_work[tr, i])
                    tr_from[tr, t - 1, i] = provider[tr, i]
                    tr_to[tr, t - 1, i] = served[tr, i]
                    tr_msg_req[tr, t - 1, i] = msg_req[nxt, tr, i]
                    tr_msg_from[tr, t - 1, i] = msg_from[nxt, tr, i]
                    tr_msg_to[tr, t - 1, i] = msg_to[nxt, tr, i]
            if t % sample_every == 0:
                row = t // sample_every
                for i in range(n):
                    base_col = TS_WORKER_PHASE if i < nw else TS_CHARGER_PHASE
                    series[tr, row, base_col + phase[tr, i]] += 1.0
                    series[tr, row, TS_STORED] += energy[tr, i]
                    if track and tr == 0:
                        tk_x[row, i] = x[tr, i]
                        tk_y[row, i] = y[tr, i]
                        tk_energy[row, i] = energy[tr, i]
                        tk_phase[row, i] = phase[tr, i]
                series[tr, row, TS_WORK] = points[tr]

    trace_arrays = (tr_x, tr_y, tr_energy, tr_consumed, tr_flags, tr_event, tr_sup, tr_from,
                    tr_to, tr_msg_req, tr_msg_from, tr_msg_to, tr_received, tr_source)
    return (points, consumed, work_energy, shared, lost, depleted, energy, drawn, paid, given,
            received, series, trace_arrays, (tk_x, tk_y, tk_energy, tk_phase))
