"""The replenishment simulator against docs/replenishment-model.md, rule by rule.

Runs are short (few ticks and trials) and reuse module-scoped results; the
expected values are computed here by hand from the spec's rates and speeds.
"""

import dataclasses
import math

import numpy as np
import pytest

from dronefleet.replenishment import Params, simulate
from dronefleet.replenishment import kernel as K
from dronefleet.replenishment.simulate import SUPERVISOR_FILES, _mc_rank
from dronefleet.supervisor import load_supervisor

V_MIN, V_MOVE = 0.005, 0.1


@pytest.fixture(scope="module")
def mobile_run():
    """Mobile chargers, traced: 4 workers, 3 chargers, 2 trials x 2500 ticks."""
    params = Params(strategy="mobile", n_workers=4, n_chargers=3, ticks=2500, trials=2)
    result = simulate(params, trace=True)
    transfers = (result["trace"]["source"] >= 0).sum()
    assert transfers > 100, "precondition: the protocol must pair workers and chargers"
    return params, result


@pytest.fixture(scope="module")
def fixed_run():
    params = Params(strategy="fixed", n_workers=6, ticks=2000, trials=2)
    return params, simulate(params, trace=True)


@pytest.fixture(scope="module")
def depletion_run():
    """Depletion certain without noise: the charger holds 0.08 units (it dies by tick 17),
    and the worker, which always heads for x = 0.55 (>= 1.045 m away at <= 0.012 m per
    tick, 0.105 units per tick), holds 8 units: it is empty after at most 77 ticks."""
    params = Params(strategy="mobile", n_workers=1, n_chargers=1, worker_capacity=8.0,
                    charger_capacity_factor=0.01, ticks=300, trials=1)
    return params, simulate(params, wheel_noise=False, trace=True)


# ------------------------------------------------------------------ hand-calculable case


def test_one_worker_cycle_matches_a_hand_calculation():
    """One worker, fixed charger, no neighbours, no wheel noise (sections 2, 4, 5, 7)."""
    params = Params(n_workers=1, ticks=4000, trials=1, sample_every=1)
    result = simulate(params, wheel_noise=False, trace=True)
    events = result["trace"]["event"][0, :, 0]
    starts = np.flatnonzero(events == K.EV_MOVE_TO_WORK) + 1        # ticks of moveToWork
    assert len(starts) >= 4
    work = result["series"][0, :, K.TS_WORK]                          # cumulative, per tick
    cycles = np.diff(starts)[1:]                                      # steady state
    points = (work[starts[2:]] - work[starts[1:-1]])

    # by hand: speed 12 cm/s = 0.012 m/tick; within 0.12 m of the target (+-0.55) the
    # attraction 100 d cm/s covers 10 % of the rest per tick and stops at d <= 0.005
    # (|F| <= 0.5), so lanes sit at +-0.545
    def tail(d0, d1=0.005):
        return math.log(d1 / d0) / math.log(0.9)

    turn = math.pi / (2 * 0.012 / 0.053)          # hard turn at +-12 cm/s wheels
    # work (and charge) starts when the ground sensor, 3 cm ahead, crosses x = +-0.5
    leg = turn + (1.015 - 0.04) / 0.012 + tail(0.12, 0.08)          # lane -> centre 0.47
    e_leave = 99.0 + 0.995 / 2                                       # first E >= 0.99 c_w
    e_low_work = (0.545 + 0.5) / 0.12 + 10.0                         # E_low at the lane
    decel = tail(0.08)                                               # still moving, working
    e_work = e_leave - leg * (V_MIN + V_MOVE)
    n_work = decel + (e_work - decel * (V_MIN + 0.1 + V_MOVE) - e_low_work) / (V_MIN + 0.1)
    hand_points = n_work - tail(0.08, 0.05)                          # centre reaches 0.5
    e_home = e_low_work - leg * (V_MIN + V_MOVE)
    outside = tail(0.08, 0.05)                                       # centre reaches -0.5
    inside = decel - outside
    e_moving = e_home - outside * (V_MIN + V_MOVE) + inside * (1.0 - V_MIN - V_MOVE)
    n_charge = decel + (99.0 + 0.995 / 2 - e_moving) / (1.0 - V_MIN)
    hand_cycle = 2 * leg + n_work + n_charge

    # tolerance: the leaving energy is anywhere in [99, 99.995) (+-5 work ticks) and
    # the turn and deceleration come in whole ticks
    assert np.all(np.abs(cycles - hand_cycle) <= 0.01 * hand_cycle), (cycles, hand_cycle)
    assert np.all(np.abs(points - hand_points) <= 0.01 * hand_points), (points, hand_points)


# ------------------------------------------------------------------ energy


@pytest.mark.parametrize("run", ["mobile_run", "fixed_run", "depletion_run"])
def test_energy_is_conserved_per_robot_and_in_total(run, request):
    params, result = request.getfixturevalue(run)
    n = params.n_workers + params.n_chargers
    capacity = np.array([params.worker_capacity] * params.n_workers
                        + [params.charger_capacity] * params.n_chargers)
    # per robot: battery change = drawn from the base + received - paid for activities - given
    change = result["battery"] - capacity
    balance = result["drawn"] + result["received"] - result["paid"] - result["given"]
    np.testing.assert_allclose(change, balance, rtol=0, atol=1e-9 * params.ticks)
    # in total: what chargers give is what workers receive plus the loss
    np.testing.assert_allclose(result["given"].sum(axis=1),
                               result["received"].sum(axis=1) + result["lost"],
                               rtol=0, atol=1e-9 * params.ticks)
    # the consumed counter is what was paid while a battery never ran dry
    alive = ~result["depleted"]
    np.testing.assert_allclose(result["consumed"][alive], result["paid"][alive],
                               rtol=0, atol=1e-9 * params.ticks)
    assert result["paid"].shape == (params.trials, n)


def test_transfer_loss_is_counted_and_never_received():
    params = Params(strategy="mobile", n_workers=4, n_chargers=3, ticks=2500, trials=1,
                    transfer_loss=0.25)
    result = simulate(params, trace=True)
    transfers = (result["trace"]["source"] >= 0).sum()
    assert transfers > 0
    # every transfer tick loses lambda v_charge; the worker gets at most (1 - lambda) v_charge
    np.testing.assert_allclose(result["lost"][0], 0.25 * 1.0 * transfers, rtol=1e-12)
    assert result["shared"][0] <= 0.75 * transfers + 1e-9
    assert result["trace"]["received"].max() <= 0.75 + 1e-12     # a difference of batteries
    assert result["efficiency_with_loss"][0] < result["efficiency"][0]


def test_batteries_stay_within_capacity(mobile_run, fixed_run):
    for params, result in (mobile_run, fixed_run):
        energy = result["trace"]["energy"]
        assert energy.min() >= 0.0
        assert energy[:, :, :params.n_workers].max() <= params.worker_capacity
        assert energy[:, :, params.n_workers:].max(initial=0) <= params.charger_capacity


def test_depleted_robots_stop_and_keep_paying_idle_energy(depletion_run):
    params, result = depletion_run
    assert result["depleted_workers"][0] == 1 and result["depleted_chargers"][0] == 1
    trace = result["trace"]
    for robot in range(2):
        dead = np.flatnonzero(trace["flags"][0, :, robot] & K.FLAG_DEPLETED)
        assert dead[0] < 100 and np.all(np.diff(dead) == 1) and dead[-1] == params.ticks - 1
        steps = np.diff(trace["consumed"][0, dead, robot])
        np.testing.assert_allclose(steps, V_MIN, rtol=1e-9)
        assert np.all(trace["energy"][0, dead, robot] == 0.0)
        assert not np.any(trace["flags"][0, dead, robot] & K.FLAG_MOVING)
        x = trace["x"][0, dead, robot]
        assert np.all(x[1:] == x[:-1])          # wheels are off: it does not move
    # a depleted worker sends a plain, non-requesting WORKER message
    dead_worker = np.flatnonzero(trace["flags"][0, :, 0] & K.FLAG_DEPLETED)
    assert not trace["msg_requesting"][0, dead_worker, 0].any()


# ------------------------------------------------------------------ protocol


def test_a_charger_serves_one_worker_at_a_time_within_the_share_distance(mobile_run):
    params, result = mobile_run
    trace = result["trace"]
    nw = params.n_workers
    source = trace["source"][:, :, :nw]
    trials, ticks, workers = np.nonzero(source >= 0)
    chargers = source[trials, ticks, workers]
    # one worker per charger per tick
    pairs = np.stack([trials, ticks, chargers], axis=1)
    assert len(np.unique(pairs, axis=0)) == len(pairs)
    # the charger names that worker and shares; the worker is charging
    assert np.all(trace["served"][trials, ticks, chargers] == workers)
    assert np.all(trace["flags"][trials, ticks, chargers] & K.FLAG_SHARING)
    assert np.all(trace["flags"][trials, ticks, workers] & K.FLAG_CHARGING)
    # centres closer than 14 cm
    dx = trace["x"][trials, ticks, workers] - trace["x"][trials, ticks, chargers]
    dy = trace["y"][trials, ticks, workers] - trace["y"][trials, ticks, chargers]
    assert np.all(100.0 * np.sqrt(dx * dx + dy * dy) < 14.0)
    # and a charger sharing with its worker farther away transfers nothing
    served = trace["served"][:, :, nw:]
    t_, k_, c_ = np.nonzero((served >= 0) & ((trace["flags"][:, :, nw:] & K.FLAG_SHARING) > 0))
    w_ = served[t_, k_, c_]
    far = 100.0 * np.hypot(trace["x"][t_, k_, w_] - trace["x"][t_, k_, nw + c_],
                           trace["y"][t_, k_, w_] - trace["y"][t_, k_, nw + c_]) >= 14.0
    assert far.any(), "precondition: chargers name workers before they arrive"
    assert np.all(trace["source"][t_[far], k_[far], w_[far]] != nw + c_[far])


def test_messages_are_one_tick_old(mobile_run):
    """A pairing uses the partner's message of the previous tick (sections 5.4, 6)."""
    params, result = mobile_run
    trace = result["trace"]
    nw = params.n_workers
    # a charger newly naming worker w at tick t read w's message of tick t - 1:
    # requesting and without a provider
    served = trace["served"][:, :, nw:]
    new = (served[:, 1:] >= 0) & (served[:, 1:] != served[:, :-1])
    trials, ticks, chargers = np.nonzero(new)
    ticks = ticks + 1
    workers = served[trials, ticks, chargers]
    assert len(workers) > 0
    assert np.all(trace["msg_requesting"][trials, ticks - 1, workers])
    assert np.all(trace["msg_from"][trials, ticks - 1, workers] == -1)
    # a worker newly taking provider c at tick t read c's message of tick t - 1, naming it;
    # at tick t - 1 it could not yet have read it, so it had no provider
    provider = trace["provider"][:, :, :nw]
    new = (provider[:, 1:] >= 0) & (provider[:, 1:] != provider[:, :-1])
    trials, ticks, workers = np.nonzero(new)
    ticks = ticks + 1
    chargers = provider[trials, ticks, workers]
    assert len(chargers) > 0
    assert np.all(trace["msg_to"][trials, ticks - 1, chargers] == workers)
    # and it answers exactly one tick after the charger first named it
    first = trace["served"][trials, ticks - 1, chargers] == workers
    before = trace["served"][trials, ticks - 2, chargers] != workers
    assert np.any(first & before)


def test_every_controllable_event_taken_was_enabled(mobile_run, fixed_run):
    for params, result in (mobile_run, fixed_run):
        trace = result["trace"]
        worker_file = "worker-with-mobile-charger" if params.mobile else "worker"
        roles = [(load_supervisor(SUPERVISOR_FILES[worker_file]), range(params.n_workers))]
        if params.mobile:
            roles.append((load_supervisor(SUPERVISOR_FILES["charger"]),
                          range(params.n_workers, params.n_workers + params.n_chargers)))
        taken = 0
        for automaton, robots in roles:
            for robot in robots:
                trials, ticks = np.nonzero(trace["event"][:, :, robot] >= 0)
                for tr, t in zip(trials, ticks):
                    name = K.EVENT_NAMES[trace["event"][tr, t, robot]]
                    e = automaton.events.index(name)
                    assert automaton.controllable[e]
                    states = trace["sup_states"][tr, t, robot]
                    for k in range(automaton.n_supervisors):
                        if automaton.alphabet[k, e]:
                            assert (states[k], e) in automaton.transitions[k], (name, k, states)
                    taken += 1
        assert taken > 10 * (params.n_workers + params.n_chargers)


def test_phases_follow_the_spec_oracle(mobile_run, fixed_run):
    """P0 -> P1 -> P2 -> P3 -> P0 (section 5.1 table): events come in cycle order."""
    cycle = {"worker": ["moveToWork", "work", "moveToCharge", "charge"],
             "charger": ["moveToWork", "shareEnergy", "moveToCharge", "charge"]}
    for params, result in (mobile_run, fixed_run):
        events = result["trace"]["event"]
        for robot in range(params.n_workers + params.n_chargers):
            order = cycle["worker" if robot < params.n_workers else "charger"]
            for tr in range(params.trials):
                taken = [K.EVENT_NAMES[e] for e in events[tr, :, robot] if e >= 0]
                assert taken == [order[i % 4] for i in range(len(taken))]


def test_worker_with_mobile_charger_moves_to_work_only_when_neither_low_nor_at_charger(
        mobile_run):
    params, result = mobile_run
    trace = result["trace"]
    nw = params.n_workers
    trials, ticks, workers = np.nonzero(trace["event"][:, :, :nw] == K.EV_MOVE_TO_WORK)
    for tr, t, w in zip(trials, ticks, workers):
        if t == 0:
            continue
        energy = trace["energy"][tr, t - 1, w]          # battery at the start of tick t + 1
        x = trace["x"][tr, t, w]
        assert energy >= (x + 0.5) / 0.12 + 10.0


# ------------------------------------------------------------------ motion


def _wheels_by_the_spec(fx, fy, mode):
    """Section 4's turning rules, every angle from fpmath's atan2 (no shortcut)."""
    angle = K.atan2(fy, fx)
    s = min(math.sqrt(fx * fx + fy * fy), K.V_MAX)
    a = abs(angle)
    if mode == K.TURN_HARD and a <= K.HARD_TO_SOFT:
        mode = K.TURN_SOFT
    if mode == K.TURN_SOFT:
        mode = K.TURN_HARD if a > K.TO_HARD else K.TURN_NO if a <= K.NO_TURN else mode
    elif mode == K.TURN_NO:
        mode = K.TURN_HARD if a > K.TO_HARD else K.TURN_SOFT if a > K.NO_TURN else mode
    if mode == K.TURN_NO:
        s1, s2 = s, s
    elif mode == K.TURN_SOFT:
        f = (K.TO_HARD - a) / K.TO_HARD
        s1, s2 = s * f, s * (2.0 - f)
    else:
        s1, s2 = -K.V_MAX, K.V_MAX
    return (s1, s2, mode) if angle > 0.0 else (s2, s1, mode)


def test_wheels_skip_atan2_only_where_the_result_cannot_change():
    """The no-turn shortcut (no atan2 well inside 10 degrees) gives the spec's bits,
    also for forces right at the shortcut's edge and at the 10-degree boundary."""
    rng = np.random.default_rng(11)
    angles = np.concatenate([rng.uniform(-math.pi, math.pi, 3000),
                             math.atan(K.NO_TURN_SLOPE) * (1.0 + rng.uniform(-1e-6, 1e-6, 500)),
                             K.NO_TURN * (1.0 + rng.uniform(-1e-9, 1e-9, 500))])
    angles *= rng.choice([-1.0, 1.0], angles.size)
    lengths = rng.uniform(0.5, 30.0, angles.size)
    forces = [(r * math.cos(t), r * math.sin(t)) for r, t in zip(lengths, angles)]
    forces += [(1.0, 0.0), (1.0, -0.0), (3.0, K.NO_TURN_SLOPE * 3.0), (-1.0, 0.0)]
    for fx, fy in forces:
        for mode in (K.TURN_NO, K.TURN_SOFT, K.TURN_HARD):
            assert K.wheels_from_force(fx, fy, mode) == _wheels_by_the_spec(fx, fy, mode)


# ------------------------------------------------------------------ supervisor VM


def test_uncontrollable_events_move_each_supervisor_that_can_and_keep_the_others():
    # two supervisors over event atWork (code 5): sup 0 has 0 -> 1, sup 1 has no transition
    tables = np.full((2, 2, 2, K.N_EVENTS), -1, dtype=np.int64)
    tables[0, 0, 0, K.EV_AT_WORK] = 1
    tables[0, 0, 1, K.EV_LOW] = 0
    tables[0, 1, 0, K.EV_LOW] = 1
    n_sup = np.array([2, 0])
    order = np.full((2, K.N_EVENTS), -1, dtype=np.int64)
    order[0, :2] = [K.EV_AT_WORK, K.EV_LOW]
    n_unc = np.array([2, 0])
    conditions = np.zeros(K.N_EVENTS, dtype=np.bool_)
    conditions[K.EV_AT_WORK] = conditions[K.EV_LOW] = True
    states = np.array([0, 0])
    K.apply_uncontrollable(tables, n_sup, 0, states, order, n_unc, conditions)
    # atWork first: sup 0 -> 1, sup 1 stays; then lowEnergy: sup 0 1 -> 0, sup 1 0 -> 1
    assert states.tolist() == [0, 1]
    order[0, :2] = [K.EV_LOW, K.EV_AT_WORK]              # the file's order decides
    states = np.array([0, 0])
    K.apply_uncontrollable(tables, n_sup, 0, states, order, n_unc, conditions)
    assert states.tolist() == [1, 1]


def test_a_different_supervisor_file_changes_the_behaviour():
    params = Params(n_workers=2, ticks=800, trials=1)
    original = load_supervisor(SUPERVISOR_FILES["worker"])
    e = original.events.index("work")
    # the same file without any `work` transition: work is never enabled
    no_work = dataclasses.replace(original, transitions=tuple(
        {key: target for key, target in t.items() if key[1] != e}
        for t in original.transitions))
    base = simulate(params, trace=True)
    changed = simulate(params, supervisors={"worker": no_work}, trace=True)
    assert base["work"][0] > 0 and K.EV_WORK in base["trace"]["event"]
    assert changed["work"][0] == 0 and K.EV_WORK not in changed["trace"]["event"]


def test_charger_id_string_order():
    # "C1" < "C10" < "C11" < "C12" < "C2" < ... < "C9"
    rank = _mc_rank(12)
    by_rank = sorted(range(12), key=lambda j: rank[j])
    assert [f"C{j + 1}" for j in by_rank] == ["C1", "C10", "C11", "C12", "C2", "C3", "C4",
                                               "C5", "C6", "C7", "C8", "C9"]


# ------------------------------------------------------------------ determinism


def test_trials_run_together_equal_each_run_alone():
    params = Params(strategy="mobile", n_workers=3, n_chargers=2, ticks=600, trials=3)
    together = simulate(params)
    for k in (1, 2, 3):
        alone = simulate(params, trials=1, first_trial=k)
        for name in ("work", "energy", "work_energy", "shared", "lost", "battery", "consumed",
                     "series", "seed"):
            assert np.array_equal(together[name][k - 1], alone[name][0]), (name, k)
    assert together["seed"].tolist() == [876, 1752, 2628]
    assert not np.array_equal(together["battery"][0], together["battery"][1])


def test_same_seed_same_bytes():
    params = Params(strategy="mobile", n_workers=2, n_chargers=1, ticks=300, trials=2)
    a, b = simulate(params), simulate(params)
    for name in ("battery", "consumed", "series"):
        assert a[name].tobytes() == b[name].tobytes()


def test_summary_metrics_are_the_spec_ratios(mobile_run):
    params, result = mobile_run
    assert np.array_equal(result["energy"], result["consumed"].sum(axis=1))
    np.testing.assert_allclose(result["efficiency"],
                               result["work_energy"] / result["energy"], rtol=1e-15)
    # the time series ends at the final work count and stored energy
    assert np.array_equal(result["series"][:, -1, K.TS_WORK], result["work"])
    np.testing.assert_allclose(result["series"][:, -1, K.TS_STORED],
                               result["battery"].sum(axis=1), rtol=1e-12)
    phases = result["series"][:, :, :8].sum(axis=2)
    assert np.all(phases == params.n_workers + params.n_chargers)


def test_only_the_last_charger_in_id_string_order_transfers_and_only_within_14_cm():
    # worker 0, chargers 1..11 (C1..C11); C2 (index 2) and C10 (index 10) both name it
    n_chargers = 11
    n = 1 + n_chargers
    sharing = np.zeros((1, n), dtype=np.bool_)
    served = np.full((1, n), -1, dtype=np.int64)
    dist = np.full((n, n), 0.10)
    sharing[0, [2, 10]] = True
    served[0, [2, 10]] = 0
    rank = _mc_rank(n_chargers)
    # "C10" < "C2": C2 is the last, and it transfers
    assert K.transfer_source(0, 0, 1, sharing, served, rank, dist) == 2
    dist[0, 2] = dist[2, 0] = 0.1399
    assert K.transfer_source(0, 0, 1, sharing, served, rank, dist) == 2
    # C2 too far: nobody transfers (C10 is not the last, so it does not step in)
    dist[0, 2] = dist[2, 0] = 0.1401
    assert K.transfer_source(0, 0, 1, sharing, served, rank, dist) == -1
    # C2 not sharing: C10 is the only one
    sharing[0, 2] = False
    assert K.transfer_source(0, 0, 1, sharing, served, rank, dist) == 10
