"""The compiled discrete-event core.

Time jumps from event to event. Each source says when its next event is and the
earliest is processed; at equal times the order is fixed (docs/delivery-model.md leaves it open):

1. UAV events (delivery or abort instant, landing, loss), lowest UAV id first;
2. an order arrival;
3. an advertisement tick (so a UAV landing or an order arriving at a tick takes part);
4. a time-series sample (so it shows the state after everything at that instant).

Advertisement ticks lie on the grid n * advert_interval_s and happen only while some
UAV is idle and some order is unallocated. State of charge is never stepped: it is a
closed form of the last landing (charging) or of the takeoff (flight), see ``energy``.

The state is a handful of named tuples of arrays (structure of arrays); the loop is one
compiled function, ``advance``, that processes every event up to a given time and can
be called again to go on, so Python can take weekly snapshots, show progress and grow
the attempt table between calls.
"""

from typing import NamedTuple

import numpy as np
from numba import types

from .auction import RULE_SIGNATURE, RULES, bid, reservation_wait
from .energy import plan_attempt, soc_after_charging
from ..fpmath import exp, log
from ..jit import borrowing, njit
from .policy import decision, sgd_step
from ..supervisor import take

# UAV modes. RESERVED: at the FC, charging, committed to an order it takes off with later.
IDLE, OUTBOUND, RETURNING, LOST, RESERVED = 0, 1, 2, 3, 4

# Attempt outcomes.
IN_FLIGHT, OUTCOME_DELIVERED, OUTCOME_ABORTED = 0, 1, 2
OUTCOME_NAMES = ("in_flight", "delivered", "aborted")

# Supervisor events the engine generates: columns of the compiled transition table.
EVENT_NAMES = ("capableTask", "notCapableTask", "bid", "wonBid", "lostBid", "deliver", "condReturn", "return")
# numpy integers, not Python ints: numba types a global Python int as a literal and would compile
# _step and supervisor.take once per event.
EV_CAPABLE, EV_NOT_CAPABLE, EV_BID, EV_WON, EV_LOST_BID, EV_DELIVER, EV_COND_RETURN, EV_RETURN = (
    np.int64(event) for event in range(len(EVENT_NAMES)))

# Status returned by ``advance``. INVALID_STATE: no event fits the state (e.g. a NaN event time
# from non-finite input); the kernel stops rather than write anywhere. STOPPED: its ``stop`` flag
# was set (Ctrl-C, see dronefleet.interrupt). BAD_SCORE: a plugin rule's bidder had a score that
# is not finite (the UAV is in counters[REFUSED_UAV]).
DONE, ATTEMPTS_FULL, SUPERVISOR_REFUSED, INVALID_STATE, STOPPED, BAD_SCORE = 0, 1, 2, 3, 4, 5

# Slots of the int64 ``counters`` array (scalars the kernel updates in place).
(NEXT_ORDER, QUEUE_LEN, LAST_ADVERTISED, NEXT_TICK, N_ATTEMPTS, NEXT_SAMPLE, N_DELIVERED, N_ABORTED,
 N_IDLE, N_LOST, N_AUCTIONS, MAY_BID, REFUSED_UAV, REFUSED_EVENT, N_RESERVED, N_RESERVATIONS,
 N_COUNTERS) = range(17)

# Values of Fleet.bidding: no bid; a bid whose capableTask and bid steps were taken; a bid of
# a bid_silent UAV, whose steps are taken only if it wins.
NO_BID, BID_STEPPED, BID_SILENT = np.int8(0), np.int8(1), np.int8(2)

# Values of Params.bids_on (auction.BIDS_ON).
BIDS_ON_POLICY, BIDS_ON_SOC_THRESHOLD, BIDS_ON_ANY = 0, 1, 2

# Safety margins of the tick skip (see _bid_window): far above rounding error, far below
# anything that matters in the model.
F_MARGIN = 1e-9     # in decision-function units, relative
SOC_MARGIN = 1e-12  # percent
THRESHOLD_MARGIN = 1e-9  # relative, on 100 - SoC (see threshold_gap)
# Relative, on instants in u = e^{k (t - base)} (see _bid_window): covers the rounding of exp and of
# the divisions, and is still far below a tick (1e-9 / k seconds).
U_MARGIN = 1e-9
# The base time of u moves to the present once k (t - base) passes this: u stays far from
# overflow (e^709) whatever the run's length.
REBASE_EXPONENT = 256.0
SCAN_TICKS = 128    # ticks looked ahead at once while someone may bid on some order
# Ticks of a scan epoch: the bounds of the tick scan are computed (one exp per idle UAV) once per
# epoch and hold for every window of SCAN_TICKS within it; longer epochs, looser bounds.
EPOCH_TICKS = 4 * SCAN_TICKS
# An auction picks the UAVs it evaluates from the packed idle set and sorts them into id order
# if the idle UAVs are at most 1/SORT_FRACTION of the fleet, and otherwise in one pass over the
# fleet (cheaper than sorting many).
SORT_FRACTION = 16
# Rows of Fleet.scan_terms: the order weights, the rest of f at the most favourable SoC of the
# epoch (an upper bound) and at the least favourable (a lower bound), |b| (for the margin) and ||w||.
SCAN_W_DISTANCE, SCAN_W_MASS, SCAN_OFFSET, SCAN_OFFSET_LOW, SCAN_ABS_INTERCEPT, SCAN_W_NORM, N_SCAN_ROWS = range(7)
# Rules whose score is the confidence f / ||w|| (negated for least_confident): an auction
# evaluates exactly only the bidders whose bounds of it may reach the best one.
LEAST_CONFIDENT, MOST_CONFIDENT = RULES["least_confident"].code, RULES["most_confident"].code
NO_TICK = np.int64(2 ** 62)  # a tick index after every run
# Queue position and membership changes, numpy integers for one compiled queued_at and _tree_add
# (a Python int literal would be a specialisation of its own).
OLDEST, QUEUED, TAKEN_OUT = np.int64(0), np.int64(1), np.int64(-1)
#: Tick indices from here on stand for "never" (NO_TICK): k * interval is no longer exact
#: for larger k, and no run processes 2^52 ticks.
MAX_TICK = 2.0 ** 52


class Params(NamedTuple):
    """Scalars of the model the kernel needs, in SI units and percent."""

    speed_m_s: float
    xi: float
    charge_rate: float      # k, 1/s
    power_empty_w: float    # flight power without parcel
    alpha: float
    t0: float               # Bottou's t0 of the "optimal" learning rate
    soc_mean: float         # standardisation of the SoC feature
    soc_std: float
    theta: float
    advert_interval_s: float
    record_interval_s: float
    rule: int               # code of the winner rule (auction.RULES); under reservation, the base rule's
    bids_on: int            # BIDS_ON_* of the winner rule
    reserves: bool          # reservation bids (docs/delivery-model.md section 9) when nobody bids immediately


class OrderBook(NamedTuple):
    """Orders (n,) and the queue of unallocated ones."""

    arrival_s: np.ndarray
    distance_m: np.ndarray
    x_distance: np.ndarray  # standardised features
    x_mass: np.ndarray
    power_w: np.ndarray     # flight power carrying the parcel
    attempts: np.ndarray    # int32
    delivered_s: np.ndarray  # nan until delivered
    # The queue of unallocated orders, ascending ids (arrival order), counters[QUEUE_LEN] long:
    # a Fenwick tree of membership counts over ids (queue_tree[id + 1]) finds the k-th order and
    # the rank of an id in O(log n); queue_next links each queued order to the next (-1 after
    # the last), so that a scan walks on in O(1) and an allocated order leaves in O(log n).
    queue_tree: np.ndarray  # int64 (n + 1,)
    queue_next: np.ndarray  # int64 (n,), valid for queued orders
    # The queued orders' features again, packed in no particular order (first counters[QUEUE_LEN]
    # columns), and where each order sits: a UAV's reach is recomputed by a loop over contiguous
    # memory, not by a walk along queue_next (a load that waits for the one before).
    queued_x: np.ndarray    # (2, n): x_distance, x_mass
    queued_ids: np.ndarray  # int64 (n,): the order in each column
    queued_pos: np.ndarray  # int64 (n,): the column of each queued order


class Fleet(NamedTuple):
    """One row per UAV."""

    soh: np.ndarray
    drain: np.ndarray       # SoC percent per second per watt
    coef: np.ndarray        # (S, 3) policy weights
    intercept: np.ndarray
    steps: np.ndarray       # learner step counter (scikit-learn's t_)
    mode: np.ndarray        # int8
    sup: np.ndarray         # (S, K) local supervisor states
    quiet: np.ndarray       # bool: from its states, notCapableTask is allowed and changes none
    # bool: from its states, capableTask and bid are allowed and a lostBid after them brings
    # every local supervisor back: a losing bid changes nothing, and needs no steps.
    bid_silent: np.ndarray
    next_s: np.ndarray      # time of the UAV's next event, inf if none; set only through ``schedule``
    event_heap: np.ndarray  # int64: UAV ids in a binary min-heap on (next_s, id), NaN first (see ``schedule``)
    heap_pos: np.ndarray    # int64: where each UAV sits in event_heap
    soc_ref: np.ndarray     # at the FC: SoC at t_ref, from which it charges
    t_ref: np.ndarray
    order: np.ndarray       # int64, order being flown, -1 if none
    attempt: np.ndarray     # int64, row of the attempt being flown
    takeoff_s: np.ndarray
    takeoff_soc: np.ndarray
    rate_out: np.ndarray    # SoC drain outbound, percent/s
    turn_s: np.ndarray      # delivery or abort instant
    turn_soc: np.ndarray
    rate_home: np.ndarray
    home_s: np.ndarray      # from the turn to landing, or to the loss instant
    land_soc: np.ndarray
    delivers: np.ndarray    # bool: this flight delivers
    lost: np.ndarray        # bool: this flight ends in a loss
    allocated_s: np.ndarray  # when the order being flown (or reserved) was allocated
    forecast_wait_s: np.ndarray  # the winning reservation bid, nan if allocated immediately
    bidding: np.ndarray     # int8 scratch of the auction being resolved: NO_BID, BID_STEPPED or BID_SILENT
    reach: np.ndarray       # max over queued orders of w_distance x_distance + w_mass x_mass
    reach_stale: np.ndarray  # bool: reach must be recomputed before use
    # The idle UAVs, packed in no particular order (first counters[N_IDLE]), and where each
    # sits: the scans that do not depend on id order touch only them.
    idle_ids: np.ndarray    # int64
    idle_pos: np.ndarray    # int64, valid for idle UAVs
    # (N_SCAN_ROWS, S): per slot of idle_ids, the terms of the bounds on its decision value over
    # the scan epoch (rows SCAN_W_DISTANCE ..., see _may_bid), contiguous so that the tick scan streams.
    scan_terms: np.ndarray
    scan_epoch: np.ndarray  # (2,) [start, end] s of the ticks scan_terms hold for; NaN: none yet
    bid_ids: np.ndarray     # int64 scratch of an auction: the UAVs it evaluates, ascending
    # (100 - soc_ref) e^{k (t_ref - base)}: an idle UAV's SoC at u = e^{k (t - base)} is 100 - charge_a / u.
    charge_a: np.ndarray
    charge_base: np.ndarray  # (1,) the base time of u [s]


class Attempts(NamedTuple):
    """One row per delivery attempt, first counters[N_ATTEMPTS] valid."""

    uav: np.ndarray
    order: np.ndarray
    takeoff_s: np.ndarray
    takeoff_soc: np.ndarray
    allocated_s: np.ndarray  # auction won (= takeoff_s unless reserved)
    forecast_wait_s: np.ndarray  # reservation bid (forecast wait until takeoff), nan if not reserved
    outcome: np.ndarray     # int8, IN_FLIGHT until the turn, then OUTCOME_DELIVERED or OUTCOME_ABORTED
    turn_s: np.ndarray      # delivery or abort instant, nan until then
    return_s: np.ndarray    # landing (or loss) instant, nan until then
    return_soc: np.ndarray
    lost: np.ndarray        # bool: the UAV did not come back


class Series(NamedTuple):
    """Time series sampled every record_interval_s, one row per sample."""

    delivered: np.ndarray
    unallocated: np.ndarray
    in_flight: np.ndarray
    aborted: np.ndarray
    idle: np.ndarray
    lost: np.ndarray
    reserved: np.ndarray


@borrowing
def soc_at(fleet, i, t, charge_rate):
    """SoC (percent) of UAV ``i`` at time ``t`` in closed form, whatever it is doing."""
    mode = fleet.mode[i]
    if mode == IDLE or mode == RESERVED:
        return soc_after_charging(fleet.soc_ref[i], t - fleet.t_ref[i], charge_rate)
    if mode == OUTBOUND:
        return fleet.takeoff_soc[i] - (t - fleet.takeoff_s[i]) * fleet.rate_out[i]
    if mode == RETURNING:
        return fleet.turn_soc[i] - (t - fleet.turn_s[i]) * fleet.rate_home[i]
    return np.nan


@borrowing
def _step(table, sup, quiet, bid_silent, counters, i, event):
    """Move UAV ``i``'s supervisor along ``event``; record the refusal and return False if not allowed.

    ``sup``, ``quiet`` and ``bid_silent`` are the Fleet's (kept up to date here): arrays, not
    the whole Fleet, which a call that is not inlined would copy onto the stack.
    """
    if event == EV_NOT_CAPABLE and quiet[i]:
        return True  # allowed, and a self-loop of every local supervisor
    if take(table, sup, i, event):
        loops = True
        silent = True
        for k in range(table.shape[0]):
            state = sup[i, k]
            loops = loops and table[k, state, EV_NOT_CAPABLE] == state
            capable = table[k, state, EV_CAPABLE]
            bidding = table[k, capable, EV_BID] if capable >= 0 else -1
            silent = silent and bidding >= 0 and table[k, bidding, EV_LOST_BID] == state
        quiet[i] = loops
        bid_silent[i] = silent
        return True
    counters[REFUSED_UAV] = i
    counters[REFUSED_EVENT] = event
    return False


@borrowing
def _scan_terms(terms, k, coef, intercept, soc_ref, t_ref, epoch, params, i):
    """Fill slot ``k`` of ``terms`` (Fleet.scan_terms) for idle UAV ``i`` and the scan epoch ``epoch``.

    SoC only grows while charging, so over the epoch's ticks the most favourable SoC is at
    its end if f grows with SoC (SoC 100, t = inf, for a UAV that may reserve) and at its
    start (or the landing, if later) otherwise, and the least favourable at the other end;
    SOC_MARGIN covers the rounding of ``exp``.
    """
    t_start = max(epoch[0], t_ref[i])
    if coef[i, 2] > 0.0:
        t_best, t_worst = np.inf if params.reserves else epoch[1], t_start
    else:
        t_best, t_worst = t_start, epoch[1]
    best = soc_after_charging(soc_ref[i], t_best - t_ref[i], params.charge_rate)
    worst = soc_after_charging(soc_ref[i], t_worst - t_ref[i], params.charge_rate)
    terms[SCAN_W_DISTANCE, k] = coef[i, 0]
    terms[SCAN_W_MASS, k] = coef[i, 1]
    terms[SCAN_OFFSET, k] = intercept[i] + coef[i, 2] * ((best + SOC_MARGIN - params.soc_mean) / params.soc_std)
    terms[SCAN_OFFSET_LOW, k] = intercept[i] + coef[i, 2] * ((worst - SOC_MARGIN - params.soc_mean) / params.soc_std)
    terms[SCAN_ABS_INTERCEPT, k] = abs(intercept[i])
    terms[SCAN_W_NORM, k] = np.sqrt(coef[i, 0] * coef[i, 0] + coef[i, 1] * coef[i, 1] + coef[i, 2] * coef[i, 2])


@borrowing(inline="always")
def _may_bid(terms, k, x_distance, x_mass):
    """Whether the idle UAV in slot ``k`` may have f >= 0 for the order at some tick of the scan epoch.

    An upper bound of f (its SoC term at the most favourable SoC), with a margin (F_MARGIN)
    far above the rounding by which it and the exact decision value differ.
    """
    value = terms[SCAN_W_DISTANCE, k] * x_distance + terms[SCAN_W_MASS, k] * x_mass
    return value + terms[SCAN_OFFSET, k] >= -F_MARGIN * (1.0 + abs(value) + terms[SCAN_ABS_INTERCEPT, k])


@borrowing(inline="always")
def _decision_bounds(terms, k, x_distance, x_mass):
    """(lower, upper) bounds of the decision value of the idle UAV in slot ``k`` for the order at any tick of the epoch.

    Wider than the exact range by the margin of :func:`_may_bid` on each side.
    """
    value = terms[SCAN_W_DISTANCE, k] * x_distance + terms[SCAN_W_MASS, k] * x_mass
    margin = F_MARGIN * (1.0 + abs(value) + terms[SCAN_ABS_INTERCEPT, k])
    return value + terms[SCAN_OFFSET_LOW, k] - margin, value + terms[SCAN_OFFSET, k] + margin


@borrowing(inline="always")
def _confidence_bounds(terms, k, x_distance, x_mass, most):
    """(lower, upper) bounds of the score (confidence, or its negation unless ``most``) of slot ``k`` if it bids.

    The lower bound holds only for a UAV that bids for sure (the lower bound of f >= 0).
    """
    low, high = _decision_bounds(terms, k, x_distance, x_mass)
    w_norm = terms[SCAN_W_NORM, k]
    if most:
        return low / w_norm, high / w_norm
    return -(high / w_norm), -(max(low, 0.0) / w_norm)


@borrowing
def _score_to_beat(fleet, uavs, n, x_distance, x_mass, most):
    """The highest score that some UAV among ``uavs[:n]`` bids for sure with (-inf if none)."""
    beat = -np.inf
    for j in range(n):
        k = fleet.idle_pos[uavs[j]]
        if _decision_bounds(fleet.scan_terms, k, x_distance, x_mass)[0] >= 0.0:
            beat = max(beat, _confidence_bounds(fleet.scan_terms, k, x_distance, x_mass, most)[0])
    return beat


@borrowing
def _become_idle(fleet, counters, params, i):
    """UAV ``i`` has landed (and learned) at ``fleet.t_ref[i]``: it joins the packed idle set."""
    n_idle = counters[N_IDLE]
    fleet.mode[i] = IDLE
    fleet.idle_ids[n_idle] = i
    fleet.idle_pos[i] = n_idle
    counters[N_IDLE] = n_idle + 1
    _scan_terms(fleet.scan_terms, n_idle, fleet.coef, fleet.intercept, fleet.soc_ref, fleet.t_ref,
                fleet.scan_epoch, params, i)
    t = fleet.t_ref[i]
    _rebase(fleet, params, t)
    fleet.charge_a[i] = (100.0 - fleet.soc_ref[i]) * exp(params.charge_rate * (t - fleet.charge_base[0]))


@borrowing
def _leave_idle(fleet, counters, i):
    """UAV ``i`` (idle) won an auction: the last of the packed idle set moves to its slot."""
    last = counters[N_IDLE] - 1
    moved = fleet.idle_ids[last]
    k = fleet.idle_pos[i]
    fleet.idle_ids[k] = moved
    fleet.idle_pos[moved] = k
    terms = fleet.scan_terms
    for row in range(terms.shape[0]):
        terms[row, k] = terms[row, last]
    counters[N_IDLE] = last


@borrowing
def first_tick_at_or_after(t, interval):
    """The smallest tick index k with k * interval >= t, exactly as the loop computes tick times.

    ``ceil(t / interval)`` alone can be off by one when the division or the product rounds.
    An infinite or NaN ``t``, or a ratio ``t / interval`` of MAX_TICK or more (a tiny interval
    or a far event), gives NO_TICK, a tick index beyond any run; nothing can overflow.
    """
    q = t / interval
    if not q < MAX_TICK:
        return NO_TICK
    k = np.int64(np.ceil(q))
    # Below MAX_TICK, ceil(q) is within one of the answer (q and k * interval each round
    # once, and interval > t / 2^52); the bounded loops make a hang impossible regardless.
    for _ in range(4):
        if k * interval < t:
            k += 1
    for _ in range(4):
        if k > 0 and (k - 1) * interval >= t:
            k -= 1
    return k


@borrowing(inline="always")
def _order_value(coef, i, x_distance, x_mass):
    """The part of UAV ``i``'s decision function that depends on the order (standardised features)."""
    return coef[i, 0] * x_distance + coef[i, 1] * x_mass


@borrowing(inline="always")
def _max_order_value(coef, i, queued_x, n):
    """The largest :func:`_order_value` of UAV ``i`` over the first ``n`` columns of ``queued_x`` (-inf if none).

    A max is exact, so its order does not matter: four running maxima, so that each step
    does not wait for the comparison before it.
    """
    b0 = b1 = b2 = b3 = -np.inf
    x0 = queued_x[0]
    x1 = queued_x[1]
    whole = n - n % 4
    for j in range(0, whole, 4):
        b0 = max(b0, _order_value(coef, i, x0[j], x1[j]))
        b1 = max(b1, _order_value(coef, i, x0[j + 1], x1[j + 1]))
        b2 = max(b2, _order_value(coef, i, x0[j + 2], x1[j + 2]))
        b3 = max(b3, _order_value(coef, i, x0[j + 3], x1[j + 3]))
    for j in range(whole, n):
        b0 = max(b0, _order_value(coef, i, x0[j], x1[j]))
    return max(max(b0, b1), max(b2, b3))


@borrowing
def _earlier(next_s, a, b):
    """Whether UAV ``a``'s next event comes before ``b``'s: by time, then by id, NaN first.

    The same order as ``np.argmin(next_s)``, which returns the lowest id among the minima,
    and the first NaN if there is one (so that ``advance`` reports INVALID_STATE).
    """
    ta = next_s[a]
    tb = next_s[b]
    if ta != ta:
        return tb == tb or a < b
    if tb != tb:
        return False
    return ta < tb or (ta == tb and a < b)


@borrowing
def schedule(fleet, i, t):
    """Set UAV ``i``'s next event to ``t`` and move it to its place in the event heap (O(log S))."""
    next_s = fleet.next_s
    heap = fleet.event_heap
    where = fleet.heap_pos
    next_s[i] = t
    n = heap.shape[0]
    k = where[i]
    while k > 0:  # up, while earlier than the parent
        parent = (k - 1) >> 1
        p = heap[parent]
        if not _earlier(next_s, i, p):
            break
        heap[k] = p
        where[p] = k
        k = parent
    while True:  # down, while a child is earlier
        child = 2 * k + 1
        if child >= n:
            break
        if child + 1 < n and _earlier(next_s, heap[child + 1], heap[child]):
            child += 1
        c = heap[child]
        if not _earlier(next_s, c, i):
            break
        heap[k] = c
        where[c] = k
        k = child
    heap[k] = i
    where[i] = k


@borrowing
def _rank(tree, order):
    """How many queued orders have an id <= ``order`` (0 for -1)."""
    count = 0
    k = order + 1
    while k > 0:
        count += tree[k]
        k &= k - 1
    return count


@borrowing
def queued_at(tree, k):
    """The queued order at position ``k`` (0-based, ascending ids); ``k`` < the queue length."""
    n = tree.shape[0] - 1
    step = 1
    while 2 * step <= n:
        step *= 2
    node = 0  # the answer is the smallest id whose rank is k + 1
    left = k + 1
    while step > 0:
        if node + step <= n and tree[node + step] < left:
            node += step
            left -= tree[node]
        step >>= 1
    return node


@borrowing
def _tree_add(tree, order, delta):
    """Add ``delta`` (1: queued, -1: taken out) to ``order``'s membership count."""
    k = order + 1
    while k < tree.shape[0]:
        tree[k] += delta
        k += k & -k


@borrowing
def _enqueue(book, fleet, counters, order):
    """Put ``order`` among the unallocated ones, at its place in arrival order."""
    tree = book.queue_tree
    link = book.queue_next
    n = counters[QUEUE_LEN]
    before = _rank(tree, order)  # queued orders with a lower id
    if before > 0:
        previous = queued_at(tree, before - 1)
        link[order] = link[previous]
        link[previous] = order
    else:
        link[order] = queued_at(tree, OLDEST) if n > 0 else -1
    _tree_add(tree, order, QUEUED)
    counters[QUEUE_LEN] = n + 1
    coef = fleet.coef
    reach = fleet.reach
    x0 = book.x_distance[order]
    x1 = book.x_mass[order]
    book.queued_x[0, n] = x0
    book.queued_x[1, n] = x1
    book.queued_ids[n] = order
    book.queued_pos[order] = n
    for i in range(reach.shape[0]):
        reach[i] = max(reach[i], _order_value(coef, i, x0, x1))


@borrowing
def _dequeue(book, fleet, counters, pos):
    """Take the order at queue position ``pos`` out of the queue."""
    tree = book.queue_tree
    order = queued_at(tree, pos)
    if pos > 0:
        book.queue_next[queued_at(tree, pos - 1)] = book.queue_next[order]
    _tree_add(tree, order, TAKEN_OUT)
    last = counters[QUEUE_LEN] - 1
    counters[QUEUE_LEN] = last
    # The last packed column moves into the one the order leaves.
    k = book.queued_pos[order]
    moved = book.queued_ids[last]
    book.queued_x[0, k] = book.queued_x[0, last]
    book.queued_x[1, k] = book.queued_x[1, last]
    book.queued_ids[k] = moved
    book.queued_pos[moved] = k
    coef = fleet.coef
    reach = fleet.reach
    stale = fleet.reach_stale
    x0 = book.x_distance[order]
    x1 = book.x_mass[order]
    for i in range(reach.shape[0]):
        if _order_value(coef, i, x0, x1) >= reach[i]:
            stale[i] = True


@borrowing
def threshold_gap(theta):
    """A bound on 100 - SoC below which a charging UAV's computed SoC may be >= ``theta``.

    The computed SoC is 100 - x rounded to nearest, which is >= theta only if x is at most
    100 - theta plus half the spacing of doubles just below theta (SoC 100 itself is
    reached once x < 2^-47, about 13 days of charging). THRESHOLD_MARGIN covers the
    rounding of x (exp, products, the tick instant) many times over.
    """
    half_ulp = 0.5 * (theta - np.nextafter(theta, -np.inf))
    return ((100.0 - theta) + half_ulp) * (1.0 + THRESHOLD_MARGIN)


@borrowing(inline="always")
def _earliest_bid(fleet, counters, params):
    """A lower bound on when an idle UAV's SoC may first reach theta (threshold rules), if nothing else happens.

    Idle UAVs only charge, so their SoC only grows; the crossing is the inverse of the charging
    curve, in closed form to within rounding (:func:`threshold_gap`, even for theta = 100),
    from the landing, not from the SoC now: near 100 % the computed SoC has too few significant
    digits left in 100 - SoC.
    """
    earliest = np.inf
    theta_gap = threshold_gap(params.theta)
    for k in range(counters[N_IDLE]):
        i = fleet.idle_ids[k]
        earliest = min(earliest, fleet.t_ref[i] + log((100.0 - fleet.soc_ref[i]) / theta_gap) / params.charge_rate)
    return earliest


@borrowing(inline="always")
def _bid_window(value, intercept, coef_soc, charge_a, params, open_u, close_u):
    """``(open_u, close_u)`` widened by when an idle UAV may bid on an order (rules that bid on their policy).

    ``value`` is the order's part of the UAV's decision value (:func:`_order_value`), ``coef_soc``
    its SoC weight, ``charge_a`` its Fleet.charge_a. While charging, SoC = 100 - a / u with
    u = e^{k (t - base)} and f is linear in SoC, so with s* the SoC at which f = 0 the UAV may
    bid from u = a / (100 - s*) on if its SoC weight is positive (one division, no log), up to
    that instant if it is negative (its window closes as it charges), always or never if zero.
    The margins (F_MARGIN on f, SOC_MARGIN, U_MARGIN) make the window wider than any rounding
    of the exact decision value at a tick: it only flags ticks, an auction decides. With
    reservations a UAV whose f grows with SoC may bid (reserve) at once if s* < 100.
    """
    slack = value + intercept
    margin = F_MARGIN * (1.0 + abs(value) + abs(intercept))
    w_soc = coef_soc / params.soc_std
    if w_soc == 0.0:
        if slack >= -margin:
            open_u = 0.0
        return open_u, close_u
    need = params.soc_mean + (-slack - margin) / w_soc
    if w_soc > 0.0:
        gap = 100.0 - need + SOC_MARGIN
        if gap > 0.0:
            open_u = min(open_u, 0.0 if params.reserves else charge_a / gap * (1.0 - U_MARGIN))
        return open_u, close_u
    gap = 100.0 - need - SOC_MARGIN
    if gap > 0.0:
        close_u = max(close_u, charge_a / gap * (1.0 + U_MARGIN))
    else:  # below s* up to SoC 100: the window never closes (and a NaN weight lands here too)
        open_u = 0.0
    return open_u, close_u


@borrowing
def _rebase(fleet, params, t):
    """Move the base time of u = e^{k (t - base)} to ``t`` once k (t - base) passes REBASE_EXPONENT.

    Every Fleet.charge_a is scaled by e^{-k (t - base)}; each product rounds once, far within U_MARGIN.
    """
    base = fleet.charge_base[0]
    if not params.charge_rate * (t - base) > REBASE_EXPONENT:
        return
    factor = exp(-params.charge_rate * (t - base))
    for i in range(fleet.charge_a.shape[0]):
        fleet.charge_a[i] *= factor
    fleet.charge_base[0] = t


@borrowing(inline="always")
def _first_tick_anyone(book, fleet, counters, params, t_tick):
    """A tick at or before the first one at which some idle UAV may bid on some queued order, if nothing
    else happens (the next tick if one may bid now; NO_TICK if none ever will).

    Each UAV's window for its best order (Fleet.reach, the largest order value over the queue)
    holds every other order's: :func:`_bid_window` is monotone in the order value.
    """
    base = fleet.charge_base[0]
    u = exp(params.charge_rate * (t_tick - base))
    open_u = np.inf
    close_u = 0.0
    for k in range(counters[N_IDLE]):
        i = fleet.idle_ids[k]
        if fleet.reach_stale[i]:
            fleet.reach[i] = _max_order_value(fleet.coef, i, book.queued_x, counters[QUEUE_LEN])
            fleet.reach_stale[i] = False
        open_u, close_u = _bid_window(fleet.reach[i], fleet.intercept[i], fleet.coef[i, 2], fleet.charge_a[i],
                                      params, open_u, close_u)
        if open_u <= u or close_u >= u:
            return counters[NEXT_TICK]
    tick = counters[NEXT_TICK]
    if not open_u < np.inf:
        return NO_TICK
    # One tick early: the log and the tick instant round.
    return max(tick, first_tick_at_or_after(base + log(open_u) / params.charge_rate, params.advert_interval_s) - 1)


@borrowing(inline="always")
def _first_possible_tick(book, fleet, counters, params, t_tick, end_max):
    """The first tick before tick ``end_max`` (and within SCAN_TICKS) whose order some idle UAV may bid on.

    Only for rules that bid on their policy. Over the scanned ticks each idle UAV's
    decision value for an order is at most its bound over the scan epoch (:func:`_may_bid`),
    so an order for which that bound is negative for everyone has no bidder at its tick.
    A window past the epoch starts a new one at ``t_tick``.
    Returns the index of the first tick that may have one, or of the tick after the window.
    """
    interval = params.advert_interval_s
    tick = counters[NEXT_TICK]
    end = min(end_max, tick + SCAN_TICKS)
    n_idle = counters[N_IDLE]
    epoch = fleet.scan_epoch
    if not end * interval <= epoch[1]:  # after every scanned tick
        epoch[0] = t_tick
        epoch[1] = t_tick + EPOCH_TICKS * interval
        for k in range(n_idle):
            _scan_terms(fleet.scan_terms, k, fleet.coef, fleet.intercept, fleet.soc_ref, fleet.t_ref, epoch, params,
                        fleet.idle_ids[k])
    terms = fleet.scan_terms
    # :func:`_may_bid` with one margin for all slots, wider than each one's by F_MARGIN (1 + ...), far
    # more than the rounding of either (|value| <= |w_distance x0| + |w_mass x1|): it passes wherever
    # _may_bid does, and the per-slot test is a dot product and a comparison (value + offset rounds
    # as in _may_bid). A tick it lets through in vain is an auction nobody bids in, as any other.
    abs_distance = abs_mass = abs_intercept = 0.0
    for k in range(n_idle):
        abs_distance = max(abs_distance, abs(terms[SCAN_W_DISTANCE, k]))
        abs_mass = max(abs_mass, abs(terms[SCAN_W_MASS, k]))
        abs_intercept = max(abs_intercept, terms[SCAN_ABS_INTERCEPT, k])
    tree = book.queue_tree
    link = book.queue_next
    x_distance = book.x_distance
    x_mass = book.x_mass
    order = queued_at(tree, _rank(tree, counters[LAST_ADVERTISED]) % counters[QUEUE_LEN])
    for j in range(end - tick):
        x0 = x_distance[order]
        x1 = x_mass[order]
        low = -F_MARGIN * (2.0 + abs_intercept + 2.0 * (abs_distance * abs(x0) + abs_mass * abs(x1)))
        anyone = False
        for k in range(n_idle):  # no early exit: a branch-free loop the compiler can vectorise
            anyone |= terms[SCAN_W_DISTANCE, k] * x0 + terms[SCAN_W_MASS, k] * x1 + terms[SCAN_OFFSET, k] >= low
        if anyone:
            return tick + j
        order = link[order]
        if order < 0:  # past the newest: round again from the oldest
            order = queued_at(tree, OLDEST)
    return end


# Inlined into advance, with _earliest_bid and _first_possible_tick: as calls, each one increfs and
# decrefs every array it reads from the named tuples, at every event that leaves a tick pending
# (reference counting was 28 % of the paper run, docs/guide/benchmarks.md); inlined, numba prunes the pairs.
@borrowing(inline="always")
def _skip_ticks(book, fleet, counters, params, t_tick, t_other, t_stop):
    """Jump over ticks before ``t_other`` at which provably nobody bids; True if any were skipped.

    ``t_other`` is the next event that changes the state (a UAV's, an order's arrival; a
    sample changes nothing a bid depends on). Each skipped tick still advertises (the position
    moves on, cyclically) and counts as an auction; nothing else happens at them.
    """
    interval = params.advert_interval_s
    # Ticks before t_other, and at or before t_stop, so that a paused run holds exactly
    # the state at t_stop.
    stop_end = first_tick_at_or_after(t_stop, interval)
    if stop_end * interval == t_stop:
        stop_end += 1
    end = min(first_tick_at_or_after(t_other, interval), stop_end)
    if params.bids_on == BIDS_ON_POLICY:
        _rebase(fleet, params, t_tick)
        if counters[MAY_BID] == 0:
            start = _first_tick_anyone(book, fleet, counters, params, t_tick)
            if start > counters[NEXT_TICK]:
                end = min(end, start)
            else:
                counters[MAY_BID] = 1
        if counters[MAY_BID] == 1:
            end = _first_possible_tick(book, fleet, counters, params, t_tick, end)
    else:
        if counters[MAY_BID] == 0:
            earliest = _earliest_bid(fleet, counters, params) - interval
            if earliest <= t_tick:
                counters[MAY_BID] = 1
            else:
                end = min(end, first_tick_at_or_after(earliest, interval))
        if counters[MAY_BID] == 1:
            return False
    skipped = end - counters[NEXT_TICK]
    if skipped <= 0:
        return False
    tree = book.queue_tree
    counters[LAST_ADVERTISED] = queued_at(tree, (_rank(tree, counters[LAST_ADVERTISED]) + skipped - 1)
                                          % counters[QUEUE_LEN])
    counters[N_AUCTIONS] += skipped
    counters[NEXT_TICK] = end
    return True


@borrowing
def _takeoff(book, fleet, attempts, counters, params, i, order, t, soc):
    """UAV ``i`` takes off with ``order`` at ``t``: its whole flight is planned in closed form.

    ``fleet.allocated_s[i]`` and ``fleet.forecast_wait_s[i]`` must say how it got the order.
    """
    rate_out = book.power_w[order] * fleet.drain[i]
    rate_empty = params.power_empty_w * fleet.drain[i]
    delivers, outbound_s, turn_soc, home_s, land_soc, lost = plan_attempt(
        soc, book.distance_m[order], params.speed_m_s, rate_out, rate_empty, params.xi)
    row = counters[N_ATTEMPTS]
    counters[N_ATTEMPTS] = row + 1
    attempts.uav[row] = i
    attempts.order[row] = order
    attempts.takeoff_s[row] = t
    attempts.takeoff_soc[row] = soc
    attempts.allocated_s[row] = fleet.allocated_s[i]
    attempts.forecast_wait_s[row] = fleet.forecast_wait_s[i]
    attempts.outcome[row] = IN_FLIGHT
    book.attempts[order] += 1
    fleet.mode[i] = OUTBOUND
    fleet.order[i] = order
    fleet.attempt[i] = row
    fleet.takeoff_s[i] = t
    fleet.takeoff_soc[i] = soc
    fleet.rate_out[i] = rate_out
    fleet.turn_s[i] = t + outbound_s
    fleet.turn_soc[i] = turn_soc
    fleet.rate_home[i] = rate_out if not delivers else rate_empty
    fleet.home_s[i] = home_s
    fleet.land_soc[i] = land_soc
    fleet.delivers[i] = delivers
    fleet.lost[i] = lost
    schedule(fleet, i, t + outbound_s)


@borrowing
def _uav_event(book, fleet, attempts, counters, params, table, i, t):
    """The reserved takeoff, turn (delivery or abort), landing or loss of UAV ``i`` at ``t``. False if refused."""
    row = fleet.attempt[i]
    order = fleet.order[i]
    if fleet.mode[i] == RESERVED:
        if not _step(table, fleet.sup, fleet.quiet, fleet.bid_silent, counters, i, EV_DELIVER):
            return False
        counters[N_RESERVED] -= 1
        _takeoff(book, fleet, attempts, counters, params, i, order, t,
                 soc_after_charging(fleet.soc_ref[i], t - fleet.t_ref[i], params.charge_rate))
        return True
    if fleet.mode[i] == OUTBOUND:
        attempts.turn_s[row] = t
        if fleet.delivers[i]:
            attempts.outcome[row] = OUTCOME_DELIVERED
            book.delivered_s[order] = t
            counters[N_DELIVERED] += 1
        else:
            attempts.outcome[row] = OUTCOME_ABORTED
            counters[N_ABORTED] += 1
        if not _step(table, fleet.sup, fleet.quiet, fleet.bid_silent, counters, i, EV_COND_RETURN):
            return False
        fleet.mode[i] = RETURNING
        schedule(fleet, i, t + fleet.home_s[i])
        return True
    # RETURNING: the flight ends.
    attempts.return_s[row] = t
    fleet.order[i] = -1
    schedule(fleet, i, np.inf)
    if fleet.lost[i]:
        attempts.lost[row] = True
        attempts.return_soc[row] = 0.0
        fleet.mode[i] = LOST
        counters[N_LOST] += 1
        if not fleet.delivers[i]:
            _enqueue(book, fleet, counters, order)
        return True
    if not _step(table, fleet.sup, fleet.quiet, fleet.bid_silent, counters, i, EV_RETURN):
        return False
    attempts.return_soc[row] = fleet.land_soc[i]
    fleet.soc_ref[i] = fleet.land_soc[i]
    fleet.t_ref[i] = t
    if not fleet.delivers[i]:
        _enqueue(book, fleet, counters, order)
    # One partial_fit step on what the UAV saw at takeoff and what happened.
    sgd_step(fleet.coef, fleet.intercept, fleet.steps, i,
             book.x_distance[order], book.x_mass[order],
             (fleet.takeoff_soc[i] - params.soc_mean) / params.soc_std,
             1.0 if fleet.delivers[i] else 0.0, params.alpha, params.t0)
    fleet.reach_stale[i] = True
    _become_idle(fleet, counters, params, i)
    return True


@borrowing
def _reserved_takeoff(book, fleet, params, i, order, t, wait):
    """When UAV ``i``, reserving ``order`` at ``t`` with bid ``wait``, takes off.

    At t + wait its SoC reaches the level at which its policy says "bid", up to rounding;
    the instant is moved on by a few units in the last place until the decision computed
    as at takeoff is >= 0, so the reserved flight never starts on a "no". This ends
    because the policy says "bid" at SoC 100 (checked in :func:`_reservation_bids`); only
    non-finite inputs can run the doubling steps to inf, and then the instant is NaN, which
    ``advance`` reports as INVALID_STATE.
    """
    x0 = book.x_distance[order]
    x1 = book.x_mass[order]
    takeoff = t + wait
    step = abs(takeoff) * 2.2e-16 + 1e-300
    while takeoff < np.inf:
        soc = soc_after_charging(fleet.soc_ref[i], takeoff - fleet.t_ref[i], params.charge_rate)
        if decision(fleet.coef, fleet.intercept, i, x0, x1, (soc - params.soc_mean) / params.soc_std) >= 0.0:
            return takeoff
        takeoff += step
        step *= 2.0
    return np.nan


@borrowing
def _reservation_bids(book, fleet, counters, params, table, order, t, immediate):
    """Second phase of an auction with reservations: the idle UAVs that did not bid now.

    If someone bid now (``immediate``), no reservation can win: they only pass
    (notCapableTask). Otherwise each bids its forecast wait, if it has one (capableTask,
    bid). Returns (refused, the lowest bidder, its wait); ties go to the highest id, and
    (-1, inf) if nobody reserves.
    """
    reserver = -1
    best_wait = np.inf
    x0 = book.x_distance[order]
    x1 = book.x_mass[order]
    x_full = (100.0 - params.soc_mean) / params.soc_std
    for i in range(fleet.mode.shape[0]):
        if fleet.mode[i] != IDLE or fleet.bidding[i]:
            continue
        wait = np.inf
        if not immediate:
            soc = soc_after_charging(fleet.soc_ref[i], t - fleet.t_ref[i], params.charge_rate)
            f_order = fleet.coef[i, 0] * x0 + fleet.coef[i, 1] * x1 + fleet.intercept[i]
            wait = reservation_wait(f_order, fleet.coef[i, 2], soc, params.soc_mean, params.soc_std,
                                    params.charge_rate)
            # SoC never passes 100: if rounding puts f at 100 below 0 while s* < 100, the UAV
            # would wait for ever (and _reserved_takeoff never return).
            if wait < np.inf and decision(fleet.coef, fleet.intercept, i, x0, x1, x_full) < 0.0:
                wait = np.inf
        if wait == np.inf:
            if not _step(table, fleet.sup, fleet.quiet, fleet.bid_silent, counters, i, EV_NOT_CAPABLE):
                return True, -1, np.inf
            continue
        if not (_step(table, fleet.sup, fleet.quiet, fleet.bid_silent, counters, i, EV_CAPABLE)
                and _step(table, fleet.sup, fleet.quiet, fleet.bid_silent, counters, i, EV_BID)):
            return True, -1, np.inf
        fleet.bidding[i] = BID_STEPPED
        if wait <= best_wait:  # ascending ids: ties go to the highest id
            best_wait = wait
            reserver = i
    return False, reserver, best_wait


# _nrt set, not left to be inherited from the borrowing caller: numba's sort allocates its stack.
@njit(cache=True, _nrt=True)
def _sort(ids, n):
    """Sort ``ids[:n]`` in place."""
    ids[:n].sort()


@borrowing
def _auction_uavs(fleet, counters, x_distance, x_mass, bounded):
    """Put the idle UAVs an auction must evaluate into ``fleet.bid_ids``, ascending; return how many.

    All idle UAVs, or with ``bounded`` (a rule that bids on its policy, bounds that hold now,
    no reservations) only those that may bid (:func:`_may_bid`) or whose notCapableTask
    step is not a silent self-loop: for the others the auction changes nothing.
    """
    ids = fleet.bid_ids
    n_uavs = fleet.mode.shape[0]
    n = 0
    if counters[N_IDLE] * SORT_FRACTION <= n_uavs:
        for k in range(counters[N_IDLE]):
            i = fleet.idle_ids[k]
            if not bounded or not fleet.quiet[i] or _may_bid(fleet.scan_terms, k, x_distance, x_mass):
                ids[n] = i
                n += 1
        _sort(ids, n)
        return n
    for i in range(n_uavs):
        if fleet.mode[i] == IDLE and (not bounded or not fleet.quiet[i]
                                      or _may_bid(fleet.scan_terms, fleet.idle_pos[i], x_distance, x_mass)):
            ids[n] = i
            n += 1
    return n


@borrowing
def _auction(book, fleet, attempts, counters, params, table, rng, t, rule_kernel):
    """Advertise one order at tick time ``t``, resolve its auction: DONE, SUPERVISOR_REFUSED or BAD_SCORE.

    Immediate bids are resolved by the rule (``rule_kernel``: a plugin's, see ``advance``). With
    reservations and nobody bidding now, the idle UAVs bid for later (:func:`_reservation_bids`):
    the lowest wait wins, and the winner waits at the FC.
    """
    pos = _rank(book.queue_tree, counters[LAST_ADVERTISED])
    if pos == counters[QUEUE_LEN]:
        pos = 0
    order = queued_at(book.queue_tree, pos)
    counters[N_AUCTIONS] += 1
    x0 = book.x_distance[order]
    x1 = book.x_mass[order]
    winner = -1
    winner_soc = 0.0
    best = -np.inf
    bidder = fleet.bidding
    # Arrays bound once, and weights read by index: no array views made per UAV in this loop.
    coef = fleet.coef
    soc_ref = fleet.soc_ref
    t_ref = fleet.t_ref
    # A rule that bids on its policy cannot bid where the tick scan's bound rules it out: no
    # SoC (exp) and decision then for that UAV.
    bounded = params.bids_on == BIDS_ON_POLICY and fleet.scan_epoch[0] <= t <= fleet.scan_epoch[1]
    uavs = fleet.bid_ids
    n_evaluated = _auction_uavs(fleet, counters, x0, x1, bounded and not params.reserves)
    # Under a confidence rule, a bidder whose score is certainly below one that some UAV bids
    # for sure cannot win (nor tie): if its bid and loss change nothing (bid_silent) and its
    # not bidding neither (quiet), it need not be evaluated at all.
    confidence = bounded and not params.reserves and (params.rule == LEAST_CONFIDENT or params.rule == MOST_CONFIDENT)
    most = params.rule == MOST_CONFIDENT
    beat = _score_to_beat(fleet, uavs, n_evaluated, x0, x1, most) if confidence else -np.inf
    for j in range(n_evaluated):
        i = uavs[j]
        bidder[i] = NO_BID
        if (confidence and fleet.quiet[i] and fleet.bid_silent[i]
                and _confidence_bounds(fleet.scan_terms, fleet.idle_pos[i], x0, x1, most)[1] < beat):
            continue
        if bounded and not _may_bid(fleet.scan_terms, fleet.idle_pos[i], x0, x1):
            bids = False
        else:
            soc = soc_after_charging(soc_ref[i], t - t_ref[i], params.charge_rate)
            f = decision(coef, fleet.intercept, i, x0, x1, (soc - params.soc_mean) / params.soc_std)
            w_norm = np.sqrt(coef[i, 0] * coef[i, 0] + coef[i, 1] * coef[i, 1] + coef[i, 2] * coef[i, 2])
            bids, score = bid(params.rule, rule_kernel, f, w_norm, soc, params.theta, rng)
            # A plugin's bid must have a finite score: NaN loses every comparison (nobody would win).
            if rule_kernel is not None and bids and not abs(score) < np.inf:
                counters[REFUSED_UAV] = i
                return BAD_SCORE
        if not bids:
            # With reservations the UAV's step waits for the second phase.
            if (not params.reserves and not fleet.quiet[i]
                    and not _step(table, fleet.sup, fleet.quiet, fleet.bid_silent, counters, i, EV_NOT_CAPABLE)):
                return SUPERVISOR_REFUSED
            continue
        if fleet.bid_silent[i]:
            bidder[i] = BID_SILENT
        elif (_step(table, fleet.sup, fleet.quiet, fleet.bid_silent, counters, i, EV_CAPABLE)
                and _step(table, fleet.sup, fleet.quiet, fleet.bid_silent, counters, i, EV_BID)):
            bidder[i] = BID_STEPPED
        else:
            return SUPERVISOR_REFUSED
        if score >= best:  # ascending ids: ties go to the highest id
            best = score
            winner = i
            winner_soc = soc
    reserved = False
    if params.reserves:
        refused, reserver, best_wait = _reservation_bids(book, fleet, counters, params, table, order, t, winner >= 0)
        if refused:
            return SUPERVISOR_REFUSED
        reserved = winner < 0 and reserver >= 0
        if reserved:
            winner = reserver
    if winner < 0:
        counters[LAST_ADVERTISED] = order
        return DONE
    for j in range(n_evaluated):
        i = uavs[j]
        if (bidder[i] == BID_STEPPED and i != winner
                and not _step(table, fleet.sup, fleet.quiet, fleet.bid_silent, counters, i, EV_LOST_BID)):
            return SUPERVISOR_REFUSED
    if bidder[winner] == BID_SILENT:  # its bid's steps, allowed (bid_silent), then the win
        _step(table, fleet.sup, fleet.quiet, fleet.bid_silent, counters, winner, EV_CAPABLE)
        _step(table, fleet.sup, fleet.quiet, fleet.bid_silent, counters, winner, EV_BID)
    if not _step(table, fleet.sup, fleet.quiet, fleet.bid_silent, counters, winner, EV_WON):
        return SUPERVISOR_REFUSED
    # Allocated: out of the queue, and the next advertisement starts again from the oldest.
    _dequeue(book, fleet, counters, pos)
    counters[LAST_ADVERTISED] = -1
    counters[MAY_BID] = 0
    _leave_idle(fleet, counters, winner)
    fleet.allocated_s[winner] = t
    if reserved:
        # Stays at the FC, charging, in the supervisor's state after wonBid until takeoff.
        fleet.mode[winner] = RESERVED
        fleet.order[winner] = order
        fleet.forecast_wait_s[winner] = best_wait
        schedule(fleet, winner, _reserved_takeoff(book, fleet, params, winner, order, t, best_wait))
        counters[N_RESERVED] += 1
        counters[N_RESERVATIONS] += 1
        return DONE
    if not _step(table, fleet.sup, fleet.quiet, fleet.bid_silent, counters, winner, EV_DELIVER):
        return SUPERVISOR_REFUSED
    fleet.forecast_wait_s[winner] = np.nan
    _takeoff(book, fleet, attempts, counters, params, winner, order, t, winner_soc)
    return DONE


@borrowing(nogil=True)
def advance(book, fleet, attempts, series, counters, params, table, rng, t_stop, rule_kernel, stop):
    """Process every event at or before ``t_stop`` (seconds), in the order of the module doc.

    All arguments but ``params``, ``table`` (compiled supervisor, (K, states, events)
    int64), ``rng`` (random-bid stream), ``rule_kernel`` and ``stop`` are updated in place.
    ``rule_kernel`` is None for a built-in rule (``params.rule``) and a plugin rule's function
    otherwise, passed as a first-class function (compiled for :func:`plugin_argtypes`).
    ``stop`` (int8, (1,)) is read before every event: once set, the kernel returns STOPPED
    (see :mod:`dronefleet.interrupt`). Returns DONE, ATTEMPTS_FULL (stopped before an event
    that needs a new attempt row: grow ``attempts`` and call again), SUPERVISOR_REFUSED (the
    UAV and event are in ``counters``), INVALID_STATE (the next event time is NaN or fits no
    event, as non-finite inputs make it; nothing was written for it), STOPPED or BAD_SCORE
    (a plugin rule's bidder scored NaN or an infinity: the UAV is in ``counters``, the auction's
    tick is ``counters[NEXT_TICK]``). Every branch tests its own condition, so an index that
    derives from the state is used only where it is valid. Without a GIL: it runs while the
    caller's thread waits for Ctrl-C.
    """
    n_orders = book.arrival_s.shape[0]
    n_samples = series.delivered.shape[0]
    capacity = attempts.uav.shape[0]
    interval = params.advert_interval_s
    while True:
        if stop[0] != 0:
            return STOPPED
        if counters[N_ATTEMPTS] == capacity:
            return ATTEMPTS_FULL
        uav = fleet.event_heap[0]
        t_uav = fleet.next_s[uav]
        t_order = book.arrival_s[counters[NEXT_ORDER]] if counters[NEXT_ORDER] < n_orders else np.inf
        t_sample = counters[NEXT_SAMPLE] * params.record_interval_s if counters[NEXT_SAMPLE] < n_samples else np.inf
        tick = counters[NEXT_TICK]
        advertising = counters[N_IDLE] > 0 and counters[QUEUE_LEN] > 0
        t_tick = tick * interval if advertising else np.inf
        t_other = min(t_uav, t_order, t_sample)
        # A sample changes nothing a bid depends on: ticks are skipped past it (and the one at it).
        t_change = min(t_uav, t_order)
        if (t_tick < t_change and params.bids_on != BIDS_ON_ANY
                and _skip_ticks(book, fleet, counters, params, t_tick, t_change, t_stop)):
            continue
        t = min(t_other, t_tick)
        if t != t or t_uav != t_uav:
            return INVALID_STATE
        if t > t_stop or t == np.inf:
            return DONE
        if t_uav == t:
            if fleet.mode[uav] != RESERVED and fleet.mode[uav] != OUTBOUND and fleet.mode[uav] != RETURNING:
                return INVALID_STATE
            if not _uav_event(book, fleet, attempts, counters, params, table, uav, t):
                return SUPERVISOR_REFUSED
        elif t_order == t and counters[NEXT_ORDER] < n_orders:
            order = counters[NEXT_ORDER]
            counters[NEXT_ORDER] = order + 1
            _enqueue(book, fleet, counters, order)
        elif t_tick == t and advertising:
            status = _auction(book, fleet, attempts, counters, params, table, rng, t, rule_kernel)
            if status != DONE:
                return status
            counters[NEXT_TICK] = tick + 1
        elif t_sample == t and counters[NEXT_SAMPLE] < n_samples:
            k = counters[NEXT_SAMPLE]
            series.delivered[k] = counters[N_DELIVERED]
            series.unallocated[k] = counters[QUEUE_LEN]
            series.idle[k] = counters[N_IDLE]
            series.lost[k] = counters[N_LOST]
            series.reserved[k] = counters[N_RESERVED]
            series.in_flight[k] = fleet.mode.shape[0] - counters[N_IDLE] - counters[N_LOST] - counters[N_RESERVED]
            series.aborted[k] = counters[N_ABORTED]
            counters[NEXT_SAMPLE] = k + 1
        else:
            return INVALID_STATE
        if t_tick != t:
            # The state changed: who may bid must be looked at again (_earliest_bid). Not after a
            # sample, which changes nothing a bid depends on (MAY_BID only picks the way to skip).
            if t_uav == t or t_order == t:
                counters[MAY_BID] = 0
            # While advertising is suspended, ticks are not held: the next one is the first
            # grid instant at or after now.
            counters[NEXT_TICK] = max(counters[NEXT_TICK], first_tick_at_or_after(t, interval))


#: A plugin rule's type in the engine: a function of the rule signature, whichever it is. The
#: engine's specialisation for it does not depend on the plugin, so numba caches it on disk.
RULE_KERNEL = types.FunctionType(RULE_SIGNATURE)


def plugin_argtypes(args: tuple) -> tuple:
    """Types to compile :func:`advance` for with a plugin rule: those of ``args`` (its first
    nine arguments), then RULE_KERNEL for the rule (``stop`` is added by :func:`dronefleet.interrupt.call`).

    Called with the dispatcher itself, numba would compile a specialisation of ``advance`` per
    plugin and per process (its cache key is the dispatcher object, which no other process
    has), and add it to the disk cache each time; the specialisation for RULE_KERNEL is
    compiled once, cached, and takes any plugin.
    """
    return tuple(advance.typeof_pyval(a) for a in args) + (RULE_KERNEL,)
