"""The event loop against docs/delivery-model.md: advertising, event instants, winner rules, loss, supervisor,
learning, the tick skip, determinism and the half-run property.

Hand-made scenarios (1 to 3 UAVs, a handful of orders) force decisions through the policy
arrays; every expected number comes from the formulas of docs/delivery-model.md (see conftest), not from
the engine's functions.
"""

import math
from pathlib import Path

import numpy as np
import pyarrow as pa
import pytest
import yaml
from sklearn.linear_model import SGDClassifier

from conftest import (
    ALWAYS, DELTA, K, MU, NEVER, SHORT_ONLY, SIGMA, SPEED, WEEK, charged, next_grid, rate, run_state,
    scenario, scenario_config, x_std,
)
from dronefleet.delivery import config as cfg
from dronefleet.delivery import engine, simulation, records as delivery_records
from dronefleet.supervisor import BUILTIN_CONTROLLER, SupervisorError

# Local supervisor state of a UAV by engine mode once every event at an instant is processed.
# S0 wait (idle), S4 after `deliver` (outbound), S5 after `condReturn` (returning; a lost UAV
# ran out of charge on its way back, after its turn).
SUP_STATE_OF_MODE = {engine.IDLE: 0, engine.OUTBOUND: 4, engine.RETURNING: 5, engine.LOST: 5}


def _takeoffs(result):
    a = result.attempts
    return list(zip(a["uav"].tolist(), a["order"].tolist(), a["takeoff_s"].tolist()))


def _advertised(arrivals, ticks):
    """Order advertised at each tick by the rule of docs/delivery-model.md section 4, if nobody bids in between."""
    last, out = None, []
    for tick in ticks:
        queued = [j for j, a in enumerate(arrivals) if a <= tick]
        later = [j for j in queued if last is not None and j > last]
        last = later[0] if later else queued[0]
        out.append(last)
    return out


# ============================================================================ advertising rules


def test_first_advertisement_is_the_oldest_order_at_tick_0():
    # Three orders at t = 0, the UAV bids on anything: it takes them oldest first; each return
    # lands on the grid, and the landing (processed before the tick) lets it bid at that tick.
    c = scenario_config()
    st = scenario(c, [0.0, 0.0, 0.0], [5000.0, 2000.0, 3000.0], [1.0, 1.0, 1.0], policies=ALWAYS)
    r = run_state(st, c)
    assert _takeoffs(r) == [(0, 0, 0.0), (0, 1, 1000.0), (0, 2, 1400.0)]


def test_nobody_bids_then_next_order_in_arrival_order():
    # The UAV bids only on orders shorter than 3500 m: ticks 0 and 2 advertise the two long orders.
    c = scenario_config()
    st = scenario(c, [0.0, 0.0, 0.0], [5000.0, 4000.0, 2000.0], [1.0, 1.0, 1.0], policies=SHORT_ONLY)
    r = run_state(st, c)
    assert _takeoffs(r) == [(0, 2, 4.0)]
    # Back at 404 s, then the two long orders are advertised every tick until the horizon.
    last_tick = math.floor(c.horizon_s / DELTA) * DELTA
    assert r.auctions == 3 + int((last_tick - 404.0) / DELTA) + 1
    assert np.isnan(r.orders["delivered_s"][:2]).all()


@pytest.mark.parametrize("rule", ["least_confident", "least_confident_every_tick"])
def test_advertising_wraps_round_to_the_oldest(rule, every_tick_rules):
    # One UAV charging from 50 %, bidding iff x_soc >= 0.35 (SoC >= 60.1 %): nobody bids for
    # ~6844 s while three orders (arrived at 0, 10, 20 s) are advertised in turn. The order it
    # takes is the one the rotation (next in arrival order, wrapping) reaches at the first tick
    # at which its SoC allows a bid.
    c = scenario_config(rule=rule, horizon_s=4 * 3600.0)
    arrivals = [0.0, 10.0, 20.0]
    st = scenario(c, arrivals, [2000.0, 2000.0, 2000.0], [1.0, 1.0, 1.0],
                  policies=((0.0, 0.0, 1.0), -0.35), soc=50.0)
    threshold = MU[2] + 0.35 * SIGMA[2]
    t_star = math.log((100.0 - 50.0) / (100.0 - threshold)) / K
    first = next_grid(t_star)
    assert 1e-6 < first - t_star < DELTA - 1e-6  # not a floating-point coin toss
    expected = _advertised(arrivals, np.arange(0.0, first + 1, DELTA))[-1]
    assert expected == 1  # the scenario is chosen so that only a correct rotation gets it
    r = run_state(st, c, t_stop=first + 1.0)
    assert _takeoffs(r) == [(0, expected, first)]
    assert r.attempts["takeoff_soc"][0] == pytest.approx(charged(50.0, first), rel=1e-12)
    assert r.auctions == first / DELTA + 1


def test_after_an_allocation_advertising_starts_again_from_the_oldest():
    # Two UAVs that bid only on short orders; orders L S L S at t = 0.
    # tick 0: o0 (long) nobody; tick 2: o1 -> UAV 1 (tie: highest id); tick 4: back to o0, nobody;
    # tick 6: o2 (long) nobody; tick 8: o3 -> UAV 0.
    c = scenario_config(n_uavs=2)
    st = scenario(c, [0.0] * 4, [5000.0, 2000.0, 4500.0, 2500.0], [1.0] * 4, policies=SHORT_ONLY)
    r = run_state(st, c, t_stop=100.0)
    assert _takeoffs(r) == [(1, 1, 2.0), (0, 3, 8.0)]


def test_advertising_is_suspended_and_resumes_on_the_grid():
    c = scenario_config()
    arrivals = [0.0, 3.3, 1001.1, 1400.0, 1700.5]
    distances = [1234.5, 1000.0, 1500.0, 2000.0, 1000.0]
    st = scenario(c, arrivals, distances, [1.0] * 5, policies=ALWAYS)
    r = run_state(st, c)
    a = r.attempts
    leg0 = 1234.5 / SPEED
    assert a["return_s"][0] == pytest.approx(2 * leg0, abs=1e-9)
    # o1 arrives while the UAV is away (no UAV idle) -> first grid instant after its landing
    # (246.9 s); o2 arrives while nothing is queued -> 1002; o3 arrives on the grid -> at once;
    # o4 arrives while it is away and it lands on the grid (1800 s) -> at once.
    assert a["takeoff_s"].tolist() == [0.0, 248.0, 1002.0, 1400.0, 1800.0]
    assert a["order"].tolist() == [0, 1, 2, 3, 4]
    # Nothing is advertised while suspended: one auction per takeoff.
    assert r.auctions == 5
    assert (a["outcome"] == engine.OUTCOME_DELIVERED).all()


def test_aborted_order_returns_to_its_place_once_its_parcel_is_back():
    # One UAV at 20 % takes o0 (6 km, 5 kg) and aborts; o1 and o2 queue up meanwhile. When the
    # parcel is back, o0 is the oldest unallocated order again (not the newest) and, advertising
    # starting from the oldest after an allocation, it is the next one taken.
    c = scenario_config()
    st = scenario(c, [0.0, 10.0, 20.0], [6000.0, 1000.0, 1000.0], [5.0, 1.0, 1.0], policies=ALWAYS, soc=20.0)
    t_abort = 0.5 * 20.0 / rate(5.0)
    t_land = 2 * t_abort
    second = next_grid(t_land)
    r = run_state(st, c, t_stop=second + 1.0)
    a = r.attempts
    assert a["order"][:2].tolist() == [0, 0]
    assert a["outcome"][0] == engine.OUTCOME_ABORTED and not a["lost"][0]
    assert a["return_s"][0] == pytest.approx(t_land, rel=1e-12)
    assert a["takeoff_s"][1] == second
    assert a["takeoff_soc"][1] == pytest.approx(charged(0.0, second - t_land), rel=1e-9, abs=1e-12)
    assert r.orders["attempts"].tolist() == [2, 0, 0]


def test_aborted_order_is_not_advertised_before_its_parcel_is_back():
    # UAV 1 (most confident) takes o0 and aborts; UAV 0 is idle all along and would bid on o0
    # (short), but only gets the chance once the parcel has landed.
    c = scenario_config(n_uavs=2, rule="most_confident")
    st = scenario(c, [0.0], [3000.0], [5.0], policies=[SHORT_ONLY, ALWAYS], soc=[100.0, 20.0])
    t_land = 2 * 0.5 * 20.0 / rate(5.0)
    simulation.advance(st, t_land - 0.01)
    # One auction (tick 0); then nothing is queued until the parcel is back.
    assert st.counters[engine.N_AUCTIONS] == 1 and st.counters[engine.N_ATTEMPTS] == 1
    assert st.counters[engine.QUEUE_LEN] == 0
    r = run_state(st, c, t_stop=next_grid(t_land) + 1.0)
    a = r.attempts
    assert a["uav"][0] == 1 and a["outcome"][0] == engine.OUTCOME_ABORTED
    assert a["return_s"][0] == pytest.approx(t_land, rel=1e-12)
    assert a["order"].tolist() == [0, 0] and a["takeoff_s"][1] == next_grid(t_land)


# ============================================================================ event instants


@pytest.mark.parametrize("xi", [0.5, 0.6])
def test_exact_event_instants_and_charging_between_flights(xi):
    soh = 0.8
    c = scenario_config(xi=xi)
    st = scenario(c, [0.0, 1000.0], [3000.0, 5000.0], [2.0, 4.5], soh=[soh], policies=ALWAYS)
    rl2, rl45, re = rate(2.0, soh), rate(4.5, soh), rate(0.0, soh)
    # Attempt 0: delivered at d / v, home at 2 d / v.
    land0 = 100.0 - 300.0 * (rl2 + re)
    # Attempt 1 at 1000 s with the charge regained on the ground; it cannot reach 5 km.
    soc1 = charged(land0, 1000.0 - 600.0)
    assert 500.0 * rl45 >= (1 - xi) * soc1
    out1 = (1 - xi) * soc1 / rl45
    turn1, ret1 = 1000.0 + out1, 1000.0 + 2 * out1
    land1 = xi * soc1 - (1 - xi) * soc1
    # Attempt 2: the aborted order again, at the first tick after the landing.
    t2 = next_grid(ret1)
    soc2 = charged(land1, t2 - ret1)
    r = run_state(st, c, t_stop=t2 + 0.001)
    a = r.attempts
    assert a["order"][:3].tolist() == [0, 1, 1]
    assert a["takeoff_s"][:3].tolist() == [0.0, 1000.0, t2]
    assert a["takeoff_soc"][0] == 100.0
    assert a["outcome"][:2].tolist() == [engine.OUTCOME_DELIVERED, engine.OUTCOME_ABORTED]
    assert a["turn_s"][0] == pytest.approx(300.0, rel=1e-14)
    assert a["return_s"][0] == pytest.approx(600.0, rel=1e-14)
    assert a["return_soc"][0] == pytest.approx(land0, rel=1e-12)
    assert r.orders["delivered_s"][0] == pytest.approx(300.0, rel=1e-14)
    assert a["takeoff_soc"][1] == pytest.approx(soc1, rel=1e-12)
    assert a["turn_s"][1] == pytest.approx(turn1, rel=1e-12)
    assert a["return_s"][1] == pytest.approx(ret1, rel=1e-12)
    assert a["return_soc"][1] == pytest.approx(land1, rel=1e-9, abs=1e-9)
    assert a["return_soc"][1] >= 0.0 and not a["lost"][1]
    assert a["takeoff_soc"][2] == pytest.approx(soc2, rel=1e-9, abs=1e-12)


def test_snapshot_soc_in_every_mode():
    # SoC is a closed form at any instant: falling at the loaded rate outbound, at the empty rate
    # flying home after a delivery, at the loaded rate flying home after an abort, and charging
    # on the ground.
    soh = 0.7
    c = scenario_config()
    st = scenario(c, [0.0, 2000.0], [3000.0, 6000.0], [2.0, 5.0], soh=[soh], policies=ALWAYS)
    rl2, rl5, re = rate(2.0, soh), rate(5.0, soh), rate(0.0, soh)
    land0 = 100.0 - 300.0 * (rl2 + re)
    soc1 = charged(land0, 2000.0 - 600.0)
    assert 600.0 * rl5 >= 0.5 * soc1  # o1 is aborted
    out1 = 0.5 * soc1 / rl5
    expected = {
        100.0: (engine.OUTBOUND, 100.0 - 100.0 * rl2),
        450.0: (engine.RETURNING, 100.0 - 300.0 * rl2 - 150.0 * re),
        1000.0: (engine.IDLE, charged(land0, 400.0)),
        2000.0 + out1 / 2: (engine.OUTBOUND, soc1 - out1 / 2 * rl5),
        2000.0 + 1.5 * out1: (engine.RETURNING, 0.5 * soc1 - out1 / 2 * rl5),
    }
    for t, (mode, soc) in expected.items():
        simulation.advance(st, t)
        assert st.fleet.mode[0] == mode, t
        assert simulation.snapshot(st, t)["soc"][0] == pytest.approx(soc, rel=1e-9, abs=1e-9), t


# ============================================================================ winner rules


@pytest.mark.parametrize("rule,policy", [("least_confident", ALWAYS), ("most_confident", ALWAYS),
                                         ("random", ALWAYS), ("threshold", NEVER)])
def test_ties_go_to_the_highest_uav_id(rule, policy):
    # Identical policies and SoC: equal bid values. (random: no ties, just all bid.)
    c = scenario_config(n_uavs=3, rule=rule, theta=50.0)
    st = scenario(c, [0.0] * 3, [2000.0] * 3, [1.0] * 3, policies=policy)
    r = run_state(st, c, t_stop=10.0)
    if rule == "random":
        assert sorted(r.attempts["uav"].tolist()) == [0, 1, 2]
    else:
        assert _takeoffs(r) == [(2, 0, 0.0), (1, 1, 2.0), (0, 2, 4.0)]


# Three policies whose bid value f / ||w|| orders them unlike f itself (order with x_d = x_m = 0).
CONFIDENCE_POLICIES = [((6.0, 0.0, 8.0), 10.0), ((0.0, 0.06, 0.08), 0.35), ((0.0, 0.0, 1.0), 3.0)]


@pytest.mark.parametrize("rule", ["least_confident", "most_confident"])
def test_confidence_rules_use_the_signed_distance(rule):
    c = scenario_config(n_uavs=3, rule=rule)
    st = scenario(c, [0.0], [3500.0], [2.75], policies=CONFIDENCE_POLICIES)
    x = x_std(3500.0, 2.75, 100.0)
    f = [sum(wi * xi for wi, xi in zip(w, x)) + b for w, b in CONFIDENCE_POLICIES]
    value = [fi / math.hypot(*w) for fi, (w, _) in zip(f, CONFIDENCE_POLICIES)]
    assert min(f) >= 0  # all bid
    expected = int(np.argmin(value)) if rule == "least_confident" else int(np.argmax(value))
    assert expected == (0 if rule == "least_confident" else 1)
    assert expected != (int(np.argmin(f)) if rule == "least_confident" else int(np.argmax(f)))
    r = run_state(st, c, t_stop=1.0)
    assert _takeoffs(r) == [(expected, 0, 0.0)]


def test_least_confident_prefers_the_lowest_soc_with_equal_policies():
    # f = 1000 + x_soc: the emptiest UAV is the least confident, the fullest the most.
    for rule, expected in (("least_confident", 0), ("most_confident", 1)):
        c = scenario_config(n_uavs=3, rule=rule)
        st = scenario(c, [0.0], [2000.0], [1.0], policies=ALWAYS, soc=[40.0, 90.0, 60.0])
        r = run_state(st, c, t_stop=1.0)
        assert _takeoffs(r) == [(expected, 0, 0.0)]


def test_threshold_rule():
    # theta = 80: only UAVs with SoC >= 80 bid (whatever their policy says), the fullest wins.
    theta = 80.0
    c = scenario_config(n_uavs=3, rule="threshold", theta=theta, horizon_s=86400.0)
    soc0 = [85.0, 95.0, 70.0]
    st = scenario(c, [0.0, 1.0, 3.0], [6000.0] * 3, [0.5] * 3, policies=NEVER, soc=soc0)
    # tick 0: o0 -> UAV 1 (95 %); tick 2: o1 -> UAV 0 (85 %; UAV 2 at 70 % does not bid).
    # Then o2 waits until some idle UAV charges up to theta.
    leg, rl, re = 600.0, rate(0.5), rate(0.0)
    land = {1: (2 * leg, 95.0 - leg * (rl + re)), 0: (2.0 + 2 * leg, charged(85.0, 2.0) - leg * (rl + re))}
    reach = {2: math.log((100.0 - 70.0) / (100.0 - theta)) / K}
    for i, (t_land, s_land) in land.items():
        reach[i] = t_land + math.log((100.0 - s_land) / (100.0 - theta)) / K
    uav = min(reach, key=reach.get)
    t = next_grid(reach[uav])
    assert 1e-6 < t - reach[uav] and all(next_grid(v) > t for i, v in reach.items() if i != uav)
    r = run_state(st, c)
    assert _takeoffs(r) == [(1, 0, 0.0), (0, 1, 2.0), (uav, 2, t)]
    assert uav == 2
    assert r.attempts["takeoff_soc"][2] == pytest.approx(charged(70.0, t), rel=1e-12)
    assert r.attempts["takeoff_soc"][2] >= theta


@pytest.mark.parametrize("seed", range(8))
def test_random_rule_draws_from_its_own_stream(seed):
    # All three bid on each of three orders: the winner of each tick is the highest of the
    # draws of the idle bidders, in id order, from the run's random-bid stream (the fourth
    # child of the seed's SeedSequence, see simulation.py).
    c = scenario_config(n_uavs=3, rule="random", seed=seed)
    st = scenario(c, [0.0] * 3, [2000.0] * 3, [1.0] * 3, policies=ALWAYS)
    rng = np.random.default_rng(np.random.SeedSequence(seed).spawn(4)[3])
    idle, expected = [0, 1, 2], []
    for _ in range(3):
        draws = rng.random(len(idle))
        expected.append(idle[int(np.argmax(draws))])
        idle.remove(expected[-1])
    r = run_state(st, c, t_stop=10.0)
    assert r.attempts["uav"].tolist() == expected


def test_random_rule_stream_is_separate():
    c = cfg.replace(cfg.default_config(), rule="random", horizon_weeks=1.0, seed=3)
    a = simulation.simulate(c)
    b = simulation.simulate(c)
    for key in a.attempts:
        np.testing.assert_array_equal(a.attempts[key], b.attempts[key])
    # Another random-bid stream: other winners, the same orders, SoH and initial policies.
    st = simulation.initial_state(c)
    st.bid_rng = np.random.default_rng(12345)
    other = run_state(st, c)
    for key in ("arrival_s", "distance_m", "mass_kg"):
        np.testing.assert_array_equal(other.orders[key], a.orders[key])
    np.testing.assert_array_equal(other.snapshots[-1]["soh"], a.snapshots[-1]["soh"])
    assert other.attempts["uav"].tolist() != a.attempts["uav"].tolist()
    # And another rule draws nothing from the order, SoH or learner streams.
    lc = simulation.initial_state(cfg.replace(c, rule="least_confident"))
    rd = simulation.initial_state(c)
    np.testing.assert_array_equal(lc.book.arrival_s, rd.book.arrival_s)
    np.testing.assert_array_equal(lc.fleet.soh, rd.fleet.soh)
    np.testing.assert_array_equal(lc.fleet.coef, rd.fleet.coef)


# ============================================================================ loss


def test_loss_with_xi_zero():
    # UAV 1 at 10 % is the least confident (f = 1000 + x_soc) and takes a 6 km, 5 kg order it
    # cannot reach: with xi = 0 it turns back at SoC 0, i.e. it is lost at that instant.
    c = scenario_config(n_uavs=2, xi=0.0, horizon_s=86400.0)
    st = scenario(c, [0.0, 2000.0, 2001.0], [6000.0, 1000.0, 1000.0], [5.0, 1.0, 1.0],
                  policies=ALWAYS, soc=[100.0, 10.0])
    t_lost = 10.0 / rate(5.0)
    r = run_state(st, c)
    a = r.attempts
    # o0 goes back to the queue and is taken by UAV 0 at the next tick; UAV 1 never bids again.
    assert _takeoffs(r) == [(1, 0, 0.0), (0, 0, next_grid(t_lost)), (0, 1, 2000.0), (0, 2, 2200.0)]
    assert a["lost"].tolist() == [True, False, False, False]
    assert a["turn_s"][0] == pytest.approx(t_lost, rel=1e-12)
    assert a["return_s"][0] == pytest.approx(t_lost, rel=1e-12)
    assert st.fleet.mode.tolist() == [engine.IDLE, engine.LOST]
    assert r.orders["attempts"].tolist() == [2, 1, 1]
    assert not np.isnan(r.orders["delivered_s"]).any()
    t = delivery_records.tables(r)
    assert t["summary"].column("lost_uavs")[0].as_py() == 1
    assert t["attempts"].column("outcome").to_pylist()[0] == "lost"
    fleet = t["fleet"].to_pylist()
    assert [row["lost"] for row in fleet if row["uav"] == 1] == [True]
    assert [row["lost"] for row in fleet if row["uav"] == 0] == [False]
    assert fleet[1]["soc"] is None  # a lost UAV has no SoC
    ts = t["timeseries"].to_pydict()
    for time, lost, idle in zip(ts["t_s"], ts["lost"], ts["idle"]):
        assert lost == (1 if time >= t_lost else 0)
        assert idle <= 2 - lost
    assert [row["winners"] for row in t["orders"].to_pylist()] == [[1, 0], [0], [0]]


# ============================================================================ supervisor


def _controller_without_deliver_in_s3(path):
    doc = yaml.safe_load(Path(BUILTIN_CONTROLLER).read_text())
    data = doc["sup_data"]
    i, state = 0, 0
    while state < 3:
        i += 1 + 3 * data[i]
        state += 1
    n_out = data[i]
    block = data[i + 1:i + 1 + 3 * n_out]
    triples = [block[j:j + 3] for j in range(0, len(block), 3)]
    kept = [t for t in triples if t[0] != "EV_deliver"]
    assert len(kept) == n_out - 1
    doc["sup_data"] = data[:i] + [n_out - 1] + [x for t in kept for x in t] + data[i + 1 + 3 * n_out:]
    path.write_text(yaml.safe_dump(doc, default_flow_style=None))
    return path


def test_supervisor_refuses_a_transition_it_does_not_allow(tmp_path):
    path = _controller_without_deliver_in_s3(tmp_path / "no-deliver.yaml")
    c = scenario_config(n_uavs=2)
    st = simulation.initial_state(c, supervisor=path)
    with pytest.raises(SupervisorError, match="deliver"):
        simulation.advance(st, c.horizon_s)
    with pytest.raises(SupervisorError, match="'deliver'"):
        simulation.simulate(cfg.replace(cfg.default_config(), horizon_weeks=1.0), supervisor=path)
    # The packaged file runs.
    simulation.simulate(c)


def test_tick_skip_is_off_when_the_idle_state_does_not_loop_on_not_capable(tmp_path):
    # Skipped ticks do not step notCapableTask, which is exact only for a self-loop (as in S0
    # of the packaged controller). A controller where it leaves S0 must see every tick.
    doc = yaml.safe_load(Path(BUILTIN_CONTROLLER).read_text())
    data = doc["sup_data"]
    at = data.index("EV_notCapableTask")  # the first state's (S0) transition on it
    assert data[at + 1:at + 3] == [0, 0]
    data[at + 2] = 1
    path = tmp_path / "leaves-s0.yaml"
    path.write_text(yaml.safe_dump(doc, default_flow_style=None))
    c = scenario_config(n_uavs=2)
    assert simulation.initial_state(c).params.bids_on == engine.BIDS_ON_POLICY
    assert simulation.initial_state(c, supervisor=path).params.bids_on == engine.BIDS_ON_ANY


def _controller_with_a_twin_of_s0(path):
    """The packaged controller with S6, a copy of S0 that a lost bid leads to (and S6 to itself).

    It allows the same event sequences, so runs are the same; but a losing bid from S0 changes
    the state (to S6), so the engine must take its steps, while from S6 it need not.
    """
    doc = yaml.safe_load(Path(BUILTIN_CONTROLLER).read_text())
    data, states, i = doc["sup_data"], [], 0
    while i < len(data):
        states.append([data[j:j + 3] for j in range(i + 1, i + 1 + 3 * data[i], 3)])
        i += 1 + 3 * data[i]
    assert ["EV_lostBid", 0, 0] in states[2]
    states[2] = [["EV_lostBid", 0, 6] if t == ["EV_lostBid", 0, 0] else t for t in states[2]]
    states.append([[event, 0, 6 if target == 0 else target] for event, _, target in states[0]])
    doc["sup_data"] = [x for triples in states for x in [len(triples)] + [y for t in triples for y in t]]
    path.write_text(yaml.safe_dump(doc, default_flow_style=None))
    return path


@pytest.mark.parametrize("rule", ["least_confident", "random", "reservation"])
def test_losing_bids_that_change_the_supervisor_state_give_the_same_run(tmp_path, rule):
    path = _controller_with_a_twin_of_s0(tmp_path / "twin.yaml")
    c = cfg.replace(cfg.default_config(), horizon_weeks=1.0, n_uavs=25, rule=rule, seed=2)
    twin = simulation.initial_state(c, supervisor=path)
    assert not twin.fleet.bid_silent.any() and twin.fleet.quiet.all()
    runs = [delivery_records.tables(simulation.simulate(c, supervisor=s)) for s in (None, path)]
    for name in ("orders", "attempts", "fleet", "timeseries"):
        assert runs[0][name].equals(runs[1][name]), name


@pytest.mark.parametrize("xi,n_uavs", [(0.5, 25), (0.3, 25)])
def test_supervisor_state_matches_mode(xi, n_uavs):
    c = cfg.replace(cfg.default_config(), horizon_weeks=1.0, xi=xi, n_uavs=n_uavs, seed=5)
    st = simulation.initial_state(c)
    modes = set()
    for t in np.linspace(0.0, c.horizon_s, 29)[1:]:
        simulation.advance(st, t)
        for i in range(n_uavs):
            modes.add(int(st.fleet.mode[i]))
            assert st.fleet.sup[i].tolist() == [SUP_STATE_OF_MODE[int(st.fleet.mode[i])]], (t, i)
    if xi < 0.5:
        assert engine.LOST in modes  # with xi < 0.5 every abort is a loss
    else:
        assert {engine.IDLE, engine.OUTBOUND, engine.RETURNING}.issubset(modes)


# ============================================================================ learning


def _sgd(coef, intercept, t):
    clf = SGDClassifier(loss="modified_huber", penalty="l2", alpha=0.01, learning_rate="optimal", eta0=0.01,
                        fit_intercept=True, random_state=0)
    clf.partial_fit(np.zeros((1, 3)), [0], classes=[0, 1])
    clf.coef_ = np.array(coef, dtype=np.float64).reshape(1, 3)
    clf.intercept_ = np.array([intercept], dtype=np.float64)
    clf.t_ = float(t)
    return clf


def _negative_intercept_seed():
    for seed in range(50):
        st = simulation.initial_state(scenario_config(n_uavs=2, seed=seed))
        if st.fleet.intercept[0] < 0:
            return seed
    raise AssertionError("no seed with a negative intercept")


def test_learning_happens_on_landing_after_a_delivery():
    # UAV 0's own initial policy; its SoC is set so that f = 0.5 on a (3500 m, 2.75 kg) order:
    # it bids, delivers, and on landing takes one partial_fit step on the quadratic branch.
    seed = _negative_intercept_seed()
    c = scenario_config(n_uavs=2, seed=seed)
    st = scenario(c, [0.0], [3500.0], [2.75])
    w0, b0, t0 = st.fleet.coef[0].copy(), float(st.fleet.intercept[0]), float(st.fleet.steps[0])
    assert t0 == 15.0 and b0 < 0 and w0[2] > 0
    soc = MU[2] + SIGMA[2] * (0.5 - b0) / w0[2]
    assert 0 < soc < 100
    st.fleet.soc_ref[0] = soc
    st.fleet.coef[1], st.fleet.intercept[1] = NEVER
    leg = 350.0
    assert leg * rate(2.75) < 0.5 * soc and soc - leg * (rate(2.75) + rate(0.0)) > 0  # it delivers
    simulation.advance(st, 2 * leg - 1.0)
    assert st.counters[engine.N_DELIVERED] == 1
    np.testing.assert_array_equal(st.fleet.coef[0], w0)  # nothing learnt before landing
    assert st.fleet.steps[0] == t0 and st.fleet.intercept[0] == b0
    simulation.advance(st, 2 * leg + 1.0)
    clf = _sgd(w0, b0, t0)
    x = np.array([x_std(3500.0, 2.75, float(st.attempts.takeoff_soc[0]))])
    assert clf.decision_function(x)[0] == pytest.approx(0.5, abs=1e-9)
    clf.partial_fit(x, [1])
    np.testing.assert_allclose(st.fleet.coef[0], clf.coef_[0], rtol=1e-12, atol=1e-15)
    assert st.fleet.intercept[0] == pytest.approx(clf.intercept_[0], rel=1e-12, abs=1e-15)
    assert st.fleet.steps[0] == clf.t_ == t0 + 1
    assert st.fleet.intercept[0] != b0  # a real update (not only the L2 shrink)


def test_learning_after_an_abort():
    w0, b0 = (0.3, -0.2, 1.0), 2.0
    c = scenario_config()
    st = scenario(c, [0.0], [6000.0], [5.0], policies=(w0, b0), soc=30.0)
    t_land = 2 * 0.5 * 30.0 / rate(5.0)
    simulation.advance(st, t_land + 0.5)
    a = st.attempts
    assert a.outcome[0] == engine.OUTCOME_ABORTED and a.return_s[0] == pytest.approx(t_land, rel=1e-12)
    clf = _sgd(w0, b0, 15.0)
    clf.partial_fit(np.array([x_std(6000.0, 5.0, 30.0)]), [0])
    np.testing.assert_allclose(st.fleet.coef[0], clf.coef_[0], rtol=1e-12)
    assert st.fleet.intercept[0] == pytest.approx(clf.intercept_[0], rel=1e-12)
    assert st.fleet.steps[0] == 16.0


# ============================================================================ whole runs


def _check_run_against_model(r, c):
    """Every attempt of a run against the closed forms of docs/delivery-model.md sections 2 and 3."""
    a, o = r.attempts, r.orders
    soh = r.snapshots[-1]["soh"]
    horizon = c.horizon_s
    last = {}  # uav -> (return_s, return_soc)
    for row in range(a["uav"].shape[0]):
        i, j = int(a["uav"][row]), int(a["order"][row])
        t0, s0 = float(a["takeoff_s"][row]), float(a["takeoff_soc"][row])
        assert t0 % DELTA == 0.0 and t0 >= o["arrival_s"][j]
        if i in last:
            ret, land = last[i]
            assert ret <= t0
            assert s0 == pytest.approx(charged(land, t0 - ret), rel=1e-9, abs=1e-9)
        else:
            assert s0 == 100.0
        leg, rl, re = o["distance_m"][j] / SPEED, rate(o["mass_kg"][j], soh[i]), rate(0.0, soh[i])
        if leg * rl < (1 - c.xi) * s0:
            out, turn_soc, r_home, home = leg, s0 - leg * rl, re, leg
            outcome = engine.OUTCOME_DELIVERED
        else:
            out = (1 - c.xi) * s0 / rl
            turn_soc, r_home, home = c.xi * s0, rl, out
            outcome = engine.OUTCOME_ABORTED
        land = turn_soc - home * r_home
        lost = land < -1e-6
        if lost:
            home = turn_soc / r_home
        if t0 + out <= horizon:
            assert a["outcome"][row] == outcome
            assert a["turn_s"][row] == pytest.approx(t0 + out, rel=1e-12)
            if outcome == engine.OUTCOME_DELIVERED:
                assert o["delivered_s"][j] == a["turn_s"][row]
        if t0 + out + home <= horizon:
            assert a["return_s"][row] == pytest.approx(t0 + out + home, rel=1e-12)
            assert bool(a["lost"][row]) == lost
            if not lost:
                assert a["return_soc"][row] == pytest.approx(max(land, 0.0), rel=1e-9, abs=1e-9)
                last[i] = (float(a["return_s"][row]), float(a["return_soc"][row]))
            else:
                last[i] = (np.inf, np.nan)
        else:
            last[i] = (np.inf, np.nan)


@pytest.mark.parametrize("xi,n_uavs,rule", [(0.5, 25, "least_confident"), (0.5, 10, "threshold"),
                                            (0.3, 25, "most_confident"), (0.6, 12, "random")])
def test_whole_run_obeys_the_closed_forms(xi, n_uavs, rule):
    c = cfg.replace(cfg.default_config(), horizon_weeks=1.0, xi=xi, n_uavs=n_uavs, rule=rule, theta=90.0, seed=11)
    r = simulation.simulate(c)
    assert r.attempts["uav"].shape[0] > 40
    _check_run_against_model(r, c)
    a, o, s = r.attempts, r.orders, r.series
    if xi < 0.5:
        assert a["lost"].any()
    # The time series from the attempt table (state after every event at the sample instant).
    turned = a["outcome"] != engine.IN_FLIGHT
    for k, t in enumerate(s["t_s"]):
        up = (a["takeoff_s"] <= t) & ~(a["return_s"] <= t)
        carrying = up & ~((a["outcome"] == engine.OUTCOME_DELIVERED) & (a["turn_s"] <= t))
        lost = int(((a["return_s"] <= t) & a["lost"]).sum())
        delivered = int((o["delivered_s"] <= t).sum())
        assert s["delivered"][k] == delivered
        assert s["in_flight"][k] == int(up.sum())
        assert s["lost"][k] == lost
        assert s["idle"][k] == n_uavs - int(up.sum()) - lost
        assert s["aborted"][k] == int((turned & (a["outcome"] == engine.OUTCOME_ABORTED) & (a["turn_s"] <= t)).sum())
        assert s["unallocated"][k] == int((o["arrival_s"] <= t).sum()) - delivered - int(carrying.sum())


# ============================================================================ tick skip


SKIP_CASES = [("least_confident", 25, 0), ("least_confident", 5, 1), ("most_confident", 25, 0),
              ("most_confident", 6, 1), ("random", 25, 0), ("random", 5, 1), ("threshold", 25, 0),
              ("threshold", 8, 1)]


@pytest.mark.parametrize("rule,n_uavs,seed", SKIP_CASES)
def test_tick_skip_is_exact(rule, n_uavs, seed, every_tick_rules):
    base = cfg.replace(cfg.default_config(), horizon_weeks=1.0, tau_minutes=15.0, n_uavs=n_uavs, seed=seed,
                       theta=80.0, rule=rule)
    skipped = delivery_records.tables(simulation.simulate(base))
    every = delivery_records.tables(simulation.simulate(cfg.replace(base, rule=every_tick_rules[rule])))
    for name in ("orders", "attempts", "fleet", "timeseries"):
        assert skipped[name].equals(every[name]), name
    ms, me = skipped["summary"].to_pylist()[0], every["summary"].to_pylist()[0]
    ms.pop("rule"), me.pop("rule")
    assert str(ms) == str(me)  # nan-safe
    assert skipped["attempts"].num_rows > 50


# Drawn here: rule, fleet size, load, threshold, charging speed (fast charging moves the base time
# of the skip's u = e^{k (t - base)} several times a run), tick interval, and the UAVs whose SoC
# weight is turned negative (their bid window closes as they charge) or set to 0.
RANDOM_SKIP_CASES = 10


@pytest.mark.parametrize("case", range(RANDOM_SKIP_CASES))
def test_tick_skip_is_exact_on_random_runs(case, every_tick_rules):
    rng = np.random.default_rng(1000 + case)
    rule = ("least_confident", "most_confident", "random", "reservation", "threshold")[case % 5]
    base = cfg.replace(cfg.default_config(), horizon_weeks=float(rng.choice([1.0, 2.0])) / 7, seed=case,
                       n_uavs=int(rng.integers(2, 30)), tau_minutes=float(rng.choice([3.0, 10.0, 30.0])),
                       theta=float(rng.choice([50.0, 90.0, 100.0])), rule=rule,
                       charger_power_w=float(rng.choice([100.0, 3000.0, 30000.0])),
                       advert_interval_s=float(rng.choice([0.5, 2.0, 30.0])))
    flipped = rng.random(base.n_uavs) < 0.3
    zeroed = rng.random(base.n_uavs) < 0.1
    results, states = [], []
    for config in (base, cfg.replace(base, rule=every_tick_rules[rule])):
        state = simulation.initial_state(config)
        state.fleet.coef[flipped, 2] *= -1.0
        state.fleet.coef[zeroed, 2] = 0.0
        results.append(delivery_records.tables(run_state(state, config)))
        states.append(state)
    skipped, every = results
    for name in ("orders", "attempts", "fleet", "timeseries"):
        assert skipped[name].equals(every[name]), name
    assert states[0].counters[engine.N_AUCTIONS] == states[1].counters[engine.N_AUCTIONS]
    assert skipped["attempts"].num_rows > 0


def test_random_skip_cases_move_the_base_time():
    """The fast-charging cases above run long enough for u's base time to move (REBASE_EXPONENT)."""
    config = cfg.replace(cfg.default_config(), horizon_weeks=1.0 / 7, n_uavs=5, charger_power_w=30000.0)
    state = simulation.initial_state(config)
    simulation.advance(state, config.horizon_s)
    assert state.fleet.charge_base[0] > 0.0
    assert state.params.charge_rate * config.horizon_s > 2 * engine.REBASE_EXPONENT


# ============================================================================ determinism


def test_same_seed_gives_byte_identical_files(tmp_path):
    c = cfg.replace(cfg.default_config(), horizon_weeks=1.0, seed=7)
    paths1 = delivery_records.write_run(simulation.simulate(c), tmp_path / "a")
    paths2 = delivery_records.write_run(simulation.simulate(c), tmp_path / "b")
    paths3 = delivery_records.write_run(simulation.simulate(cfg.replace(c, seed=8)), tmp_path / "c")
    assert set(paths1) == set(delivery_records.TABLES)
    for name in delivery_records.TABLES:
        assert paths1[name].read_bytes() == paths2[name].read_bytes(), name
    for name in ("orders", "attempts", "fleet", "timeseries"):
        assert paths1[name].read_bytes() != paths3[name].read_bytes(), name


# ============================================================================ half run


@pytest.mark.parametrize("phase", ["outbound", "returning"])
def test_a_run_is_a_prefix_of_a_longer_run(phase):
    """A run stopped while a UAV is in the air equals the start of a longer run.

    The split instant is taken from the long run itself, in the middle of a flight's
    outbound (or return) leg in week 4, so a flight spans it on every machine.
    """
    base = cfg.replace(cfg.default_config(), n_uavs=25, seed=0)
    long = simulation.simulate(cfg.replace(base, horizon_weeks=6.0))
    la = long.attempts
    j = int(np.flatnonzero(la["takeoff_s"] > 3.5 * WEEK)[0])
    start, end = (la["takeoff_s"][j], la["turn_s"][j]) if phase == "outbound" else (la["turn_s"][j], la["return_s"][j])
    short = simulation.simulate(cfg.replace(base, horizon_weeks=(start + end) / 2.0 / WEEK))
    half = short.config.horizon_s
    assert start < half < end and half > 3 * WEEK
    # Orders that arrived before the split.
    n = short.orders["arrival_s"].shape[0]
    assert long.orders["arrival_s"][n - 1] < half <= long.orders["arrival_s"][n]
    for key in ("arrival_s", "distance_m", "mass_kg"):
        np.testing.assert_array_equal(short.orders[key], long.orders[key][:n])
    d_short, d_long = short.orders["delivered_s"], long.orders["delivered_s"][:n]
    np.testing.assert_array_equal(d_short, np.where(d_long <= half, d_long, np.nan))
    # Attempts that took off by the split.
    sa = short.attempts
    m = sa["uav"].shape[0]
    assert (la["takeoff_s"][:m] <= half).all() and (m == la["uav"].shape[0] or la["takeoff_s"][m] > half)
    for key in ("uav", "order", "takeoff_s", "takeoff_soc"):
        np.testing.assert_array_equal(sa[key], la[key][:m])
    turned = la["turn_s"][:m] <= half
    np.testing.assert_array_equal(sa["outcome"], np.where(turned, la["outcome"][:m], engine.IN_FLIGHT))
    np.testing.assert_array_equal(sa["turn_s"], np.where(turned, la["turn_s"][:m], np.nan))
    back = la["return_s"][:m] <= half
    for key in ("return_s", "return_soc"):
        np.testing.assert_array_equal(sa[key], np.where(back, la[key][:m], np.nan))
    np.testing.assert_array_equal(sa["lost"], la["lost"][:m] & back)
    assert not back[j] and turned[j] == (phase == "returning")
    # Fleet at the end of weeks 1-3, time series up to the split.
    ts, tl = delivery_records.tables(short), delivery_records.tables(long)
    weeks = [pa.compute.less_equal(t["fleet"]["week"], 3) for t in (ts, tl)]
    fleet_short, fleet_long = ts["fleet"].filter(weeks[0]), tl["fleet"].filter(weeks[1])
    assert fleet_short.num_rows == 3 * 25
    assert fleet_short.equals(fleet_long)
    k = ts["timeseries"].num_rows
    assert tl["timeseries"]["t_s"][k - 1].as_py() <= half < tl["timeseries"]["t_s"][k].as_py()
    assert ts["timeseries"].equals(tl["timeseries"].slice(0, k))
