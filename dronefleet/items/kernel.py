"""Compiled kernel of the item-delivery / foraging model (docs/items-model.md), vectorised over trials.

One call of :func:`run_trials` runs every trial of one configuration (one (n, c, s) cell of an
experiment): each trial seeds its own streams from its root seed, draws its world, and steps
t = 1..T in the order of the spec's section 8. State is a structure of plain arrays indexed by
node (0 = home, 1..m = locations, row-major on the IDP grid) or robot (0..n-1).

Compiled with ``error_model='numpy'``: a float division is then a plain IEEE division, not one
guarded against a zero divisor (no kernel divides by zero), which lets the value loops vectorise;
results are the same, IEEE division being exact-rounded either way.

Only + - * / sqrt, floor/ceil and :mod:`dronefleet.fpmath` ``exp``/``log`` touch the trajectory;
random numbers come from :mod:`dronefleet.rng` streams, so a run is bit-identical on any CPU.
Streams per trial (spec section 10): ``STREAM_WORLD`` (a) positions then true parameters,
``STREAM_GENERATION`` (b) the truth's draws (Bernoulli, Poisson, logistic noise), and one stream
per robot (c), ``STREAM_ROBOT + i``. Seeded from the trial's root seed and the stream's key, they
are the same for every algorithm, n, c and s: trials with the same index are paired.
"""

import numpy as np

from ..fpmath import exp, log
from ..jit import borrowing, njit
from ..rng import lane_u64, normal_pair, seed_stream, uniform, unit

# Modes, truths, algorithms, CAS variants (the ints the Python layer passes in ``opts``).
MODE_FP, MODE_IDP = 0, 1
BERNOULLI, POISSON, LOGISTIC = 0, 1, 2
ALG_R, ALG_GR, ALG_GRIC, ALG_CAS, ALG_AS, ALG_ASTC, ALG_SF = 0, 1, 2, 3, 4, 5, 6
CAS_MAX_EXPECTED, CAS_RATE, CAS_GR_NO_EARMARK = 0, 1, 2

# Integer options, float parameters: indices into ``opts`` and ``pars``.
(O_MODE, O_TRUTH, O_ALG, O_CAS, O_GR_CAP_MAX, O_TIES_LOWEST, O_PRIVATE, O_OBS_REAL,
 O_COUNT_PICKUP, O_RESAMPLE, O_STEPS, O_CAPACITY, O_ROBOTS, O_DRAW_POSITIONS, O_DRAW_PARAMS,
 O_CAS_SHARED) = range(16)
N_OPTS = 16
(P_SPEED, P_PV, P_KP, P_RATE, P_K, P_LG, P_SE, P_X0, P_MMIN,
 P_MEAN, P_SD, P_LOW, P_HIGH, P_OBS_RANGE) = range(14)
N_PARS = 14

# Streams per trial: world (a), generation (b), then one per robot (c).
STREAM_WORLD, STREAM_GENERATION, STREAM_ROBOT = 0, 1, 2
# Key of location j's Bernoulli/Poisson generation stream: LOCATION_KEY + j (beyond every robot's key).
LOCATION_KEY = 1 << 32
UNIT_BITS = 9007199254740992.0   # 2**53: a uniform is k / 2**53, k the top 53 bits of a draw

# Per-trial outputs (columns of ``totals``) and per-robot ones (last axis of ``per_robot``).
T_GENERATED, T_SERVED, T_VISITS, T_TRIPS, T_PICKED = range(5)
# Measures beyond the summary (the verdicts read them): departures to a location and those to a
# location another robot is heading to or standing at (ASTC: two robots on one location, L393);
# SF's sleep-time updates and the sum of |change| [steps] in each half of the run (L383).
T_DEPARTURES, T_SHARED, T_SF_UPDATES_EARLY, T_SF_CHANGE_EARLY, T_SF_UPDATES_LATE, T_SF_CHANGE_LATE = range(5, 11)
N_TOTALS = 11
R_TRIPS, R_VISITS, R_ITEMS = range(3)
N_PER_ROBOT = 3
# Trace columns (per step and robot): node (-1 in transit), destination, steps left, payload y.
TR_NODE, TR_DEST, TR_LEFT, TR_Y = range(4)

STAY = -1
TIE_REL = 1e-12            # A25: values within 1e-12 relative are equal
MINUS_ONE_BITS = int(np.array(-1.0).view(np.int64))   # -1.0's bits read as an int64 (negative)
TRAVEL_GUARD = 1e-9        # A6: ceil(D/s - 1e-9), float noise never adds a step
POISSON_LEVELS = 4         # Poisson counts below 4 read from thresholds, in a loop that vectorises
POISSON_CHUNK = 16.0       # Poisson(lambda) as a sum of ceil(lambda/16) inversions (exp(-16) >> underflow)
NEVER = np.int64(1) << np.int64(62)   # "k = infinity" (ASTC), a sleeping step that never comes


# ------------------------------------------------------------------ samplers and geometry


@njit(cache=True, error_model='numpy')
def poisson_parts(lam):
    """(parts, mean of a part, exp(-mean)) of Poisson(lam) drawn as a sum of inversions."""
    parts = max(1, int(np.ceil(lam / POISSON_CHUNK)))
    mu = lam / parts
    return parts, mu, exp(-mu)


@njit(cache=True, error_model='numpy', inline='always')
def poisson(u, lanes, j, parts, mu, e_mu):
    """Poisson(parts * mu) by inversion of each part (k = 0, p = exp(-mu), F = p; while u > F:
    k += 1, p *= mu / k, F += p): the first part from the uniform ``u``, the others from
    stream ``j`` of ``lanes`` (4, streams); ``e_mu`` = exp(-mu)."""
    total = 0
    for part in range(parts):
        if part > 0:
            u = unit(lane_u64(lanes, j))
        k = 0
        p = e_mu
        cdf = p
        while u > cdf and p > 0.0:
            k += 1
            p = p * mu / k
            cdf += p
        total += k
    return total


@njit(cache=True, error_model='numpy')
def poisson_levels(parts, mu, e_mu, out):
    """``out[i]`` = floor(F_i 2**53) for i < POISSON_LEVELS, F_i the inversion's running sum
    (:func:`poisson`, the same operations): a uniform k / 2**53 gives at least i + 1 arrivals
    exactly when k > out[i]. -1 (every k exceeds it) when the inversion takes several parts."""
    p = e_mu
    cdf = p
    for i in range(POISSON_LEVELS):
        if i > 0:
            if p <= 0.0:             # the inversion stops where p underflows: no level beyond
                out[i] = NEVER
                continue
            p = p * mu / i
            cdf += p
        out[i] = int(np.floor(cdf * UNIT_BITS)) if parts == 1 else -1


@njit(cache=True, error_model='numpy')
def travel_time(ax, ay, bx, by, speed):
    """t(a, b) [steps] = max(1, ceil(D/s - 1e-9)) for distinct nodes (A6); 0 for the same node."""
    dx = ax - bx
    dy = ay - by
    steps = int(np.ceil(np.sqrt(dx * dx + dy * dy) / speed - TRAVEL_GUARD))
    return max(1, steps)


@njit(cache=True, error_model='numpy')
def travel_table(pos, speed, out):
    """``out[a, b]`` = t(a, b) [steps] for nodes at ``pos`` (M1, 2); 0 on the diagonal; ``out`` (M1, M1) is
    float64 in the kernel (whole numbers, exact), so that the value loops vectorise."""
    m1 = pos.shape[0]
    for a in range(m1):
        out[a, a] = 0
        for b in range(a + 1, m1):
            steps = travel_time(pos[a, 0], pos[a, 1], pos[b, 0], pos[b, 1], speed)
            out[a, b] = steps
            out[b, a] = steps


@njit(cache=True, error_model='numpy', inline='always')
def predict(truth, rate, big_k, growth, observed, observed_at, tau):
    """D_hat_j(tau) from the model's (O_j, t_j) (section 5): linear for Bernoulli (p_hat) and
    Poisson (lam_hat), the closed-form logistic for logistic (A14, 0 if O_j = 0)."""
    if truth == LOGISTIC:
        if observed <= 0.0:
            return 0.0
        return big_k / (1.0 + ((big_k - observed) / observed) * exp(-growth * (tau - observed_at)))
    return observed + rate * (tau - observed_at)


@njit(cache=True, error_model='numpy', inline='always')
def expected(predicted, value, seen, seen_at, rate, t, out, b):
    """D_hat_b(t + out[b]) of location b: ``value[b]`` where a pass of :func:`predict` put it
    (``predicted``), else the linear model's, the same operations as :func:`predict`."""
    return value[b] if predicted else seen[b] + rate * (t + out[b] - seen_at[b])


@njit(cache=True, error_model='numpy', inline='always')
def greater(u, w):
    """u > w by more than TIE_REL relative (A25): otherwise the two are equal."""
    return u > w and (u - w) > TIE_REL * max(abs(u), abs(w))


@njit(cache=True, error_model='numpy')
def astc_wait(big_k, growth, target, observed, observed_at, t, out_time):
    """ASTC's k: the smallest integer k >= 1 with D_hat_a(t + k + t(0, a)) >= target, from the
    closed form then checked against the prediction (7.6); NEVER if target >= K or O_a = 0."""
    if target >= big_k or observed <= 0.0:
        return NEVER
    if observed >= target:
        return 1
    a = (big_k - observed) / observed
    k = int(np.ceil(observed_at + log(a / (big_k / target - 1.0)) / growth - t - out_time))
    k = max(1, k)
    while predict(LOGISTIC, 0.0, big_k, growth, observed, observed_at, t + k + out_time) < target:
        k += 1
    while k > 1 and predict(LOGISTIC, 0.0, big_k, growth, observed, observed_at, t + k - 1 + out_time) >= target:
        k -= 1
    return k


@njit(cache=True, error_model='numpy')
def bernoulli_step(lanes, below, count):
    """One step of Bernoulli generation at every location j >= 1 from its stream ``lanes[:, j]``:
    an item when the draw's top 53 bits are below ``below[j]`` = ceil(p_j 2**53), i.e. u < p_j.
    Adds to ``count`` (M1,) and returns the items generated. Not inlined: alone, the loop vectorises."""
    generated = 0
    for j in range(1, count.shape[0]):
        item = np.int64(np.int64(lane_u64(lanes, j) >> np.uint64(11)) < below[j])
        count[j] += item
        generated += item
    return generated


@njit(cache=True, error_model='numpy')
def poisson_step(lanes, levels, count, draws, parts, part_mean, part_exp):
    """One step of Poisson generation at every location j >= 1 from its stream ``lanes[:, j]``: the
    inversion's count read from the thresholds ``levels`` (POISSON_LEVELS, M1) of
    :func:`poisson_levels`, and where the draw exceeds the last one (rarely), the inversion itself
    (:func:`poisson`). ``draws`` (M1,) is scratch. Adds to ``count`` and returns the arrivals.
    Not inlined: alone, the loop vectorises."""
    level0, level1, level2, level3 = levels[0], levels[1], levels[2], levels[3]
    generated = 0
    tail = False
    for j in range(1, count.shape[0]):
        k = np.int64(lane_u64(lanes, j) >> np.uint64(11))
        arrivals = np.int64(k > level0[j]) + np.int64(k > level1[j]) + np.int64(k > level2[j]) + np.int64(k > level3[j])
        count[j] += arrivals
        generated += arrivals
        tail |= k > level3[j]
        draws[j] = k
    if tail:
        for j in range(1, count.shape[0]):
            if draws[j] > level3[j]:         # the inversion's count replaces the levels'
                arrivals = poisson(draws[j] / UNIT_BITS, lanes, j, parts[j], part_mean[j], part_exp[j]) - POISSON_LEVELS
                count[j] += arrivals
                generated += arrivals
    return generated


# ------------------------------------------------------------------ decisions (section 7)


@njit(cache=True, error_model='numpy', inline='always')
def earmark_move(earmark, capacity, y, a, b):
    """Keep ``earmark`` (M1,) = sum of c - y_r over the robots heading to each location (7.2,
    A27: in transit, its destination; at a node, the node itself until it re-decides; home never
    counts) as one robot with payload ``y`` turns from node ``a`` to ``b``. Updated at each change
    instead of summed over the robots at every decision: whole numbers, so the sums are exact and
    the same in any order."""
    if a > 0:
        earmark[a] -= capacity - y
    if b > 0:
        earmark[b] += capacity - y


@njit(cache=True, error_model='numpy', inline='always')
def uniform_candidate(a, m, rng, stream):
    """A location 1..m other than ``a`` (0: home, every location is one), uniform; STAY if none."""
    count = m - 1 if a > 0 else m
    if count <= 0:
        return STAY
    b = 1 + int(uniform(rng, 0, stream) * count)
    if a > 0 and b >= a:
        b += 1
    return b


@njit(cache=True, error_model='numpy', inline='always')
def decide(i, t, a, opts, pars, travel, observed, observed_at, row, earmark, y, assigned, owner, leave_at,
           rng, value, near_top):
    """Where robot ``i``, at node ``a`` at step ``t``, goes next: a node, or STAY (section 7).

    ``travel`` (M1, M1) travel times; ``observed``, ``observed_at`` (rows, M1) the world model, of
    which the robot reads ``row``;
    ``earmark`` (M1,) sum of c - y_r over robots heading to each node (:func:`earmark_move`; the
    robot itself counts only at its own node, never a candidate); ``y`` (n,) payloads;
    ``assigned`` (n,) AS/ASTC/SF locations (0: none); ``owner`` (M1,) the robot + 1 assigned to
    a location (0: none); ``leave_at`` (n,) SF's step to leave home; draws come from
    ``rng[0, STREAM_ROBOT + i]``; ``value`` (M1,) float64 and ``near_top`` (M1,) int64 are scratch.
    """
    algorithm = opts[O_ALG]
    stream = STREAM_ROBOT + i
    if algorithm == ALG_R:
        return decide_random(a, y[i], opts[O_CAPACITY], pars[P_PV], travel.shape[0] - 1, rng, stream)
    if algorithm == ALG_AS or algorithm == ALG_ASTC or algorithm == ALG_SF:
        return decide_assigned(t, a, opts, pars, travel, observed[row], observed_at[row], assigned[i], owner,
                               leave_at[i], rng, stream)
    return decide_greedy(t, a, opts, pars, travel, observed[row], observed_at[row], earmark, y[i], rng,
                         stream, value, near_top)


@njit(cache=True, error_model='numpy', inline='always')
def decide_random(a, yi, capacity, p_visit, m, rng, stream):
    """R (7.1): full, home; empty, or with probability ``p_visit``, a uniform other location; else home."""
    if yi == capacity:
        return 0 if a > 0 else STAY
    if yi == 0 or uniform(rng, 0, stream) < p_visit:
        return uniform_candidate(a, m, rng, stream)
    return 0 if a > 0 else STAY


@njit(cache=True, error_model='numpy', inline='always')
def decide_assigned(t, a, opts, pars, travel, seen, seen_at, own, owner, leave_at, rng, stream):
    """AS, ASTC and SF (7.5-7.7) for a robot assigned location ``own`` (0: none), reading its
    model's row ``seen``, ``seen_at`` (M1,); SF leaves home at step ``leave_at``; ``owner`` (M1,)."""
    algorithm = opts[O_ALG]
    if a > 0:
        return 0                         # foraged on arrival; home again
    if own == 0:
        return STAY                      # more robots than locations: sleeps for ever
    if algorithm == ALG_SF:
        return own if t >= leave_at else STAY
    big_k, growth = pars[P_K], pars[P_LG]
    target = 0.5 * big_k + opts[O_CAPACITY]
    out_time = travel[0, own]
    if predict(opts[O_TRUTH], pars[P_RATE], big_k, growth, seen[own], seen_at[own], t + out_time) >= target:
        return own
    if algorithm == ALG_AS:
        return STAY
    k = astc_wait(big_k, growth, target, seen[own], seen_at[own], t, out_time)
    m = travel.shape[0] - 1
    count = 0
    for b in range(1, m + 1):
        if owner[b] == 0 and travel[0, b] + travel[b, 0] < k:
            count += 1
    if count == 0:
        return STAY
    pick = int(uniform(rng, 0, stream) * count)
    for b in range(1, m + 1):
        if owner[b] == 0 and travel[0, b] + travel[b, 0] < k:
            if pick == 0:
                return b
            pick -= 1
    return STAY


@njit(cache=True, error_model='numpy', inline='always')
def decide_greedy(t, a, opts, pars, travel, seen, seen_at, earmark, yi, rng, stream, value, near_top):
    """GR, GRIC and CAS (7.2-7.4): the best candidate against a baseline (A25 ties), from the
    model's row ``seen``, ``seen_at`` (M1,); the robot carries ``yi``. See :func:`decide`."""
    algorithm = opts[O_ALG]
    capacity = opts[O_CAPACITY]
    m = travel.shape[0] - 1
    truth = opts[O_TRUTH]
    rate, big_k, growth = pars[P_RATE], pars[P_K], pars[P_LG]
    if yi == capacity and a > 0:
        return 0
    variant = opts[O_CAS]
    sweeper = algorithm == ALG_CAS and variant != CAS_GR_NO_EARMARK
    if sweeper or a == 0:
        baseline, fallback = 0.0, STAY
    else:
        baseline, fallback = yi / travel[a, 0], 0
    # One plain loop per rule over contiguous rows (the model's row, travel times from a, and from
    # home, which by symmetry are those to home), without branches: the compiler vectorises it.
    # The predictions get a pass of their own only where they need one (the logistic closed form)
    # or are the values (CAS max_expected); otherwise the rule's loop computes them as it goes.
    out, back = travel[a], travel[0]
    predicted = truth == LOGISTIC or (sweeper and variant != CAS_RATE)
    if predicted:
        for b in range(1, m + 1):
            value[b] = predict(truth, rate, big_k, growth, seen[b], seen_at[b], t + out[b])
    if sweeper and opts[O_CAS_SHARED]:
        # option cas_shared_targets: the targets of the others, ear-marked as GR's, discount the count
        for b in range(1, m + 1):
            wanted = max(0.0, expected(predicted, value, seen, seen_at, rate, t, out, b) - earmark[b])
            value[b] = wanted / max(1, out[b]) if variant == CAS_RATE else wanted
    elif sweeper:
        if variant == CAS_RATE:
            for b in range(1, m + 1):            # b = a (0 steps) is never chosen
                value[b] = expected(predicted, value, seen, seen_at, rate, t, out, b) / max(1, out[b])
    elif algorithm == ALG_GR and not opts[O_GR_CAP_MAX]:
        for b in range(1, m + 1):
            wanted = expected(predicted, value, seen, seen_at, rate, t, out, b) - earmark[b]
            value[b] = min(capacity, yi + max(0.0, wanted)) / (out[b] + back[b])
    elif algorithm == ALG_GR:                # the text's max (A1)
        for b in range(1, m + 1):
            wanted = expected(predicted, value, seen, seen_at, rate, t, out, b) - earmark[b]
            value[b] = max(capacity, yi + max(0.0, wanted)) / (out[b] + back[b])
    else:
        ear = 1.0 if algorithm != ALG_CAS else 0.0      # CAS gr_no_earmark: GRIC without ear-marks
        for b in range(1, m + 1):
            wanted = expected(predicted, value, seen, seen_at, rate, t, out, b) - ear * earmark[b]
            value[b] = (yi + max(0.0, wanted)) / (out[b] + back[b])
    return best_of(a, m, value, baseline, fallback, travel, opts[O_TIES_LOWEST], rng, stream, near_top)


@njit(cache=True, error_model='numpy', inline='always')
def best_of(a, m, value, baseline, fallback, travel, lowest_index, rng, stream, near_top):
    """The location b != a of greatest ``value[b]`` (>= 0) if it beats ``baseline`` by more than
    TIE_REL (the baseline keeps ties), else ``fallback``. Values within TIE_REL of the greatest
    tie (A25): the shorter t(a, b) wins, then a uniform choice among the tied at that time, by
    one draw (floor(u * ties), in index order) once they are counted; or, with
    ``lowest_index``, the lowest index whatever the travel time. ``value`` is scratch: the
    robot's own node is overwritten; so is ``near_top`` (M1,) int64."""
    if a > 0:
        value[a] = -1.0                  # below every value: never the best, never tied
    # The greatest value, as the greatest bit pattern: non-negative doubles order as their bits
    # read as int64 do, and every negative one (-1, -0.0) reads below them; a maximum of integers
    # vectorises, one of doubles does not (NaN rules). Where the values differ (no positive value)
    # the top beats no baseline (>= 0) either way.
    bits = value.view(np.int64)
    top_bits = MINUS_ONE_BITS
    for b in range(1, m + 1):
        top_bits = max(top_bits, bits[b])
    near_top[0] = top_bits
    top = near_top.view(np.float64)[0]
    if not greater(top, baseline):
        return fallback
    near = top * (1.0 - 4.0 * TIE_REL)   # below it no value is within TIE_REL of top
    # Count the values from ``near`` up, sum their indices and find the first and the last, in a
    # loop without branches that vectorises: when the top is alone there, it is the best with no
    # draw. Otherwise their indices, in order (again without branches, which the scattered ties
    # would mispredict), go through the tie rules, with the same draws as a scan of every location.
    within, where, first, last = 0, 0, m, 0
    for b in range(1, m + 1):
        hit = value[b] >= near
        within += hit
        where += hit * b
        first = min(first, b + (1 - hit) * m)
        last = max(last, hit * b)
    if within == 1:
        return where
    within = 0
    for b in range(first, last + 1):
        near_top[within] = b
        within += value[b] >= near
    best, best_time, ties = STAY, 0, 0
    for c in range(within):
        b = near_top[c]
        v = value[b]
        if greater(top, v) or not greater(v, baseline):
            continue
        time = travel[a, b]
        if best == STAY:
            best, best_time, ties = b, time, 1
            if lowest_index:
                break
        elif time < best_time:
            best, best_time, ties = b, time, 1
        elif time == best_time:
            ties += 1                    # each tied location kept with probability 1/ties
            if uniform(rng, 0, stream) * ties < 1.0:
                best = b
    return best


# ------------------------------------------------------------------ one trial


@njit(cache=True, error_model='numpy')
def observe_in_range(t, reach, pos, travel, node, origin, dest, arrive_at, private, obs_real, truth, count,
                     population, observed, observed_at):
    """A7 (o > 0): at the end of step t every robot observes every location within ``reach`` of
    its position, the node it stands at or, in transit from a to b with l of t(a, b) steps left
    (due at step ``arrive_at`` = t + l), the point a + (t(a, b) - l) / t(a, b) (b - a) of its
    straight path."""
    reach2 = reach * reach
    for i in range(node.shape[0]):
        if node[i] >= 0:
            x, y = pos[node[i], 0], pos[node[i], 1]
        else:
            a, b = origin[i], dest[i]
            done = (travel[a, b] - (arrive_at[i] - t)) / travel[a, b]
            x = pos[a, 0] + done * (pos[b, 0] - pos[a, 0])
            y = pos[a, 1] + done * (pos[b, 1] - pos[a, 1])
        row = i if private else 0
        for j in range(1, pos.shape[0]):
            dx = pos[j, 0] - x
            dy = pos[j, 1] - y
            if dx * dx + dy * dy <= reach2:
                if truth == LOGISTIC:
                    observed[row, j] = population[j] if obs_real else np.floor(population[j])
                else:
                    observed[row, j] = count[j]
                observed_at[row, j] = t



@njit(cache=True, error_model='numpy')
def draw_world(opts, pars, m, rng, pos, truth_par):
    """Stream (a) of a trial: FP positions (x then y per location, index order) if drawn, then
    the m normal deviates of the true parameters mean + sd z, clipped to [low, high] or redrawn
    (A10); logistic draws none. ``pos`` (M1, 2), ``truth_par`` (M1,) filled in place."""
    if opts[O_DRAW_POSITIONS]:
        for j in range(1, m + 1):
            pos[j, 0] = uniform(rng, 0, STREAM_WORLD)
            pos[j, 1] = uniform(rng, 0, STREAM_WORLD)
    if not opts[O_DRAW_PARAMS] or opts[O_TRUTH] == LOGISTIC:
        return
    mean, sd, low, high = pars[P_MEAN], pars[P_SD], pars[P_LOW], pars[P_HIGH]
    spare, have = 0.0, False
    for j in range(1, m + 1):
        while True:
            if have:
                z, have = spare, False
            else:
                z, spare = normal_pair(rng, 0, STREAM_WORLD)
                have = True
            value = mean + sd * z
            if opts[O_RESAMPLE] and (value < low or value > high):
                continue
            break
        truth_par[j] = min(max(value, low), high)


@njit(cache=True, error_model='numpy', nogil=True)
def run_trials(opts, pars, seeds, grid_pos, given_par, totals, per_robot, trace, trace_counts, stop):
    """Every trial of one configuration; results written into ``totals`` (trials, N_TOTALS) and
    ``per_robot`` (trials, n, N_PER_ROBOT), int64.

    ``seeds`` (trials,) root seeds; ``grid_pos`` (M1, 2) node positions (IDP grid, or the given
    world of a test; FP positions are drawn unless ``opts[O_DRAW_POSITIONS]`` is 0);
    ``given_par`` (M1,) true parameters used when ``opts[O_DRAW_PARAMS]`` is 0. ``trace``
    (T + 1, n, 4) and ``trace_counts`` (T + 1, M1) record the first trial step by step when
    their first axis is not empty (tests, replay). ``stop`` (1,) int8: Ctrl-C, checked every step.
    Allocates the state once; :func:`run_trial` runs each trial in it.
    """
    n = opts[O_ROBOTS]
    m1 = grid_pos.shape[0]
    rows = n if opts[O_PRIVATE] != 0 else 1
    travel = np.empty((m1, m1))     # float64: the value loops convert no integer
    travel_table(grid_pos, pars[P_SPEED], travel)
    world = (grid_pos.copy(), travel, given_par.copy())
    generation = (np.zeros((4, m1), dtype=np.uint64), np.zeros((POISSON_LEVELS, m1), dtype=np.int64),
                  np.zeros(m1, dtype=np.int64), np.ones(m1, dtype=np.int64), np.zeros(m1), np.ones(m1))
    locations = (np.zeros(m1, dtype=np.int64), np.zeros(m1), np.zeros((rows, m1)), np.zeros((rows, m1)),
                 np.zeros(m1), np.zeros(m1, dtype=np.int64))
    robots = (np.zeros(n, dtype=np.int64), np.zeros(n, dtype=np.int64), np.zeros(n, dtype=np.int64),
              np.zeros(n, dtype=np.int64), np.zeros(n, dtype=np.int64), np.zeros(n, dtype=np.int64),
              np.zeros(n, dtype=np.int64), np.zeros(n, dtype=np.int64), np.zeros(n, dtype=np.bool_))
    scratch = (np.zeros(m1), np.zeros(m1, dtype=np.int64))
    rng = np.empty((1, STREAM_ROBOT + n, 4), dtype=np.uint64)
    for tr in range(seeds.shape[0]):
        if stop[0] != 0:
            break
        run_trial(opts, pars, seeds[tr], rng, world, generation, locations, robots, scratch,
                  totals[tr], per_robot[tr], trace if tr == 0 else trace[:0], trace_counts, stop)


@borrowing(error_model='numpy', nogil=True)
def run_trial(opts, pars, seed, rng, world, generation, locations, robots, scratch, totals, per_robot, trace,
              trace_counts, stop):
    """One trial from its root ``seed``, in the state :func:`run_trials` allocated (it allocates
    nothing, so numba counts no references: each would be an atomic operation per array at every
    decision). ``world`` = (positions (M1, 2), travel times (M1, M1), true parameters (M1,));
    ``generation`` = (streams (4, M1), thresholds (POISSON_LEVELS, M1), scratch draws, Poisson
    parts, part means, their exp(-mean)) (:func:`seed_generation`); ``locations`` = (counts,
    populations, observed (rows, M1), observed at (rows, M1), ear-marks, owners); ``robots`` =
    (node, destination, origin, arrival step, payload, assigned location, SF sleep, SF leave step,
    arrived) (n,) each; ``scratch`` = (values (M1,), near-top indices (M1,)). Results into
    ``totals`` (N_TOTALS,) and ``per_robot`` (n, N_PER_ROBOT); ``trace`` as in :func:`run_trials`
    (empty: not traced)."""
    mode, truth, algorithm = opts[O_MODE], opts[O_TRUTH], opts[O_ALG]
    steps, capacity, n = opts[O_STEPS], opts[O_CAPACITY], opts[O_ROBOTS]
    pos, travel, truth_par = world
    lanes, threshold, draws, parts, part_mean, part_exp = generation
    count, population, observed, observed_at, earmark, owner = locations
    node, dest, origin, arrive_at, y, assigned, sleep, leave_at, arrived = robots
    value, near_top = scratch
    m1 = pos.shape[0]
    m = m1 - 1
    foraging = mode == MODE_FP
    private = opts[O_PRIVATE] != 0
    big_k, growth, noise = pars[P_K], pars[P_LG], pars[P_SE]
    m_min, x0, reach = pars[P_MMIN], pars[P_X0], pars[P_OBS_RANGE]
    target = 0.5 * big_k + capacity
    earmarking = algorithm == ALG_GR or algorithm == ALG_GRIC or (algorithm == ALG_CAS and opts[O_CAS_SHARED] != 0)
    tracing = trace.shape[0] > 0

    for s in range(STREAM_ROBOT + n):
        seed_stream(rng, 0, s, seed, s)
    draw_world(opts, pars, m, rng, pos, truth_par)
    if opts[O_DRAW_POSITIONS]:
        travel_table(pos, pars[P_SPEED], travel)
    if truth != LOGISTIC:
        seed_generation(truth, seed, truth_par, rng, lanes, threshold, parts, part_mean, part_exp)
    count[:] = 0
    population[:] = x0
    observed[:, :] = x0 if truth == LOGISTIC else 0.0
    observed_at[:, :] = 0.0
    owner[:] = 0
    earmark[:] = 0.0                 # every robot at home: nothing ear-marked
    node[:] = 0
    dest[:] = 0
    y[:] = 0
    assigned[:] = 0
    sleep[:] = 0
    leave_at[:] = 0
    arrived[:] = False
    generated = 0
    served = 0
    picked = 0
    removed = 0.0
    per_robot[:, :] = 0
    totals[T_DEPARTURES:] = 0
    if algorithm == ALG_AS or algorithm == ALG_ASTC or algorithm == ALG_SF:
        assign_locations(min(n, m), rng, owner, assigned)
    spare, have = 0.0, False
    for t in range(0, steps + 1):
        if stop[0] != 0:
            break
        if t > 0:
            # 1. generation, every location; Bernoulli and Poisson from each location's own
            # stream, in loops that vectorise (the inversion only where an arrival is due)
            if truth == BERNOULLI:
                generated += bernoulli_step(lanes, threshold[0], count)
            elif truth == POISSON:
                generated += poisson_step(lanes, threshold, count, draws, parts, part_mean, part_exp)
            else:
                spare, have = logistic_step(growth, big_k, noise, rng, population, spare, have)
            # 2. movement: robots due at their destination arrive
            for i in range(n):
                if node[i] < 0 and arrive_at[i] == t:
                    node[i] = dest[i]
                    arrived[i] = True
        # 3. robots at a node, in id order: serve, observe, decide
        for i in range(n):
            a = node[i]
            if a < 0:
                continue
            row = i if private else 0
            if a == 0:
                if arrived[i]:
                    per_robot[i, R_TRIPS] += 1
                    if algorithm == ALG_SF:
                        leave_at[i] = t + sleep[i]     # A29: the arrival step is the first sleep step
                if foraging and not opts[O_COUNT_PICKUP]:
                    served += y[i]
                    per_robot[i, R_ITEMS] += y[i]
                y[i] = 0
            else:
                if arrived[i]:
                    per_robot[i, R_VISITS] += 1
                if truth == LOGISTIC and algorithm == ALG_SF and arrived[i] and a == assigned[i]:
                    stock = np.floor(population[a])
                    before = sleep[i]
                    sleep[i] = max(0, int(np.floor(sleep[i] + pars[P_KP] * (target - stock) + 0.5)))
                    half = T_SF_UPDATES_LATE if 2 * t > steps else T_SF_UPDATES_EARLY
                    totals[half] += 1
                    totals[half + 1] += abs(sleep[i] - before)
                k, seen = take_at_location(truth, opts[O_OBS_REAL], a, capacity - y[i], m_min, count, population)
                if truth == LOGISTIC:
                    removed += k
                y[i] += k
                picked += k
                if earmarking:
                    earmark[a] -= k              # its c - y_i, still ear-marked at a, shrinks
                if not foraging or opts[O_COUNT_PICKUP]:
                    served += k
                    per_robot[i, R_ITEMS] += k
                observed[row, a] = seen
                observed_at[row, a] = t
            arrived[i] = False
            b = decide(i, t, a, opts, pars, travel, observed, observed_at, row, earmark, y,
                       assigned, owner, leave_at, rng, value, near_top)
            if b != STAY and b != a:
                if b > 0:
                    totals[T_DEPARTURES] += 1
                    if heading_elsewhere(i, b, node, dest):
                        totals[T_SHARED] += 1
                if earmarking:
                    earmark_move(earmark, capacity, y[i], a, b)
                node[i] = -1
                origin[i] = a
                dest[i] = b
                arrive_at[i] = t + int(travel[a, b])     # one jump: no count-down per step
        if reach > 0.0:
            observe_in_range(t, reach, pos, travel, node, origin, dest, arrive_at, private, opts[O_OBS_REAL],
                             truth, count, population, observed, observed_at)
        if tracing:
            record_step(t, node, dest, arrive_at, y, count, population, truth, trace[t], trace_counts[t])
    if truth == LOGISTIC:            # A19: net growth of the stock, foraged included
        stock = 0.0
        for j in range(1, m1):
            stock += population[j]
        generated = int(np.floor(stock + removed - m * x0))
    totals[T_GENERATED] = generated
    totals[T_SERVED] = served
    totals[T_PICKED] = picked
    totals[T_VISITS] = per_robot[:, R_VISITS].sum()
    totals[T_TRIPS] = per_robot[:, R_TRIPS].sum()


@njit(cache=True, error_model='numpy')
def heading_elsewhere(i, b, node, dest):
    """Whether a robot other than ``i`` stands at location ``b`` or is heading to it (``node``,
    ``dest`` (n,)): robot i's departure to b is then to a shared target."""
    for j in range(node.shape[0]):
        if j != i and (node[j] == b or (node[j] < 0 and dest[j] == b)):
            return True
    return False


@njit(cache=True, error_model='numpy')
def seed_generation(truth, seed, truth_par, rng, lanes, threshold, parts, part_mean, part_exp):
    """Seed location j's Bernoulli or Poisson stream (key LOCATION_KEY + j) from the trial's root
    ``seed`` into column j of ``lanes`` (4, M1) and set its thresholds from its true parameter
    ``truth_par[j]``: a draw's top 53 bits k give the uniform u = k / 2**53. Bernoulli:
    ``threshold[0, j]`` = ceil(p_j 2**53), an item when k is below it, i.e. u < p_j. Poisson: the
    inversion gives the smallest i with u <= F_i, i.e. k <= floor(F_i 2**53), so for i <
    POISSON_LEVELS the count is the number of levels ``threshold[:, j]`` that k exceeds; above the
    last one the inversion runs (rarely), in ``parts[j]`` parts of mean ``part_mean[j]``,
    ``part_exp[j]`` = exp(-part_mean[j]). ``rng``'s STREAM_GENERATION slot is the scratch."""
    for j in range(1, lanes.shape[1]):
        seed_stream(rng, 0, STREAM_GENERATION, seed, LOCATION_KEY + j)
        for w in range(4):
            lanes[w, j] = rng[0, STREAM_GENERATION, w]
        if truth == BERNOULLI:
            threshold[0, j] = int(np.ceil(truth_par[j] * UNIT_BITS))
        else:
            parts[j], part_mean[j], part_exp[j] = poisson_parts(truth_par[j])
            poisson_levels(parts[j], part_mean[j], part_exp[j], threshold[:, j])


@njit(cache=True, error_model='numpy')
def assign_locations(robots, rng, owner, assigned):
    """A17: robots 0 .. ``robots`` - 1, in id order, each take a uniform one of the locations not
    yet taken (a draw from its own stream): ``owner`` (M1,) robot + 1 per location, ``assigned`` (n,)."""
    m = owner.shape[0] - 1
    for i in range(robots):
        pick = int(uniform(rng, 0, STREAM_ROBOT + i) * (m - i))
        for j in range(1, m + 1):
            if owner[j] == 0:
                if pick == 0:
                    owner[j] = i + 1
                    assigned[i] = j
                    break
                pick -= 1


@njit(cache=True, error_model='numpy')
def logistic_step(growth, big_k, noise, rng, population, spare, have):
    """One step of every location's stochastic logistic growth (A14; one normal deviate each, in
    pairs from STREAM_GENERATION, ``spare`` the second of a pair when ``have``), floored at 0.
    Returns the new (spare, have)."""
    for j in range(1, population.shape[0]):
        if have:
            z, have = spare, False
        else:
            z, spare = normal_pair(rng, 0, STREAM_GENERATION)
            have = True
        x = population[j]
        x = x + (growth * x * (1.0 - x / big_k) + 0.5 * noise * noise * x) + noise * x * z
        population[j] = max(0.0, x)
    return spare, have


@njit(cache=True, error_model='numpy')
def take_at_location(truth, obs_real, a, free, m_min, count, population):
    """A robot with room for ``free`` items at location ``a`` takes what it can: (items taken,
    what it observes there after). Bernoulli/Poisson: from ``count`` (M1,) int64; logistic: whole
    items above ``m_min`` of ``population`` (M1,), observed as is (``obs_real``) or floored."""
    if truth == LOGISTIC:
        k = min(free, max(0, int(np.floor(population[a]) - m_min)))
        population[a] -= k
        return k, population[a] if obs_real else np.floor(population[a])
    k = min(free, count[a])
    count[a] -= k
    return k, np.float64(count[a])


@njit(cache=True, error_model='numpy')
def record_step(t, node, dest, arrive_at, y, count, population, truth, trace, trace_counts):
    """Step ``t`` of the first trial into ``trace`` (n, 4) (node, destination, steps left, payload)
    and ``trace_counts`` (M1,) (counts, or populations)."""
    for i in range(node.shape[0]):
        moving = node[i] < 0
        trace[i, TR_NODE] = node[i]
        trace[i, TR_DEST] = dest[i] if moving else node[i]
        trace[i, TR_LEFT] = arrive_at[i] - t if moving else 0
        trace[i, TR_Y] = y[i]
    for j in range(trace_counts.shape[0]):
        trace_counts[j] = population[j] if truth == LOGISTIC else count[j]
