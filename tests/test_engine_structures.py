"""The engine's event heap and order queue give exactly what the plain arrays they replace gave.

The event heap must pick the UAV ``np.argmin(next_s)`` picks (lowest id among equal
instants, the first NaN if any); the queue must hold the unallocated orders in ascending
id order, whatever the order of insertions and removals, and its packed copy the same orders.
A larger fleet's run is compared with digests of its tables taken with the engine that used
the plain arrays.
"""

import numpy as np
import pytest

from dronefleet.delivery.config import default_config, replace
from dronefleet.delivery import engine, simulation


def _fleet_with_heap(n):
    """A Fleet whose only meaningful fields are the event heap's (the kernels used here read no other)."""
    fields = {name: np.zeros(1) for name in engine.Fleet._fields}
    fields.update(next_s=np.full(n, np.inf), event_heap=np.arange(n, dtype=np.int64),
                  heap_pos=np.arange(n, dtype=np.int64))
    return engine.Fleet(**fields)


@pytest.mark.parametrize("seed", range(6))
def test_event_heap_top_is_argmin_with_ties_and_nan(seed):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 60))
    fleet = _fleet_with_heap(n)
    # Few distinct instants, so that ties are common; inf and now and then NaN too.
    instants = np.concatenate([rng.integers(0, 8, 6).astype(np.float64), [np.inf, np.inf, np.nan]])
    for _ in range(400):
        i = int(rng.integers(n))
        engine.schedule(fleet, i, instants[rng.integers(instants.shape[0] - (seed % 2 == 0))])
        assert fleet.event_heap[0] == np.argmin(fleet.next_s)
        assert np.array_equal(fleet.heap_pos[fleet.event_heap], np.arange(n))


def _book(n):
    fields = {name: np.zeros(n) for name in engine.OrderBook._fields}
    fields.update(x_distance=np.arange(n, dtype=np.float64), x_mass=-np.arange(n, dtype=np.float64),
                  queue_tree=np.zeros(n + 1, np.int64), queue_next=np.full(n, -1, np.int64),
                  queued_x=np.zeros((2, n)), queued_ids=np.zeros(n, np.int64), queued_pos=np.zeros(n, np.int64))
    return engine.OrderBook(**fields)


def _walk(book, counters):
    """The queue as the scan walks it: from the oldest along queue_next."""
    if counters[engine.QUEUE_LEN] == 0:
        return []
    order, out = engine.queued_at(book.queue_tree, 0), []
    while order >= 0:
        out.append(int(order))
        order = book.queue_next[order]
    return out


@pytest.mark.parametrize("seed", range(6))
def test_queue_keeps_ascending_ids_through_insertions_and_removals(seed):
    rng = np.random.default_rng(100 + seed)
    n = int(rng.integers(1, 300))
    book = _book(n)
    fields = {name: np.zeros(1) for name in engine.Fleet._fields}
    fields.update(coef=np.zeros((0, 3)), reach=np.zeros(0), reach_stale=np.zeros(0, np.bool_))  # no UAVs
    fleet = engine.Fleet(**fields)
    counters = np.zeros(engine.N_COUNTERS, np.int64)
    reference = []
    for _ in range(2000):
        if reference and rng.random() < 0.45:
            pos = int(rng.integers(len(reference)))
            engine._dequeue(book, fleet, counters, pos)
            del reference[pos]
        else:
            absent = np.setdiff1d(np.arange(n), reference)
            if absent.shape[0] == 0:
                continue
            order = int(rng.choice(absent))
            engine._enqueue(book, fleet, counters, order)
            reference = sorted(reference + [order])
        assert counters[engine.QUEUE_LEN] == len(reference)
        assert _walk(book, counters) == reference
        # the packed copy holds the same orders, each with its features and position
        packed = book.queued_ids[:len(reference)]
        assert sorted(packed.tolist()) == reference
        assert np.array_equal(book.queued_pos[packed], np.arange(len(reference)))
        assert np.array_equal(book.queued_x[:, :len(reference)], np.stack([book.x_distance[packed], book.x_mass[packed]]))
        for k in rng.integers(0, max(len(reference), 1), 3) if reference else []:
            assert engine.queued_at(book.queue_tree, k) == reference[k]
        for last in (-1, int(rng.integers(n))):
            assert engine._rank(book.queue_tree, last) == np.searchsorted(reference, last, side="right")


#: Digests (dronefleet.fingerprint.table_digest) of a 300-UAV, 2-day run per rule, taken with the engine
#: before the event heap and the linked queue (commit 951c56e: np.argmin over next_s, a sorted array
#: shifted on every insertion and removal). A large fleet exercises ties, long backlogs and
#: removals deep in the queue far more than the 25-UAV golden runs.
LARGE_FLEET = {
    "least_confident": {
        "attempts": "82d6dd6f98c8ee91273cacce6e71f6249de41cadf98ffa5c6e029b3327c8a673",
        "fleet": "0c21fc5e39cacb7f1eadeb13416d84994c12ebd14c77c96e3951720dffb0027c",
        "orders": "07f4dc02beef7bd13135f983984b845a72bcbfae088b6243d4378d060dcdbb2e",
        "summary": "16a2f7907e6b64f6212fa170a64bad32b31c27ff3ab690c5f2b3dff2dc2f4b8a",
        "timeseries": "26671d3e2f11afff93b61c4321f15b54cda2a0c44869f5c36eeab55352d6c9de",
    },
    "reservation": {
        "attempts": "c1f5d63034976c112bcb0d05f7ea690bc3ae86052f71ec258329a7d873333d5d",
        "fleet": "6a4f95aa0744ad20c0a3df7dc32eb65187f8dd1c751ba9dae30d824bd475ae98",
        "orders": "a2951a65dfb13a90684ade2bb64d46d99e6d40585b79a78bc18a3c40fd626669",
        "summary": "80ee12e8858736e3b5470bf5dac931797f82139d3bbb62995715bfb175a0d854",
        "timeseries": "9b0dc239d03d52ab3feef29047a98395ac28edb271b83f14f7474ff6b9da8714",
    },
    "threshold": {
        "attempts": "a5b19897426167313a1ced2b98b0a24b4297e78fd26fcf1ae474d381d3b7de86",
        "fleet": "0a5bb7e8ea30a8d9425a4caaa8ea2061d857da83bf40f9ecc8714887747e60db",
        "orders": "29698e7c2cc021caa04d6b5a83a3391b3e7bcc7bc2d3570e35ed84a2ea4c316a",
        "summary": "bad717d2c213b63c2009a41e36c10d7b330c126403a05e479e398d97dcd6bc8b",
        "timeseries": "ee926cbd04df0dcc0e66833ede69c1bc86dcea5a4d1d407ea52e61d24d257d3f",
    },
}


@pytest.mark.parametrize("rule", sorted(LARGE_FLEET))
def test_a_large_fleet_run_is_bit_identical_to_the_array_engine(rule):
    from dronefleet.delivery.records import tables
    from dronefleet.fingerprint import table_digest

    config = replace(default_config(), n_uavs=300, horizon_weeks=2 / 7, tau_minutes=15.0 * 25 / 300, rule=rule, seed=3)
    digests = {name: table_digest(table) for name, table in tables(simulation.simulate(config)).items()}
    assert digests == LARGE_FLEET[rule]


def _paused_states(rule, n_uavs=60, hours=36, every_s=1800.0):
    """A run of a mid-size fleet under ``rule``, yielded at every pause (every ``every_s`` seconds)."""
    config = replace(default_config(), n_uavs=n_uavs, horizon_weeks=hours / 168, tau_minutes=15.0 * 25 / n_uavs,
                     rule=rule, seed=5)
    state = simulation.initial_state(config)
    for t in np.arange(every_s, config.horizon_s + every_s / 2, every_s):
        simulation.advance(state, float(t))
        yield state, float(t)


@pytest.mark.parametrize("rule", ["least_confident", "reservation"])
def test_packed_idle_set_and_supervisor_flags_follow_the_fleet(rule):
    for state, _ in _paused_states(rule):
        fleet, n_idle = state.fleet, int(state.counters[engine.N_IDLE])
        packed = fleet.idle_ids[:n_idle]
        assert sorted(packed.tolist()) == np.flatnonzero(fleet.mode == engine.IDLE).tolist()
        assert np.array_equal(fleet.idle_pos[packed], np.arange(n_idle))
        # quiet: notCapableTask is allowed and loops on every local supervisor's state; bid_silent:
        # capableTask, bid and lostBid are allowed in turn and come back to it.
        table, supervisors = state.table, np.arange(fleet.sup.shape[1])
        loops = table[supervisors, fleet.sup, engine.EV_NOT_CAPABLE] == fleet.sup
        assert np.array_equal(fleet.quiet, loops.all(axis=1))
        silent = []
        for states in fleet.sup:
            capable = table[supervisors, states, engine.EV_CAPABLE]
            bidding = table[supervisors, capable, engine.EV_BID]
            silent.append(bool(np.all((capable >= 0) & (bidding >= 0)
                                      & (table[supervisors, bidding, engine.EV_LOST_BID] == states))))
        assert fleet.bid_silent.tolist() == silent


@pytest.mark.parametrize("rule", ["least_confident", "reservation"])
def test_scan_bounds_hold_at_every_tick_of_their_epoch(rule):
    """An idle UAV's exact decision value at a tick of the scan epoch lies within its bounds; if >= 0, it may bid."""
    from dronefleet.delivery.energy import soc_after_charging
    from dronefleet.delivery.policy import decision

    checked = 0
    for state, t in _paused_states(rule, hours=24, every_s=3600.0):
        fleet, params, book = state.fleet, state.params, state.book
        start, end = fleet.scan_epoch
        if not start <= t <= end:
            continue
        ticks = np.arange(engine.first_tick_at_or_after(t, params.advert_interval_s),
                          np.floor(end / params.advert_interval_s) + 1) * params.advert_interval_s
        orders = np.arange(book.arrival_s.shape[0])[:100]
        for k in range(int(state.counters[engine.N_IDLE])):
            i = fleet.idle_ids[k]
            for tick in ticks[::7]:
                soc = soc_after_charging(fleet.soc_ref[i], tick - fleet.t_ref[i], params.charge_rate)
                x_soc = (soc - params.soc_mean) / params.soc_std
                for order in orders:
                    x0, x1 = book.x_distance[order], book.x_mass[order]
                    f = decision(fleet.coef, fleet.intercept, i, x0, x1, x_soc)
                    low, high = engine._decision_bounds(fleet.scan_terms, k, x0, x1)
                    assert low <= f <= high, (i, tick, order)
                    if f >= 0.0:
                        checked += 1
                        assert engine._may_bid(fleet.scan_terms, k, x0, x1), (i, tick, order)
    assert checked > 500
