"""Rules of the item-delivery / foraging model (the spec ITEM-DELIVERY.md, docs/items-model.md),
each checked on a world built by hand: travel times, a whole trip, serving and unloading, the
t = T rule, ear-marking, each algorithm's choice, the tie rules, the truths, ASTC's k, SF's sleep,
the metrics and the common random numbers. Expected values are computed here by hand or with
Python's math, never with the kernel's own helpers."""

import math

import numpy as np
import pytest

from dronefleet.items import Params, run_cell, simulate
from dronefleet.items import kernel as k
from dronefleet.items.simulate import grid_positions, kernel_inputs, measures
from dronefleet.rng import seed_stream

HOME = (0.5, 0.5)


def world(*locations, truth=()):
    """(positions, true parameters) of home and ``locations`` (x, y), indexed by node."""
    positions = np.array([HOME, *locations], dtype=np.float64)
    return positions, np.array([0.0, *truth], dtype=np.float64)


def trace_of(params, the_world):
    r = run_cell(params.replace(trials=1), world=the_world, trace=True)
    return r, r["trace"], r["trace_counts"]


# ---------------------------------------------------------------- travel times (A6)


def test_travel_time_is_the_ceiling_with_a_floor_of_one_and_a_guard_against_float_noise():
    assert k.travel_time(0.5, 0.5, 0.5, 0.9, 0.15) == 3            # 0.4 / 0.15 = 2.67
    assert 0.8 - 0.5 == 0.30000000000000004                        # float noise ...
    assert k.travel_time(0.5, 0.5, 0.5, 0.8, 0.1) == 3             # ... does not add a step
    assert k.travel_time(0.5, 0.5, 0.5, 0.5, 0.2) == 1             # distinct nodes at one point (IDP centre)
    table = np.zeros((3, 3), dtype=np.int32)
    k.travel_table(np.array([HOME, (0.5, 0.5), (0.9, 0.5)]), 0.2, table)
    assert table.tolist() == [[0, 1, 2], [1, 0, 2], [2, 2, 0]]


def test_the_idp_grid_is_inclusive_row_major_and_holds_a_point_at_home():
    p = Params(mode="delivery", grid_spacing=0.1)
    pos = grid_positions(p)
    assert p.n_locations == 121 and pos.shape == (122, 2)
    assert tuple(pos[0]) == HOME and tuple(pos[1]) == (0.0, 0.0) and tuple(pos[2]) == (0.1, 0.0)
    assert tuple(pos[12]) == (0.0, 0.1) and tuple(pos[121]) == (1.0, 1.0)   # x fastest
    assert (0.5, 0.5) in {tuple(row) for row in pos[1:]}
    assert Params(mode="delivery", grid_spacing=0.1, grid_edge="exclusive").n_locations == 100
    assert Params(mode="delivery", grid_spacing=0.05).n_locations == 441


# ---------------------------------------------------------------- a trip by hand (sections 3, 6, 8)

# One location at (0.5, 0.9), 3 steps from home at s = 0.15; Bernoulli p = 1: one item per step.
TRIP = world((0.5, 0.9), truth=(1.0,))
FP_TRIP = Params(truth="bernoulli", algorithm="GR", n_robots=1, capacity=2, speed=0.15, steps=6, trials=1)


def test_a_foraging_trip_by_hand():
    # t = 0: GR at home sees D_hat(0 + 3) = 0.3 * 3, v' = 0.9 / 6 > 0: leaves for location 1 (3 steps).
    # t = 3: arrives, 3 items there, takes c = 2, observes 1, full: home (3 steps). t = 6: unloads 2.
    r, trace, counts = trace_of(FP_TRIP, TRIP)
    node, dest, left, y = (trace[:, 0, col].tolist() for col in range(4))
    assert node == [-1, -1, -1, -1, -1, -1, -1]
    assert dest == [1, 1, 1, 0, 0, 0, 1]
    assert left == [3, 2, 1, 3, 2, 1, 3]
    assert y == [0, 0, 0, 2, 2, 2, 0]
    assert counts[:, 1].tolist() == [0, 1, 2, 1, 2, 3, 4]
    generated, served, visits, trips, picked = r["totals"][0, :k.T_PICKED + 1]   # the summary's totals
    assert (generated, served, visits, trips, picked) == (6, 2, 1, 1, 2)
    summary = simulate(FP_TRIP)["summary"]        # the drawn world differs; only the columns' arithmetic
    assert summary["rate"][0] == pytest.approx(100.0 * summary["served"][0] / summary["generated"][0])


def test_at_t_equals_T_unloading_counts_and_payloads_on_board_are_lost():
    assert run_cell(FP_TRIP.replace(steps=6), world=TRIP)["totals"][0, k.T_SERVED] == 2   # unloaded at T
    assert run_cell(FP_TRIP.replace(steps=5), world=TRIP)["totals"][0, k.T_SERVED] == 0   # on board at T
    # A15's option counts them at pickup
    assert run_cell(FP_TRIP.replace(steps=5, count_at="pickup"), world=TRIP)["totals"][0, k.T_SERVED] == 2


def test_a_delivery_trip_counts_demands_at_delivery_and_reloads_at_home():
    p = FP_TRIP.replace(mode="delivery", steps=3)
    r, trace, counts = trace_of(p, TRIP)
    assert r["totals"][0, k.T_SERVED] == 2 and r["totals"][0, k.T_GENERATED] == 3   # delivered at T = 3
    assert trace[3, 0, k.TR_Y] == 2 and counts[3, 1] == 1        # 2 handed out: empty, 1 demand left
    r, trace, _ = trace_of(p.replace(steps=6), TRIP)
    assert trace[6, 0, k.TR_Y] == 0 and trace[6, 0, k.TR_DEST] == 1   # reloaded, out again


# ---------------------------------------------------------------- decisions on a hand-built world


def decide(params, i, t, a, positions, observed, *, y=None, earmark=None, observed_at=None, assigned=None,
           owner=None, leave_at=None, seed=1):
    """``kernel.decide`` for robot ``i`` at node ``a``, step ``t``, on the given world and model."""
    opts, pars, _, _ = kernel_inputs(params)
    m1 = len(positions)
    travel = np.zeros((m1, m1))
    k.travel_table(np.asarray(positions, dtype=np.float64), params.speed, travel)
    n = params.n_robots
    rng = np.zeros((1, k.STREAM_ROBOT + n, 4), dtype=np.uint64)
    for s in range(k.STREAM_ROBOT + n):
        seed_stream(rng, 0, s, seed, s)
    as_array = lambda v, size, dtype: np.zeros(size, dtype) if v is None else np.asarray(v, dtype)  # noqa: E731
    return k.decide(i, t, a, opts, pars, travel, np.asarray([observed], dtype=np.float64),
                    as_array(observed_at, (1, m1), np.float64).reshape(1, m1), 0,
                    as_array(earmark, m1, np.float64), as_array(y, n, np.int64), as_array(assigned, n, np.int64),
                    as_array(owner, m1, np.int64), as_array(leave_at, n, np.int64), rng, np.zeros(m1),
                    np.zeros(m1, dtype=np.int64))


# home, then two locations 2 steps from home (s = 0.1) on opposite sides, and a far one (4 steps)
SYMMETRIC = [HOME, (0.5, 0.7), (0.5, 0.3), (0.9, 0.5)]


def test_earmarks_count_robots_heading_to_a_location_and_at_it_never_at_home():
    out = np.zeros(4)
    k.earmark_move(out, 10, 3, 0, 1)        # robot 0 heads from home to 1 with y = 3
    k.earmark_move(out, 10, 4, 0, 2)        # robot 1 heads to 2 with y = 4 (and stands there)
    k.earmark_move(out, 10, 1, 0, 1)        # robot 3 went to 1 with y = 1 ...
    k.earmark_move(out, 10, 1, 1, 0)        # ... and heads home: it no longer counts at 1
    k.earmark_move(out, 10, 10, 0, 2)       # robot 4, full, at 2: adds 0
    assert out.tolist() == [0.0, 7.0, 6.0, 0.0]     # home never counted
    k.earmark_move(out, 10, 3, 1, 0)
    k.earmark_move(out, 10, 4, 2, 0)
    k.earmark_move(out, 10, 10, 2, 0)
    assert not out.any()                    # everyone home again: nothing ear-marked


def test_gr_subtracts_earmarks_and_a_second_robot_goes_elsewhere():
    p = Params(truth="bernoulli", algorithm="GR", n_robots=2, capacity=10, speed=0.1, ties="lowest_index")
    # both locations predict 0.3 * 2 = 0.6 on arrival; location 1 is ear-marked by 10 items of room
    assert decide(p, 0, 0, 0, SYMMETRIC, [0, 0, 0, 0]) == 1
    assert decide(p, 0, 0, 0, SYMMETRIC, [0, 0, 0, 0], earmark=[0, 10, 0, 0]) == 2
    # the whole kernel at t = 0: robot 0 heads to 1, robot 1 sees it and takes 2 (A8, A27) ...
    positions, par = np.array(SYMMETRIC[:3]), np.array([0.0, 0.3, 0.3])
    _, trace, _ = trace_of(p.replace(steps=1), (positions, par))
    assert trace[0, :, k.TR_DEST].tolist() == [1, 2]
    # ... while GRIC's rule without ear-marking (CAS gr_no_earmark) sends both to 1
    cas = p.replace(algorithm="CAS", cas_variant="gr_no_earmark")
    _, trace, _ = trace_of(cas.replace(steps=1), (positions, par))
    assert trace[0, :, k.TR_DEST].tolist() == [1, 1]


def test_gr_compares_with_going_home_and_caps_the_load_gric_and_the_literal_max_do_not():
    base = dict(truth="poisson", n_robots=1, capacity=10, speed=0.1, lam_hat=0.0)
    # robot at location 1 (2 steps from home) with y = 9: going home is worth 9 / 2 = 4.5;
    # location 3 (4 steps from 1, 4 from home) holds 50: capped 10 / 8 = 1.25, uncapped 59 / 8 = 7.4
    observed = [0, 0, 0, 50]
    gr = Params(algorithm="GR", **base)
    assert decide(gr, 0, 5, 1, SYMMETRIC, observed, y=[9]) == 0
    assert decide(gr.replace(gr_cap="max"), 0, 5, 1, SYMMETRIC, observed, y=[9]) == 3
    gric = Params(mode="delivery", algorithm="GRIC", **base)
    assert decide(gric, 0, 5, 1, SYMMETRIC, observed, y=[9]) == 3
    assert decide(gr, 0, 5, 1, SYMMETRIC, observed, y=[10]) == 0            # full: home
    assert decide(gr, 0, 5, 0, SYMMETRIC, [0, 0, 0, 0]) == k.STAY           # A16: at home, nothing: stay


def test_cas_scores_expected_count_or_count_per_step_and_stays_when_all_are_zero():
    p = Params(truth="poisson", algorithm="CAS", n_robots=1, capacity=10, speed=0.1, lam_hat=0.0)
    observed = [0, 0, 4.0, 9.0]             # from home: 4 at 2 steps (location 2), 9 at 4 steps (3)
    assert decide(p, 0, 0, 0, SYMMETRIC, observed) == 3                       # max expected: 9 > 4
    assert decide(p.replace(cas_variant="rate"), 0, 0, 0, SYMMETRIC, observed) == 3   # 9/4 > 4/2
    observed = [0, 0, 5.0, 9.0]
    assert decide(p.replace(cas_variant="rate"), 0, 0, 0, SYMMETRIC, observed) == 2  # 5/2 > 9/4
    assert decide(p, 0, 0, 0, SYMMETRIC, [0, 0, 0, 0]) == k.STAY
    assert decide(p, 0, 3, 1, SYMMETRIC, [0, 0, 0, 0], y=[4]) == k.STAY     # not full, nothing: stays
    assert decide(p, 0, 3, 1, SYMMETRIC, [0, 0, 0, 0], y=[10]) == 0          # full: home


def test_cas_sees_the_others_targets_only_with_cas_targets_shared():
    p = Params(truth="poisson", algorithm="CAS", n_robots=2, capacity=10, speed=0.1, lam_hat=0.0)
    observed = [0, 0, 4.0, 9.0]             # 9 expected at 3, but another robot with room for 10 heads there
    for variant in ("max_expected", "rate"):
        unseen = p.replace(cas_variant=variant)
        assert decide(unseen, 0, 0, 0, SYMMETRIC, observed, earmark=[0, 0, 0, 10]) == 3
        assert decide(unseen.replace(cas_targets="shared"), 0, 0, 0, SYMMETRIC, observed, earmark=[0, 0, 0, 10]) == 2
    shared = p.replace(cas_targets="shared")
    assert decide(shared, 0, 0, 0, SYMMETRIC, observed, earmark=[0, 0, 0, 5]) == 2   # 9 - 5 = 4: a tie, shorter
    assert decide(shared, 0, 0, 0, SYMMETRIC, observed, earmark=[0, 0, 4, 10]) == k.STAY   # nothing left for it
    # the whole kernel at t = 0 (0.3 per step expected: 1.2 at the far location 3, 0.6 at 1 and 2):
    # unseen, both robots go to 3; shared, the second sees the first's target and takes 1
    positions, par = np.array(SYMMETRIC), np.array([0.0, 0.3, 0.3, 0.3])
    both = Params(truth="bernoulli", algorithm="CAS", n_robots=2, capacity=10, speed=0.1, ties="lowest_index",
                  steps=1)
    _, trace, _ = trace_of(both, (positions, par))
    assert trace[0, :, k.TR_DEST].tolist() == [3, 3]
    _, trace, _ = trace_of(both.replace(cas_targets="shared"), (positions, par))
    assert trace[0, :, k.TR_DEST].tolist() == [3, 1]


def test_shared_targets_count_departures_to_a_location_another_robot_heads_to_or_stands_at():
    positions, par = np.array(SYMMETRIC), np.array([0.0, 0.3, 0.3, 0.3])
    both = Params(truth="bernoulli", algorithm="CAS", n_robots=2, capacity=10, speed=0.1, ties="lowest_index",
                  steps=1, trials=1)
    for targets, shared in (("unseen", 1), ("shared", 0)):
        totals = run_cell(both.replace(cas_targets=targets), world=(positions, par))["totals"][0]
        assert (totals[k.T_DEPARTURES], totals[k.T_SHARED]) == (2, shared)


def test_sf_sleep_updates_are_its_visits_split_at_half_time_and_absent_for_other_algorithms():
    sf = Params(truth="logistic", algorithm="SF", n_robots=4, sigma_e=0.12, trials=3, steps=400)
    m = measures(sf)
    visits = simulate(sf)["summary"]["visits"]       # SF visits only its own location: one update each
    assert (m["sf_updates_early"] + m["sf_updates_late"]).tolist() == visits.tolist()
    assert (m["sf_updates_late"] > 0).all() and (m["sf_change_early"] >= m["sf_updates_early"] * 0).all()
    assert (m["served"] == simulate(sf)["summary"]["served"]).all()
    astc = measures(sf.replace(algorithm="ASTC"))
    assert not astc["sf_updates_early"].any() and not astc["sf_change_late"].any()


def test_foraging_is_item_delivery_with_the_items_carried_the_other_way():
    """Section 3.3: serving a demand is foraging it. On one world, a foraging run counting items
    when picked up and an item-delivery run are the same run: every robot's node, destination and
    payload at every step, every location's count, and every total."""
    rng = np.random.default_rng(7)
    the_world = (np.vstack([HOME, rng.uniform(0.0, 1.0, (12, 2))]), np.concatenate([[0.0], rng.uniform(0.05, 0.8, 12)]))
    for algorithm, options in (("R", {}), ("GR", {}), ("CAS", {}), ("CAS", {"cas_variant": "rate"}),
                               ("GR", {"lam_hat_source": "mu"})):
        fp = Params(algorithm=algorithm, n_robots=3, capacity=4, trials=3, steps=200, count_at="pickup", **options)
        idp = fp.replace(mode="delivery", count_at="unload", mu_l=fp.lambda_mean, sigma_l=fp.lambda_sd)
        a = run_cell(fp, world=the_world, trace=True)
        b = run_cell(idp, world=the_world, trace=True)
        for name in ("totals", "per_robot", "trace", "trace_counts"):
            assert np.array_equal(a[name], b[name]), (algorithm, options, name)
        assert a["totals"][:, k.T_SERVED].sum() > 0
    # counted at unload instead, foraging loses what is on board at T: the same trajectory, fewer items
    unload = run_cell(fp.replace(count_at="unload"), world=the_world, trace=True)
    assert np.array_equal(unload["trace"], a["trace"])
    assert (unload["totals"][:, k.T_SERVED] <= a["totals"][:, k.T_SERVED]).all()


def test_theorem_1_random_robots_fill_up_more_surely_as_locations_multiply():
    """Theorem 1: Bernoulli truth, R: the more locations, the fuller a robot comes home."""
    per_trip = []
    for locations in (5, 80):
        s = simulate(Params(truth="bernoulli", algorithm="R", locations=locations, trials=5, steps=400))["summary"]
        per_trip.append(s["served"].sum() / s["trips"].sum())
    assert per_trip[0] < 0.6 * Params().capacity < 0.9 * Params().capacity < per_trip[1]


def test_random_goes_home_when_full_and_otherwise_picks_another_location_uniformly():
    p = Params(truth="poisson", algorithm="R", n_robots=1, capacity=10, speed=0.1)
    zero = [0, 0, 0, 0]
    assert decide(p, 0, 1, 2, SYMMETRIC, zero, y=[10]) == 0
    picks = [decide(p, 0, 1, 2, SYMMETRIC, zero, y=[0], seed=s) for s in range(600)]
    assert set(picks) == {1, 3} and abs(picks.count(1) - 300) < 60           # never its own location
    assert all(decide(p.replace(p_v=0.0), 0, 1, 2, SYMMETRIC, zero, y=[5], seed=s) == 0 for s in range(50))
    assert all(decide(p.replace(p_v=1.0), 0, 1, 2, SYMMETRIC, zero, y=[5], seed=s) in (1, 3) for s in range(50))
    picks = [decide(p, 0, 1, 2, SYMMETRIC, zero, y=[5], seed=s) for s in range(600)]
    assert abs(picks.count(0) - 300) < 60                                     # p_v = 0.5


def test_ties_go_to_the_shorter_trip_then_at_random_or_to_the_lowest_index():
    p = Params(truth="poisson", algorithm="CAS", n_robots=1, capacity=10, speed=0.1, lam_hat=0.0)
    # 1 and 2 tie at 5 (2 steps each), 3 ties too but is 4 steps away: never chosen
    observed = [0, 5.0, 5.0, 5.0]
    picks = [decide(p, 0, 0, 0, SYMMETRIC, observed, seed=s) for s in range(600)]
    assert set(picks) == {1, 2} and abs(picks.count(1) - 300) < 60
    lowest = p.replace(ties="lowest_index")
    assert {decide(lowest, 0, 0, 0, SYMMETRIC, observed, seed=s) for s in range(50)} == {1}
    # within 1e-12 relative is a tie; 1e-9 is not
    assert {decide(lowest, 0, 0, 0, SYMMETRIC, [0, 5.0, 5.0 * (1 + 1e-13), 0])} == {1}
    assert decide(lowest, 0, 0, 0, SYMMETRIC, [0, 5.0, 5.0 * (1 + 1e-9), 0]) == 2
    # the home baseline keeps ties: a location worth exactly y / t(a, 0) does not beat going home
    gr = Params(truth="poisson", algorithm="GR", n_robots=1, capacity=10, speed=0.1, lam_hat=0.0)
    # at 1 with y = 2: home is 2 / 2 = 1; location 2 (4 steps, then 2 home) with 4 more: 6 / 6 = 1
    assert decide(gr, 0, 0, 1, SYMMETRIC, [0, 0, 4.0, 0], y=[2]) == 0
    assert decide(gr, 0, 0, 1, SYMMETRIC, [0, 0, 4.1, 0], y=[2]) == 2


def test_with_an_observation_range_robots_see_locations_near_their_path():
    # home (0.5, 0.5), 1 at (0.9, 0.5), 2 at (0.7, 0.55) beside the path, 3 at (0.7, 0.9) far from it;
    # robot 0 left home for 1 (4 steps), 2 steps done at step 6: at (0.7, 0.5), due at step 8.
    # Robot 1 stands at 3.
    pos = np.array([HOME, (0.9, 0.5), (0.7, 0.55), (0.7, 0.9)])
    travel = np.zeros((4, 4))
    k.travel_table(pos, 0.1, travel)
    assert travel[0, 1] == 4
    node, origin, dest, arrive_at = (np.array(v) for v in ([-1, 3], [0, 0], [1, 3], [8, 0]))
    count = np.array([0, 7, 5, 9])
    observed, observed_at = np.zeros((1, 4)), np.zeros((1, 4))
    k.observe_in_range(6, 0.06, pos, travel, node, origin, dest, arrive_at, False, False, k.POISSON, count,
                       np.zeros(4), observed, observed_at)
    assert observed[0].tolist() == [0, 0, 5, 9] and observed_at[0].tolist() == [0, 0, 6, 6]
    # private models (A26): each robot's own row
    observed = np.zeros((2, 4))
    k.observe_in_range(6, 0.06, pos, travel, node, origin, dest, arrive_at, True, False, k.POISSON, count,
                       np.zeros(4), observed, np.zeros((2, 4)))
    assert observed.tolist() == [[0, 0, 5, 0], [0, 0, 0, 9]]
    # the whole run: a range changes what the robots know, hence what they do
    p = Params(trials=2, steps=300)
    assert not np.array_equal(run_cell(p)["totals"], run_cell(p.replace(obs_range=0.3))["totals"])


# ---------------------------------------------------------------- logistic: prediction, AS, ASTC, SF


@pytest.mark.parametrize("observed, since", [(10.0, 0), (50.0, 7), (99.0, 30), (120.0, 3)])
def test_the_logistic_prediction_is_the_closed_form(observed, since):
    expected = 100.0 / (1.0 + ((100.0 - observed) / observed) * math.exp(-0.04 * since))
    assert k.predict(k.LOGISTIC, 0.0, 100.0, 0.04, observed, 5.0, 5.0 + since) == pytest.approx(expected, rel=1e-14)
    assert k.predict(k.LOGISTIC, 0.0, 100.0, 0.04, 0.0, 5.0, 50.0) == 0.0    # A14: O = 0 predicts 0
    assert k.predict(k.POISSON, 0.5, 100.0, 0.04, 3.0, 5.0, 9.0) == 5.0       # O + lam_hat (tau - t_j)


def test_astc_k_is_the_smallest_step_reaching_the_target():
    rng = np.random.default_rng(3)
    for _ in range(300):
        big_k, growth = 100.0, 0.04
        target = 50.0 + rng.integers(1, 20)
        observed, observed_at = float(rng.integers(1, int(target))), float(rng.integers(0, 50))
        t, out = observed_at + rng.integers(0, 20), int(rng.integers(1, 5))

        brute = next(step for step in range(1, 10_000)
                     if big_k / (1 + (big_k - observed) / observed * math.exp(-growth * (t + step + out - observed_at)))
                     >= target)
        assert k.astc_wait(big_k, growth, target, observed, observed_at, t, out) == brute
    assert k.astc_wait(100.0, 0.04, 100.0, 30.0, 0.0, 0.0, 1) == k.NEVER     # target >= K
    assert k.astc_wait(100.0, 0.04, 60.0, 0.0, 0.0, 0.0, 1) == k.NEVER       # O = 0


def test_as_sleeps_below_the_target_and_astc_visits_an_unassigned_location_meanwhile():
    base = dict(truth="logistic", n_robots=1, capacity=10, speed=0.1)
    as_ = Params(algorithm="AS", **base)
    # assigned location 1 (2 steps); target K/2 + c = 60, predicted on arrival: 58 -> 59.94, 58.1 -> 60.03
    assert decide(as_, 0, 0, 0, SYMMETRIC, [0, 58.0, 0, 0], assigned=[1], owner=[0, 1, 0, 0]) == k.STAY
    assert decide(as_, 0, 0, 0, SYMMETRIC, [0, 58.1, 0, 0], assigned=[1], owner=[0, 1, 0, 0]) == 1
    assert decide(as_, 0, 0, 1, SYMMETRIC, [0, 61.0, 0, 0], assigned=[1], owner=[0, 1, 0, 0]) == 0
    assert decide(as_, 0, 0, 0, SYMMETRIC, [0, 99.0, 0, 0], assigned=[0]) == k.STAY   # unassigned: sleeps
    astc = Params(algorithm="ASTC", **base)
    # O = 50 at t = 0: 50 -> 60 takes ln(1.5) / 0.04 = 10.1 steps, 2 of them on the way out: k = 9 ...
    wait = k.astc_wait(100.0, 0.04, 60.0, 50.0, 0.0, 0.0, 2)
    assert wait == 9
    # ... so location 2 (round trip 4 < 9) is visited, location 3 (round trip 8 < 9) too: one of them
    picks = {decide(astc, 0, 0, 0, SYMMETRIC, [0, 50.0, 0, 0], assigned=[1], owner=[0, 1, 0, 0], seed=s)
             for s in range(100)}
    assert picks == {2, 3}
    # an assigned location is never an extra one; a round trip of k or more is not either (O = 57: k = 2)
    assert decide(astc, 0, 0, 0, SYMMETRIC, [0, 50.0, 0, 0], assigned=[1], owner=[0, 1, 1, 1]) == k.STAY
    assert decide(astc, 0, 0, 0, SYMMETRIC, [0, 57.0, 0, 0], assigned=[1], owner=[0, 1, 0, 0]) == k.STAY


@pytest.mark.parametrize("gain, sleep", [(1.0, 9), (0.5, 5)])    # 0.5 * 9 = 4.5 rounds half up to 5
def test_sf_sleeps_tau_steps_from_its_arrival_step(gain, sleep):
    # one location 1 step away; sigma_e = 0: x1 = 50 + 0.04 * 50 * 0.5 = 51 on arrival at t = 1;
    # tau = round(0 + K_p (60 - 51)); forages 10; home at t = 2, leaves at t = 2 + tau
    p = Params(truth="logistic", algorithm="SF", n_robots=1, capacity=10, speed=0.2, sigma_e=0.0, K_p=gain,
               steps=20)
    _, trace, counts = trace_of(p, world((0.5, 0.6)))
    assert counts[1, 1] == 51.0 - 10.0
    node = trace[:, 0, k.TR_NODE].tolist()
    assert node[1] == -1 and node[2: 2 + sleep] == [0] * sleep and node[2 + sleep] == -1


def test_the_logistic_truth_is_the_euler_step_clipped_at_zero():
    # m_min = K: nothing is ever foraged, so the population follows the SDE alone
    p = Params(truth="logistic", algorithm="R", n_robots=1, sigma_e=0.0, m_min=1_000_000, x0=1.0, steps=300)
    _, _, counts = trace_of(p, world((0.5, 0.6)))
    x = 1.0
    for t in range(1, 301):
        x = max(0.0, x + (0.04 * x * (1.0 - x / 100.0) + 0.5 * 0.0 * 0.0 * x) + 0.0 * x * 0.0)
        assert counts[t, 1] == x
    # with noise, the unforaged population fluctuates around about K
    p = p.replace(sigma_e=0.12, x0=50.0, steps=2000)
    _, _, counts = trace_of(p, world(*[(0.1, 0.1)] * 50))
    assert 90.0 < counts[500:, 1:].mean() < 102.0


# ---------------------------------------------------------------- truths and samplers


def generation_streams(m1, seed=12345):
    """Per-location generation streams (4, m1) as the kernel seeds them."""
    rng = np.zeros((1, 1, 4), dtype=np.uint64)
    lanes = np.zeros((4, m1), dtype=np.uint64)
    for j in range(m1):
        seed_stream(rng, 0, 0, seed, k.LOCATION_KEY + j)
        lanes[:, j] = rng[0, 0]
    return lanes


def poisson_generation(mean, locations=2001, steps=50):
    """Counts of ``steps`` steps of Poisson(mean) generation at ``locations`` locations."""
    m1 = locations + 1
    parts, mu, e_mu = k.poisson_parts(mean)
    levels = np.zeros((k.POISSON_LEVELS, m1), dtype=np.int64)
    k.poisson_levels(parts, mu, e_mu, levels[:, 0])
    levels[:, :] = levels[:, :1]
    count = np.zeros(m1, dtype=np.int64)
    lanes = generation_streams(m1)
    draws = []
    for _ in range(steps):
        before = count.copy()
        generated = k.poisson_step(lanes, levels, count, np.zeros(m1, dtype=np.int64), np.full(m1, parts),
                                   np.full(m1, mu), np.full(m1, e_mu))
        assert generated == (count - before).sum()
        draws.append(count[1:] - before[1:])
    return np.concatenate(draws)


@pytest.mark.parametrize("mean", [0.01, 0.1, 0.5, 3.0, 40.0])
def test_poisson_generation_has_the_poisson_pmf(mean):
    draws = poisson_generation(mean)
    se = math.sqrt(mean / draws.size)
    assert abs(draws.mean() - mean) < 5 * se
    assert abs(draws.var() / mean - 1.0) < 0.05
    # chi-square of the pmf over the values expected at least 20 times, the rest pooled in the tails
    values = np.arange(draws.max() + 1)
    pmf = np.array([math.exp(-mean + v * math.log(mean) - math.lgamma(v + 1)) for v in values])
    expected = pmf * draws.size
    keep = expected >= 20
    observed = np.bincount(draws, minlength=values.size)
    cells_obs = np.append(observed[keep], observed[~keep].sum())
    cells_exp = np.append(expected[keep], draws.size - expected[keep].sum())
    statistic = ((cells_obs - cells_exp) ** 2 / cells_exp).sum()
    dof = cells_obs.size - 1
    assert statistic < dof + 6 * math.sqrt(2 * dof) + 10          # far beyond the 1e-4 quantile
    assert (poisson_generation(0.0, locations=10, steps=10) == 0).all()


@pytest.mark.parametrize("mean", [1e-300, 0.01, 0.1, 0.5, 3.0, 15.9, 16.5])
def test_poisson_thresholds_give_the_inversions_count_exactly(mean):
    parts, mu, e_mu = k.poisson_parts(mean)
    levels = np.zeros(k.POISSON_LEVELS, dtype=np.int64)
    k.poisson_levels(parts, mu, e_mu, levels)
    bits = np.random.default_rng(3).integers(0, 2**53, 20_000)
    edges = np.clip(np.concatenate([levels - 1, levels, levels + 1]), 0, 2**53 - 1)
    lanes = generation_streams(1)
    for draw in np.concatenate([bits, edges]):
        u = float(draw) / 2**53
        by_levels = int((draw > levels).sum())
        if by_levels < k.POISSON_LEVELS:
            assert by_levels == k.poisson(u, lanes.copy(), 0, parts, mu, e_mu)
        else:
            assert k.poisson(u, lanes.copy(), 0, parts, mu, e_mu) >= k.POISSON_LEVELS


def test_bernoulli_thresholds_are_u_below_p_exactly():
    for p in (0.0, 1e-300, 0.3, 0.5, 1.0 - 2**-53, 1.0):
        below = math.ceil(p * 2**53)
        for draw in {0, max(0, below - 1), below, min(2**53 - 1, below + 1), 2**53 - 1}:
            assert (draw < below) == (draw / 2**53 < p)


def test_bernoulli_and_poisson_generation_follow_the_true_rates():
    twenty = [(0.1 + 0.04 * j, 0.2) for j in range(20)]
    p = Params(truth="bernoulli", algorithm="R", n_robots=1, steps=1000, trials=1)
    generated = run_cell(p, world=world(*twenty, truth=[0.3] * 20))["totals"][0, k.T_GENERATED]
    assert abs(generated - 6000) < 5 * math.sqrt(20_000 * 0.3 * 0.7)
    generated = run_cell(p.replace(truth="poisson"), world=world(*twenty, truth=[0.5] * 20))["totals"][0, 0]
    assert abs(generated - 10_000) < 5 * math.sqrt(10_000)


def draw(params, seed=7):
    """Stream (a) of trial root seed ``seed``: (positions, true parameters)."""
    opts, pars, positions, truth_par = kernel_inputs(params)
    rng = np.zeros((1, k.STREAM_ROBOT, 4), dtype=np.uint64)
    seed_stream(rng, 0, k.STREAM_WORLD, seed, k.STREAM_WORLD)
    k.draw_world(opts, pars, params.n_locations, rng, positions, truth_par)
    return positions, truth_par


def test_true_parameters_are_clipped_or_redrawn_and_idp_rates_share_their_deviates():
    positions, p_j = draw(Params(truth="bernoulli", p_sd=1.0, locations=200))
    assert p_j[1:].min() == 0.0 and p_j[1:].max() == 1.0                       # A10: clipped
    assert ((positions[1:] >= 0) & (positions[1:] < 1)).all()
    _, p_j = draw(Params(truth="bernoulli", p_sd=1.0, locations=200, truncation="resample"))
    assert ((p_j[1:] > 0) & (p_j[1:] < 1)).all() and len(set(p_j[1:])) == 200   # redrawn instead
    _, lam_fp = draw(Params(truth="poisson", locations=200))
    assert lam_fp[1:].min() == 0.0 and abs(lam_fp[1:].mean() - 0.52) < 0.06
    # IDP: lambda_j = max(0.01, mu_l + sigma_l z_j), the same z_j for every mu_l, sigma_l (section 10)
    a = draw(Params(mode="delivery", mu_l=0.10, sigma_l=0.08))[1][1:]
    b = draw(Params(mode="delivery", mu_l=0.15, sigma_l=0.04))[1][1:]
    assert a.min() == 0.01
    inside = (a > 0.01) & (b > 0.01)
    assert inside.sum() > 300
    np.testing.assert_allclose((a[inside] - 0.10) / 0.08, (b[inside] - 0.15) / 0.04, rtol=1e-9, atol=1e-12)


# ---------------------------------------------------------------- metrics and common random numbers


def test_a_trial_draws_the_same_world_and_generation_for_every_algorithm_n_c_and_s():
    base = Params(truth="bernoulli", trials=4, steps=300)
    generated = {(alg, n, c, s): tuple(simulate(base.replace(algorithm=alg, n_robots=n, capacity=c, speed=s))
                                       ["summary"]["generated"])
                 for alg in ("R", "GR", "CAS") for n in (1, 7) for c in (1, 12) for s in (0.2, 0.6)}
    assert len(set(generated.values())) == 1
    assert len(set(next(iter(generated.values())))) == 4                         # trials differ
    # the world does not depend on the robots either (stream (a) is drawn first, alone)
    assert np.array_equal(draw(base)[0], draw(base.replace(n_robots=9, algorithm="R"))[0])
    # and a trial is the same alone and beside others
    together = simulate(base)["summary"]
    alone = simulate(base.replace(first_trial=3, trials=1))["summary"]
    assert all(alone[c][0] == together[c][2] or (np.isnan(alone[c][0]) and np.isnan(together[c][2]))
               for c in together)


def test_the_summary_metrics():
    s = simulate(Params(trials=3, steps=400))["summary"]
    assert (s["trial"] == [1, 2, 3]).all() and (s["seed"] == 2015 * 2**32 + np.arange(1, 4)).all()
    np.testing.assert_array_equal(s["rate"], 100.0 * s["served"] / s["generated"])
    np.testing.assert_array_equal(s["items_per_trip"], s["served"] / s["trips"])
    assert (s["served"] <= s["picked"]).all() and (s["served"] <= s["generated"]).all()
    logistic = simulate(Params(truth="logistic", algorithm="SF", trials=2, steps=400))["summary"]
    np.testing.assert_array_equal(logistic["rate"], logistic["served"])       # A19: F itself
    delivery = simulate(Params(mode="delivery", trials=2, steps=300))["summary"]
    np.testing.assert_array_equal(delivery["served"], delivery["picked"])     # S counted at delivery
