"""Reservation bids (docs/delivery-model.md section 9) and saved fleets (warm starts).

Hand-made scenarios check the rules against closed forms computed here; whole runs from a
saved fleet are checked against an independent replay of the policies from the tables.
"""

import math

import numpy as np
import pyarrow.parquet as pq
import pytest

from conftest import K, MU, SIGMA, run_state, scenario, scenario_config, x_std
from dronefleet import cli
from dronefleet.delivery import config as cfg
from dronefleet.delivery import engine, fleet as fleetfile, simulation, records as delivery_records
from dronefleet.delivery.metrics import run_metrics
from dronefleet.delivery.orders import generate_orders
from dronefleet.delivery.policy import optimal_init, sgd_step

STATE_RESERVED = 3  # the supervisor's state after wonBid (S0 -capableTask-> 1 -bid-> 2 -wonBid-> 3)


def soc_policy(need_soc, w_distance=0.0, distance=3500.0):
    """A policy that bids on an order at ``distance`` iff SoC >= ``need_soc`` (f grows with SoC)."""
    x_d = (distance - MU[0]) / SIGMA[0]
    return (w_distance, 0.0, 1.0), -(need_soc - MU[2]) / SIGMA[2] - w_distance * x_d


def decision(policy, d, m, soc):
    (w0, w1, w2), b = policy
    x0, x1, x2 = x_std(d, m, soc)
    return w0 * x0 + w1 * x1 + w2 * x2 + b


def crossing_time(soc0, target):
    """When the charging curve from ``soc0`` reaches ``target``, in closed form."""
    return math.log((100.0 - soc0) / (100.0 - target)) / K


def reservation_config(n_uavs=1, horizon_s=24 * 3600.0, **changes):
    return scenario_config(n_uavs=n_uavs, horizon_s=horizon_s, rule="reservation", **changes)


# ---------------------------------------------------------------------------- the rule


@pytest.mark.parametrize("soc0,need", [(40.0, 80.0), (10.0, 99.0), (75.0, 75.5)])
def test_reserved_takeoff_is_the_analytic_crossing_and_the_policy_says_bid(soc0, need):
    c = reservation_config(horizon_s=2 * 24 * 3600.0)
    policy = soc_policy(need)
    st = scenario(c, [0.0], [3500.0], [2.0], policies=policy, soc=soc0)
    r = run_state(st, c)
    a = r.attempts
    assert a["uav"].shape[0] == 1
    expected = crossing_time(soc0, need)
    assert a["allocated_s"][0] == 0.0
    assert a["takeoff_s"][0] == pytest.approx(expected, abs=1e-9)
    assert a["forecast_wait_s"][0] == pytest.approx(expected, abs=1e-9)
    assert a["takeoff_soc"][0] == pytest.approx(need, abs=1e-9)
    assert decision(policy, 3500.0, 2.0, a["takeoff_soc"][0]) >= 0.0
    assert r.reservations == 1
    m = run_metrics(r)
    assert (m["reservations_won"], m["forecast_met_pct"]) == (1, 100.0)  # 2 kg over 3.5 km: delivered
    assert m["median_reservation_wait_s"] == pytest.approx(expected, abs=1e-9)
    # The time series: reserved (at the FC, not idle, not in flight) until takeoff.
    s = r.series
    waiting = s["t_s"] < a["takeoff_s"][0]
    flying = (s["t_s"] >= a["takeoff_s"][0]) & (s["t_s"] < a["return_s"][0])
    assert waiting.sum() >= 1  # the sample at t = 0
    assert s["reserved"].tolist() == waiting.astype(int).tolist()
    assert s["in_flight"].tolist() == flying.astype(int).tolist()
    assert (s["idle"] == 1 - waiting - flying).all()


def test_no_reservation_when_the_needed_soc_is_out_of_reach_or_f_falls_with_soc():
    c = reservation_config(n_uavs=2)
    out_of_reach = soc_policy(100.0 + 1e-6)
    falls = ((0.0, 0.0, -1.0), -1.0)  # f = -x_soc - 1 < 0 from SoC 21 up
    st = scenario(c, [0.0], [3500.0], [2.0], policies=[out_of_reach, falls], soc=50.0)
    r = run_state(st, c)
    assert r.attempts["uav"].shape[0] == 0 and r.reservations == 0
    assert r.auctions == c.horizon_s / 2.0 + 1  # advertised at every tick, nobody bids


def test_an_immediate_bid_beats_any_reservation():
    # UAV 1 would reserve with a wait of ~0 (it needs 50.0001 % at 50 %); UAV 0 bids now.
    c = reservation_config(n_uavs=2)
    st = scenario(c, [0.0], [3500.0], [2.0], policies=[soc_policy(30.0), soc_policy(50.0001)], soc=50.0)
    r = run_state(st, c, t_stop=10.0)
    assert r.attempts["uav"].tolist() == [0]
    assert math.isnan(r.attempts["forecast_wait_s"][0]) and r.reservations == 0
    assert st.fleet.mode.tolist() == [engine.OUTBOUND, engine.IDLE]


@pytest.mark.parametrize("socs,winner", [((60.0, 60.0), 1), ((70.0, 60.0), 0), ((60.0, 70.0), 1)])
def test_the_lowest_reservation_bid_wins_ties_to_the_highest_id(socs, winner):
    c = reservation_config(n_uavs=2)
    st = scenario(c, [0.0], [3500.0], [2.0], policies=soc_policy(90.0))
    st.fleet.soc_ref[:] = socs
    simulation.advance(st, 0.0)
    assert st.fleet.mode[winner] == engine.RESERVED and st.fleet.mode[1 - winner] == engine.IDLE
    assert st.fleet.next_s[winner] == pytest.approx(crossing_time(socs[winner], 90.0), abs=1e-9)
    assert st.fleet.sup[winner].tolist() == [STATE_RESERVED]
    assert st.fleet.sup[1 - winner].tolist() == [0]  # lost its bid: back to waiting


def test_a_reserved_uav_takes_no_part_in_other_auctions_and_its_order_is_not_advertised():
    # UAV 0 reserves the long order 0 at t = 0. Order 1 (short) arrives at 10 s: UAV 0's policy
    # says "bid now" to it, yet it must wait until UAV 0 is back from order 0.
    c = reservation_config(n_uavs=1)
    policy = ((-0.5, 0.0, 1.0), 0.0)
    d0, d1 = 6000.0, 1000.0
    assert decision(policy, d0, 1.0, 40.0) < 0.0 < decision(policy, d1, 1.0, 40.0)
    st = scenario(c, [0.0, 10.0], [d0, d1], [1.0, 1.0], policies=policy, soc=40.0)
    simulation.advance(st, 5000.0)
    assert st.fleet.mode[0] == engine.RESERVED
    assert st.counters[engine.QUEUE_LEN] == 1 and engine.queued_at(st.book.queue_tree, 0) == 1  # order 0 is out of the queue
    assert st.counters[engine.N_AUCTIONS] == 1  # nobody idle: advertising is suspended
    r = run_state(st, c)
    a = r.attempts
    assert a["order"].tolist()[:2] == [0, 1]
    need = MU[2] + SIGMA[2] * 0.5 * (d0 - MU[0]) / SIGMA[0]
    assert a["takeoff_s"][0] == pytest.approx(crossing_time(40.0, need), abs=1e-9)
    # Order 1 is allocated at the first tick after the landing (reserved, as the UAV lands low).
    assert a["allocated_s"][1] == math.ceil(a["return_s"][0] / 2.0) * 2.0


def test_a_reserved_uav_is_out_of_auctions_that_go_on_for_the_others():
    # As above, with UAV 1 idle and never bidding: order 1 is advertised all along, and UAV 0,
    # whose policy says "bid now" to it, takes no part until it is back from order 0.
    c = reservation_config(n_uavs=2)
    policy = ((-0.5, 0.0, 1.0), 0.0)
    never = ((0.0, 0.0, 1.0), -1e3)
    st = scenario(c, [0.0, 10.0], [6000.0, 1000.0], [1.0, 1.0], policies=[policy, never], soc=40.0)
    simulation.advance(st, 5000.0)
    assert st.fleet.mode.tolist() == [engine.RESERVED, engine.IDLE]
    assert st.counters[engine.N_AUCTIONS] == 1 + 2496  # order 0 at t = 0, then order 1 at 10, 12, .., 5000
    r = run_state(st, c)
    a = r.attempts
    assert a["uav"].tolist()[:2] == [0, 0] and a["order"].tolist()[:2] == [0, 1]
    assert a["allocated_s"][1] == math.ceil(a["return_s"][0] / 2.0) * 2.0


@pytest.mark.parametrize("base,winner", [("least_confident", 0), ("most_confident", 1)])
def test_immediate_bids_are_resolved_by_the_base_rule(base, winner):
    # Both bid now; UAV 0 is the less confident.
    c = reservation_config(n_uavs=2, base_rule=base)
    st = scenario(c, [0.0], [3500.0], [2.0], policies=[((0.0, 0.0, 1.0), 1.0), ((0.0, 0.0, 1.0), 3.0)], soc=50.0)
    r = run_state(st, c, t_stop=0.0)
    assert r.attempts["uav"].tolist() == [winner] and r.reservations == 0


@pytest.mark.parametrize("seed", range(4))
def test_reservation_with_the_random_base_rule_draws_like_the_random_rule(seed):
    # With immediate bidders only, reservation(random) is the random rule: same draws, same winners.
    policies = [((0.0, 0.0, 1.0), 1.0 + i) for i in range(4)]
    winners = []
    for rule in ("random", "reservation"):
        c = scenario_config(n_uavs=4, horizon_s=600.0, rule=rule, base_rule="random", seed=seed)
        st = scenario(c, [0.0, 0.0, 0.0], [1000.0] * 3, [1.0] * 3, policies=policies)
        winners.append(run_state(st, c).attempts["uav"].tolist())
    assert winners[0] == winners[1] and len(winners[0]) == 3


def test_an_aborted_reserved_order_is_advertised_again_once_its_parcel_is_back():
    # SoH 0.5 and the policy of a healthy UAV: the reserved flight of 6 km with 5 kg aborts, and
    # what the UAV learns from it keeps it from bidding again.
    c = reservation_config(n_uavs=1, horizon_s=3 * 24 * 3600.0)
    policy = soc_policy(60.0, distance=6000.0)
    st = scenario(c, [0.0], [6000.0], [5.0], soh=[0.5], policies=policy, soc=30.0)
    r = run_state(st, c)
    a = r.attempts
    assert a["uav"].shape[0] == 1 and a["outcome"][0] == engine.OUTCOME_ABORTED
    # Advertised once at t = 0, then at every tick from the landing on.
    assert r.auctions == 1 + (c.horizon_s / 2.0 - math.ceil(a["return_s"][0] / 2.0) + 1)
    assert st.counters[engine.QUEUE_LEN] == 1 and engine.queued_at(st.book.queue_tree, 0) == 0
    t = delivery_records.tables(r)["attempts"].to_pydict()
    assert t["reserved"] == [True] and t["forecast_met"] == [False]
    m = run_metrics(r)
    assert (m["reservations_won"], m["forecast_met_pct"]) == (1, 0.0)
    assert t["wait_s"][0] == pytest.approx(crossing_time(30.0, 60.0), abs=1e-9)


def test_supervisor_state_matches_mode_in_a_reservation_run(saved_fleet):
    c = cfg.replace(saved_fleet.config, rule="reservation", fleet_file=str(saved_fleet.path), horizon_weeks=1.0)
    st = simulation.initial_state(c)
    sup_of_mode = {engine.IDLE: 0, engine.RESERVED: STATE_RESERVED, engine.OUTBOUND: 4, engine.RETURNING: 5}
    seen = set()
    for t in np.linspace(0.0, c.horizon_s, 57)[1:]:
        simulation.advance(st, t)
        for i, mode in enumerate(st.fleet.mode.tolist()):
            seen.add(mode)
            assert st.fleet.sup[i].tolist() == [sup_of_mode[mode]], (t, i)
    assert engine.RESERVED in seen


# ---------------------------------------------------------------------------- saved fleets


@pytest.fixture(scope="module")
def saved_fleet(tmp_path_factory):
    """A fleet that learned for 2 weeks (10 UAVs), saved; its run and path."""
    c = cfg.replace(cfg.default_config(), horizon_weeks=2.0, n_uavs=10, seed=3)
    result = simulation.simulate(c)
    path = tmp_path_factory.mktemp("fleet") / "fleet.parquet"
    fleetfile.save_fleet(result, path)
    result.path = path
    return result


def test_save_then_load_gives_identical_policies_soh_and_soc(saved_fleet):
    final = saved_fleet.snapshots[-1]
    loaded = fleetfile.load_fleet(saved_fleet.path, saved_fleet.config)
    assert loaded.coef.tobytes() == final["coef"].tobytes()
    assert loaded.intercept.tobytes() == final["intercept"].tobytes()
    assert loaded.steps.tobytes() == final["steps"].tobytes()
    assert loaded.soh.tobytes() == final["soh"].tobytes()
    assert loaded.soc.tobytes() == final["soc"].tobytes()
    assert loaded.lost.tolist() == final["lost"].tolist() and loaded.period == 1
    assert delivery_records.read_config(saved_fleet.path) == saved_fleet.config
    assert pq.read_table(saved_fleet.path).num_rows == 10


def test_a_run_fleet_table_is_a_fleet_file_too(saved_fleet, tmp_path):
    paths = delivery_records.write_run(saved_fleet, tmp_path)
    from_table = fleetfile.load_fleet(paths["fleet"], saved_fleet.config)
    saved = fleetfile.load_fleet(saved_fleet.path, saved_fleet.config)
    for field in ("soh", "coef", "intercept", "steps", "soc", "lost"):
        assert np.array_equal(getattr(from_table, field), getattr(saved, field)), field


def test_a_warm_start_starts_from_the_fleet_with_an_empty_queue_and_fresh_orders(saved_fleet):
    c = cfg.replace(saved_fleet.config, fleet_file=str(saved_fleet.path))
    st = simulation.initial_state(c)
    final = saved_fleet.snapshots[-1]
    assert st.fleet.coef.tobytes() == final["coef"].tobytes()
    assert st.fleet.soc_ref.tobytes() == final["soc"].tobytes() and st.fleet.t_ref.tolist() == [0.0] * 10
    assert st.counters[engine.QUEUE_LEN] == 0 and st.counters[engine.N_IDLE] == 10
    assert st.period == 2
    assert st.book.arrival_s[0] == 0.0  # a new order stream, from t = 0
    assert not np.array_equal(st.book.distance_m[:20], saved_fleet.orders["distance_m"][:20])
    # The same seed's third period differs from its second.
    r2 = simulation.simulate(cfg.replace(c, horizon_weeks=0.5))
    path = saved_fleet.path.with_name("period2.parquet")
    fleetfile.save_fleet(r2, path)
    st3 = simulation.initial_state(cfg.replace(c, fleet_file=str(path)))
    assert st3.period == 3 and not np.array_equal(st3.book.distance_m[:20], st.book.distance_m[:20])


def test_a_warm_start_without_reservations_is_a_plain_run_from_that_fleet(saved_fleet):
    # The same fleet put in place by hand in a new run of period 2 gives the same tables.
    c = cfg.replace(saved_fleet.config, fleet_file=str(saved_fleet.path))
    warm = delivery_records.tables(simulation.simulate(c))
    final = saved_fleet.snapshots[-1]
    plain = saved_fleet.config
    rngs = np.random.SeedSequence(c.seed, spawn_key=(simulation.PERIOD_STREAMS, 2)).spawn(4)
    orders = generate_orders(plain, np.random.default_rng(rngs[0]))
    st = simulation.initial_state(plain, orders=orders, soh=final["soh"])
    st.bid_rng = np.random.default_rng(rngs[3])
    st.fleet.coef[:] = final["coef"]
    st.fleet.intercept[:] = final["intercept"]
    st.fleet.steps[:] = final["steps"]
    st.fleet.soc_ref[:] = final["soc"]
    st.period = 2
    snapshots = []
    for t in simulation.stops(plain.horizon_s):
        simulation.advance(st, t)
        snapshots.append(simulation.snapshot(st, t))
    by_hand = delivery_records.tables(simulation.collect(st, snapshots, plain))
    for name in ("orders", "attempts", "fleet", "timeseries"):
        assert warm[name].equals(by_hand[name]), name
    assert str(warm["summary"].to_pylist()) == str(by_hand["summary"].to_pylist())  # nan-safe


@pytest.mark.parametrize("key,value", [("n_uavs", 9), ("scaler_mean", (3000.0, 2.75, 50.0)),
                                       ("scaler_std", (1000.0, 1.298, 28.87))])
def test_a_fleet_saved_under_another_size_or_scaling_is_refused(saved_fleet, key, value):
    c = cfg.replace(saved_fleet.config, **{key: value, "fleet_file": str(saved_fleet.path)})
    with pytest.raises(fleetfile.FleetFileError, match=rf"saved with {key} = .* this run has {key} = .*must agree"):
        simulation.initial_state(c)


def test_a_missing_or_foreign_fleet_file_is_refused(saved_fleet, tmp_path):
    with pytest.raises(fleetfile.FleetFileError, match="no such file"):
        fleetfile.load_fleet(tmp_path / "nope.parquet", saved_fleet.config)
    paths = delivery_records.write_run(saved_fleet, tmp_path)
    with pytest.raises(fleetfile.FleetFileError, match="lacks the fleet column"):
        fleetfile.load_fleet(paths["orders"], saved_fleet.config)


def test_fleet_file_seed_placeholder(saved_fleet, tmp_path):
    fleetfile.save_fleet(saved_fleet, tmp_path / "seed=3.parquet")
    c = cfg.replace(saved_fleet.config, fleet_file=str(tmp_path / "seed={seed}.parquet"))
    assert simulation.initial_state(c).period == 2
    with pytest.raises(fleetfile.FleetFileError, match="seed=4.parquet"):
        simulation.initial_state(cfg.replace(c, seed=4))


def test_cli_saves_and_starts_from_a_fleet_with_the_seed_in_its_name(tmp_path, capsys):
    common = ["--set", "horizon_weeks=0.1", "--set", "n_uavs=5", "--seed", "3"]
    pattern = str(tmp_path / "fleet-{seed}.parquet")
    assert cli.main(["run", *common, "--out", str(tmp_path / "a"), "--save-fleet", pattern]) == 0
    assert (tmp_path / "fleet-3.parquet").is_file()
    assert cli.main(["run", *common, "--out", str(tmp_path / "b"), "--fleet", pattern,
                     "--set", "rule=reservation"]) == 0
    summary = pq.read_table(tmp_path / "b" / "summary.parquet").to_pylist()[0]
    assert (summary["period"], summary["rule"]) == (2, "reservation")
    assert delivery_records.read_config(tmp_path / "b" / "summary.parquet").fleet_file == pattern
    capsys.readouterr()
    assert cli.main(["run", "--set", "n_uavs=6", "--seed", "3", "--fleet", pattern]) == 2
    assert "saved with n_uavs = 5, but this run has n_uavs = 6" in capsys.readouterr().err


def test_lost_uavs_stay_lost_in_a_warm_start(tmp_path):
    c = cfg.replace(cfg.default_config(), horizon_weeks=0.01, n_uavs=10, xi=0.3, seed=5)  # 4 of 10 lost
    result = simulation.simulate(c)
    lost = result.snapshots[-1]["lost"]
    assert 0 < lost.sum() < 10
    fleetfile.save_fleet(result, tmp_path / "fleet.parquet")
    warm = cfg.replace(c, fleet_file=str(tmp_path / "fleet.parquet"), xi=0.5, horizon_weeks=0.5)
    st = simulation.initial_state(warm)
    assert st.fleet.mode.tolist() == [engine.LOST if x else engine.IDLE for x in lost]
    assert st.counters[engine.N_IDLE] == 10 - lost.sum() and st.counters[engine.N_LOST] == lost.sum()
    r = run_state(st, warm)
    assert not np.isin(r.attempts["uav"], np.flatnonzero(lost)).any()
    assert r.snapshots[-1]["lost"].tolist() == lost.tolist()


# ---------------------------------------------------------------------------- whole runs, replayed


def _replay_policies(fleet0, attempts, orders, config):
    """Every UAV's policy after each landing, replayed from the attempt table (docs/delivery-model.md section 8).

    Returns, per UAV, a list of (time it took effect, coef, intercept), from t = 0.
    """
    coef, intercept, steps = fleet0.coef.copy(), fleet0.intercept.copy(), fleet0.steps.copy()
    history = [[(0.0, coef[i].copy(), intercept[i])] for i in range(coef.shape[0])]
    a = attempts
    landed = np.flatnonzero(~np.isnan(a["return_s"]) & ~a["lost"])
    mean, std = np.array(config.scaler_mean), np.array(config.scaler_std)
    for row in landed[np.argsort(a["return_s"][landed], kind="stable")]:
        i, order = int(a["uav"][row]), int(a["order"][row])
        x = (np.array([orders["distance_m"][order], orders["mass_kg"][order], a["takeoff_soc"][row]]) - mean) / std
        sgd_step(coef, intercept, steps, i, x[0], x[1], x[2],
                 1.0 if a["outcome"][row] == engine.OUTCOME_DELIVERED else 0.0,
                 config.alpha, optimal_init(config.alpha))
        history[i].append((a["return_s"][row], coef[i].copy(), intercept[i]))
    return history


def test_whole_warm_run_reservations_obey_the_rules(saved_fleet):
    c = cfg.replace(saved_fleet.config, rule="reservation", fleet_file=str(saved_fleet.path), horizon_weeks=2.0)
    st = simulation.initial_state(c)
    r = run_state(st, c)
    a, o = r.attempts, r.orders
    # Reservations still waiting at the horizon have no attempt row yet.
    waiting_since = np.where(st.fleet.mode == engine.RESERVED, st.fleet.allocated_s, np.inf)
    fleet0 = fleetfile.load_fleet(saved_fleet.path, c)
    history = _replay_policies(fleet0, a, o, c)
    reserved = ~np.isnan(a["forecast_wait_s"])
    assert reserved.sum() > 20 and (~reserved).sum() > 5
    # A reserved UAV is committed from allocation to landing and bids nowhere else meanwhile.
    for i in range(c.n_uavs):
        mine = np.flatnonzero(a["uav"] == i)
        ends = np.where(np.isnan(a["return_s"][mine]), np.inf, a["return_s"][mine])
        assert np.all(a["allocated_s"][mine][1:] >= ends[:-1]), i
    # Takeoff at the forecast instant with a policy that says "bid".
    rows = np.flatnonzero(reserved)
    # Up to a few units in the last place of the takeoff instant: _reserved_takeoff moves it on by
    # 1, 2, 4 ... ulps until the policy says "bid" (near SoC 100 one ulp of SoC is ~1e-9 s).
    late = a["takeoff_s"][rows] - a["allocated_s"][rows] - a["forecast_wait_s"][rows]
    assert np.all(np.abs(late) <= 64 * np.spacing(a["takeoff_s"][rows]))

    def policy_at(i, t):
        effective = [h for h in history[i] if h[0] <= t]
        return effective[-1][1], effective[-1][2]

    def f(i, order, soc, t):
        w, b = policy_at(i, t)
        x = (np.array([o["distance_m"][order], o["mass_kg"][order], soc]) - np.array(c.scaler_mean)) / np.array(c.scaler_std)
        return float(w @ x + b)

    for row in rows:
        # The engine guarantees f >= 0 in its own operation order; numpy's dot rounds differently.
        i, order = int(a["uav"][row]), int(a["order"][row])
        assert 0.0 <= f(i, order, a["takeoff_soc"][row], a["takeoff_s"][row]) + 1e-12 < 1e-6
    # No reservation won an auction at which an idle UAV bid immediately.
    for row in rows:
        t, order = a["allocated_s"][row], int(a["order"][row])
        for i in range(c.n_uavs):
            mine = np.flatnonzero(a["uav"] == i)
            busy = (a["allocated_s"][mine] <= t) & ~(a["return_s"][mine] <= t)
            gone = a["lost"][mine] & (a["return_s"][mine] <= t)
            if busy.any() or gone.any() or waiting_since[i] <= t or fleet0.lost[i]:
                continue
            before = mine[a["return_s"][mine] <= t]
            if before.size:
                last = before[np.argmax(a["return_s"][before])]
                soc = 100.0 - (100.0 - a["return_soc"][last]) * math.exp(-K * (t - a["return_s"][last]))
            else:
                soc = 100.0 - (100.0 - fleet0.soc[i]) * math.exp(-K * t)
            assert f(i, order, soc, t) < 1e-9, (row, i)


def test_reservation_runs_are_deterministic_and_the_tick_skip_is_exact(saved_fleet, every_tick_rules):
    c = cfg.replace(saved_fleet.config, rule="reservation", fleet_file=str(saved_fleet.path), horizon_weeks=1.0)
    skipped = delivery_records.tables(simulation.simulate(c))
    again = delivery_records.tables(simulation.simulate(c))
    every = delivery_records.tables(simulation.simulate(cfg.replace(c, rule=every_tick_rules["reservation"])))
    for name in ("orders", "attempts", "fleet", "timeseries"):
        assert skipped[name].equals(again[name]) and skipped[name].equals(every[name]), name
    assert skipped["attempts"].num_rows > 20
