"""Figure tables by hand: run outcomes, backlog by arrival week, weekly accuracy, Fig. 18's grid, thresholds.

Inputs are small tidy tables written as hive-partitioned parquet and read back the way a
sweep's results are read, so grid keys arrive as categoricals (float keys as strings).
"""

import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from conftest import WEEK
from dronefleet.delivery import config as cfg
from dronefleet.delivery import analysis, auction
from dronefleet.delivery.metrics import by_arrival_week
from dronefleet.delivery.policy import decision

C = cfg.default_config()


def hive(root, parts):
    """Write each (grid keys, rows) as ``root/<key>=<value>/.../part-0.parquet``; read the dataset back."""
    for keys, rows in parts:
        folder = Path(root, *[f"{key}={value}" for key, value in keys.items()])
        folder.mkdir(parents=True)
        pd.DataFrame(rows).to_parquet(folder / "part-0.parquet", index=False)
    return pd.read_parquet(root)


# ---------------------------------------------------------------------------- run outcomes


def summary_row(delivered, median_s):
    return {"orders_arrived": [100], "delivered": [delivered], "median_delivery_time_s": [median_s],
            "attempts": [delivered + 10], "aborted_pct": [100 * 10 / (delivered + 10)], "pending": [100 - delivered],
            "backlog_age_s": [1e5], "lost_uavs": [0], "decision_accuracy": [0.8]}


def test_run_outcomes_one_row_per_run_with_numeric_keys_in_numeric_order(tmp_path):
    parts = [({"rule": rule, "tau_minutes": tau, "seed": seed}, summary_row(delivered, 60.0 * delivered))
             for rule, tau, seed, delivered in [("random", 5.0, 1, 70), ("least_confident", 15.0, 0, 90),
                                                 ("least_confident", 5.0, 1, 80), ("least_confident", 5.0, 0, 85)]]
    summary = hive(tmp_path / "summary", parts)
    assert isinstance(summary["tau_minutes"].dtype, pd.CategoricalDtype)  # what a sweep hands us
    out = analysis.run_outcomes(summary)
    assert list(out.columns) == ["rule", "tau_minutes", "seed", *analysis.OUTCOMES]
    # Numbers, sorted as numbers (the strings would put "15.0" before "5.0").
    assert out[["rule", "tau_minutes", "seed", "delivered"]].values.tolist() == [
        ["least_confident", 5.0, 0, 85], ["least_confident", 5.0, 1, 80], ["least_confident", 15.0, 0, 90],
        ["random", 5.0, 1, 70]]
    assert out["median_delivery_time_s"].tolist() == [60.0 * 85, 60.0 * 80, 60.0 * 90, 60.0 * 70]


def test_run_outcomes_refuses_runs_that_a_missing_grid_key_would_merge(tmp_path):
    parts = [({"rule": "random", "tau_minutes": tau, "seed": 0}, summary_row(50, 60.0)) for tau in (15.0, 20.0)]
    with pytest.raises(ValueError, match="grid key missing"):
        analysis.run_outcomes(hive(tmp_path / "summary", parts), by=("rule",))


# ---------------------------------------------------------------------------- backlog by arrival week


def test_backlog_by_arrival_week_by_hand_and_as_metrics_per_run(tmp_path):
    T = 2 * WEEK
    runs = {
        ("random", 0): ([0.0, WEEK - 1.0, WEEK, 1.5 * WEEK], [10.0, None, None, 1.6 * WEEK]),
        ("random", 1): ([0.0, 0.5 * WEEK], [None, None]),
        ("least_confident", 0): ([0.25 * WEEK], [0.3 * WEEK]),
    }
    parts = [({"rule": rule, "seed": seed}, {"arrival_s": arrival, "delivered_s": delivered})
             for (rule, seed), (arrival, delivered) in runs.items()]
    orders = hive(tmp_path / "orders", parts)
    out = analysis.backlog_by_arrival_week(orders, T, by=("rule",))
    assert list(out.columns) == ["rule", "seed", "arrival_week", "arrived", "pending", "backlog_age_s"]
    assert out[["rule", "seed", "arrival_week", "arrived", "pending"]].values.tolist() == [
        ["least_confident", 0, 1, 1, 0], ["least_confident", 0, 2, 0, 0],
        ["random", 0, 1, 2, 1], ["random", 0, 2, 2, 1],
        ["random", 1, 1, 2, 2], ["random", 1, 2, 0, 0]]
    assert out["backlog_age_s"].tolist() == pytest.approx(
        [0.0, 0.0, T - (WEEK - 1.0), T - WEEK, T + T - 0.5 * WEEK, 0.0], rel=1e-12)
    # The same numbers as the one-run metric, run by run.
    for (rule, seed), (arrival, delivered) in runs.items():
        one = out[(out["rule"] == rule) & (out["seed"] == seed)].drop(columns=["rule", "seed"])
        pd.testing.assert_frame_equal(one.reset_index(drop=True), by_arrival_week(arrival, delivered, T))


def test_backlog_by_arrival_week_refuses_a_wrong_horizon():
    orders = pd.DataFrame({"rule": ["random"], "seed": [0], "arrival_s": [1.5 * WEEK], "delivered_s": [math.nan]})
    with pytest.raises(ValueError, match="horizon"):
        analysis.backlog_by_arrival_week(orders, WEEK, by=("rule",))


# ---------------------------------------------------------------------------- weekly accuracy


T_975_DF3 = 3.182446305284263  # Student's t, 97.5 % quantile, 3 degrees of freedom (tables)


def test_weekly_accuracy_pools_uavs_of_all_runs_with_a_t_band(tmp_path):
    parts = [
        ({"rule": "random", "seed": 0}, {"week": [1, 1, 2, 2], "uav": [0, 1, 0, 1],
                                         "decision_accuracy": [0.5, 0.7, 0.9, 0.9]}),
        ({"rule": "random", "seed": 1}, {"week": [1, 1, 2, 2], "uav": [0, 1, 0, 1],
                                         "decision_accuracy": [0.6, 0.8, 0.9, math.nan]}),
        ({"rule": "least_confident", "seed": 0}, {"week": [1, 1], "uav": [0, 1], "decision_accuracy": [1.0, 0.0]}),
    ]
    out = analysis.weekly_accuracy(hive(tmp_path / "fleet", parts))
    assert list(out.columns) == ["rule", "week", "uavs", "mean_accuracy", "ci_low", "ci_high", "confidence"]
    assert out[["rule", "week", "uavs"]].values.tolist() == [
        ["least_confident", 1, 2], ["random", 1, 4], ["random", 2, 3]]
    # random, week 1: 4 UAVs 0.5, 0.7, 0.6, 0.8: mean 0.65, s^2 = 0.05 / 3.
    half = T_975_DF3 * math.sqrt(0.05 / 3) / 2
    row = out.iloc[1]
    assert (row["mean_accuracy"], row["ci_low"], row["ci_high"]) == pytest.approx((0.65, 0.65 - half, 0.65 + half))
    # Week 2 leaves the nan out; three equal values have a band of width 0.
    assert out.iloc[2][["mean_accuracy", "ci_low", "ci_high"]].tolist() == pytest.approx([0.9, 0.9, 0.9])
    # least_confident: 1.0 and 0.0, s = sqrt(0.5), t(1) = 12.706.
    assert out.iloc[0]["ci_high"] - 0.5 == pytest.approx(12.706204736174696 * math.sqrt(0.5) / math.sqrt(2))


# ---------------------------------------------------------------------------- Figure 18 grid


def kernel_winner_soh(policies, soc, distance, mass):
    """The engine's least_confident auction among ``policies`` (rows in UAV order), with the compiled
    ``policy.decision`` and ``auction.least_confident``; the winner's SoH, nan if nobody bids."""
    coef = policies[["w_distance", "w_mass", "w_soc"]].to_numpy(np.float64)
    intercept = policies["intercept"].to_numpy(np.float64)
    x0, x1, x2 = ((value - mean) / std for value, mean, std in zip((distance, mass, soc), C.scaler_mean, C.scaler_std))
    rng = np.random.default_rng(0)  # unused by least_confident, but the kernel takes one
    best, winner = -np.inf, -1
    for i in range(coef.shape[0]):
        f = decision(coef, intercept, i, x0, x1, x2)
        w = coef[i]
        bids, score = auction.least_confident(f, np.sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]), soc, 0.0, rng)
        if bids and score >= best:  # ascending ids: ties go to the highest id, as in the engine
            best, winner = score, i
    return math.nan if winner < 0 else policies["soh"].iloc[winner]


POLICY = ["w_distance", "w_mass", "w_soc", "intercept"]
ALWAYS_SURE = [0.0, 0.0, 1.0, 1e3]  # bids everywhere with confidence about 1000
NEVER = [0.0, 0.0, 1.0, -1e3]


def fleets_for_the_grid():
    """Four runs of 6 UAVs: random policies (seed 3); a tie (seed 5); a lost UAV (seed 8); no bidder (seed 9)."""
    rng = np.random.default_rng(7)
    n = 4 * 6
    fleets = pd.DataFrame({
        "seed": np.repeat([3, 5, 8, 9], 6), "uav": np.tile(np.arange(6), 4), "soh": rng.uniform(0.5, 1.0, n),
        # f falls with distance and mass and rises with SoC: bids on part of the grid.
        "w_distance": rng.normal(-2.0, 0.5, n), "w_mass": rng.normal(-2.0, 0.5, n),
        "w_soc": rng.normal(3.0, 0.5, n), "intercept": rng.normal(0.0, 1.0, n), "lost": False,
    })

    def at(seed, uavs):
        return (fleets["seed"] == seed) & fleets["uav"].isin(uavs)

    # Seed 5: UAVs 2 and 4 have one policy, less confident than the others wherever it bids, so
    # they tie there (the higher id must win); elsewhere UAVs 0, 1, 3, 5 tie (5 must win).
    fleets.loc[at(5, [0, 1, 3, 5]), POLICY] = ALWAYS_SURE
    fleets.loc[at(5, [2, 4]), POLICY] = [-2.0, -2.0, 3.0, 0.0]
    # Seed 8: UAV 1 bids everywhere with confidence below 4 and would always win, but it is lost.
    fleets.loc[at(8, [0, 2, 3, 4, 5]), POLICY] = ALWAYS_SURE
    fleets.loc[at(8, [1]), POLICY + ["lost"]] = [0.0, 0.0, 1.0, 1.8, True]
    fleets.loc[at(9, range(6)), POLICY] = NEVER
    return fleets


def test_winner_soh_grid_equals_the_compiled_auction_with_ties_a_lost_uav_and_no_bidder():
    fleets = fleets_for_the_grid()
    socs, distances, masses = [10.0, 60.0, 100.0], analysis.DISTANCE_GRID[::20], analysis.MASS_GRID[::30]
    grid = analysis.winner_soh_grid(fleets, C, socs, distances, masses)
    assert len(grid) == 3 * 5 * 4 and (grid["runs"] == 4).all()
    points = grid.set_index(["soc", "distance_m", "mass_kg"])
    for soc in socs:
        for d in distances:
            for m in masses:
                sohs = [kernel_winner_soh(f[~f["lost"]], soc, d, m) for _, f in fleets.groupby("seed")]
                winners = [s for s in sohs if not math.isnan(s)]
                assert points.loc[(soc, d, m), "runs_with_winner"] == len(winners)
                assert points.loc[(soc, d, m), "mean_winner_soh"] == pytest.approx(np.mean(winners), rel=1e-12)

    def alone(seed, **changes):
        return analysis.winner_soh_grid(fleets[fleets["seed"] == seed].assign(**changes), C, socs, distances,
                                        masses)["mean_winner_soh"]

    soh = fleets.set_index(["seed", "uav"])["soh"]
    # Where UAVs 2 and 4 of seed 5 bid: f >= 0 of their policy.
    x = [(grid[column] - mean) / std for column, mean, std in zip(("distance_m", "mass_kg", "soc"), C.scaler_mean,
                                                                  C.scaler_std)]
    tied_bid = -2.0 * x[0] - 2.0 * x[1] + 3.0 * x[2] >= 0.0
    assert 0 < tied_bid.sum() < len(grid)
    assert alone(5).tolist() == np.where(tied_bid, soh[5, 4], soh[5, 5]).tolist()
    assert alone(8).tolist() == [soh[8, 5]] * len(grid)
    assert alone(8, lost=False).tolist() == [soh[8, 1]] * len(grid)
    assert alone(9).isna().all()


def test_winner_soh_grid_is_exact_decimals_and_refuses_several_weeks():
    assert analysis.MASS_GRID.tolist() == [round(0.5 + 0.05 * k, 2) for k in range(91)]
    assert analysis.DISTANCE_GRID.tolist() == [1000.0 + 50 * k for k in range(81)]
    assert analysis.SOC_GRID.tolist() == [10.0 * k for k in range(1, 11)]
    fleets = fleets_for_the_grid()
    with pytest.raises(ValueError, match="last week"):
        analysis.winner_soh_grid(pd.concat([fleets, fleets]), C)


# ---------------------------------------------------------------------------- thresholds


def test_threshold_table_by_hand_and_equal_deliveries_share_a_rank():
    rows = [  # theta, tau, delivered, median delivery time (s), aborted %
        (50.0, 15.0, 100, 600.0, 10.0), (50.0, 20.0, 80, 300.0, 20.0),
        (70.0, 15.0, 120, 900.0, 5.0), (70.0, 20.0, 100, 700.0, 5.0),
        (90.0, 15.0, 130, 400.0, 0.0), (90.0, 20.0, 90, 200.0, 0.0),
    ]
    outcomes = pd.DataFrame(rows, columns=["theta", "tau_minutes", "delivered", "median_delivery_time_s", "aborted_pct"])
    outcomes = outcomes.assign(rule="threshold", seed=0, pending=10, backlog_age_s=3600.0)
    table, best = analysis.threshold_table(outcomes)
    assert table["theta"].tolist() == [50.0, 70.0, 90.0]
    assert table["runs"].tolist() == [2, 2, 2]
    assert table["delivered_mean"].tolist() == [90.0, 110.0, 110.0]
    assert table["median_delivery_time_s"].tolist() == [450.0, 800.0, 300.0]
    assert table["aborted_pct_mean"].tolist() == [15.0, 5.0, 0.0]
    # 70 and 90 deliver as many (both rank 1); 90 is also the fastest.
    assert table["delivered_rank"].tolist() == [3, 1, 1] and table["delivery_time_rank"].tolist() == [2, 3, 1]
    assert best == 90.0 and table["best"].tolist() == [False, False, True]
    with pytest.raises(ValueError, match="threshold runs only"):
        analysis.threshold_table(pd.concat([outcomes, outcomes.assign(rule="random")]))


def thresholds(runs):
    """Threshold runs' outcomes from ``{theta: [(delivered, median delivery time s), ...]}``."""
    rows = [(theta, seed, delivered, time) for theta, pairs in runs.items()
            for seed, (delivered, time) in enumerate(pairs)]
    frame = pd.DataFrame(rows, columns=["theta", "seed", "delivered", "median_delivery_time_s"])
    return frame.assign(rule="threshold", tau_minutes=15.0, aborted_pct=0.0, pending=0, backlog_age_s=0.0)


@pytest.mark.parametrize("runs, best", [
    # One theta has the most deliveries and the shortest time: it wins outright.
    ({50.0: [(100, 900.0)], 80.0: [(300, 100.0)], 90.0: [(200, 500.0)]}, 80.0),
    # The measures conflict: 60 delivers most but is the slowest (ranks 1 + 3); 70 is second
    # and fastest (2 + 1): the lower rank sum wins over the most deliveries.
    ({60.0: [(300, 900.0)], 70.0: [(290, 100.0)], 80.0: [(200, 500.0)]}, 70.0),
    # A conflict with equal rank sums (1 + 2 and 2 + 1): the most deliveries win.
    ({70.0: [(300, 500.0)], 80.0: [(290, 100.0)]}, 70.0),
    # Equal on both measures: the lower theta.
    ({80.0: [(300, 100.0)], 90.0: [(300, 100.0)]}, 80.0),
    # Medians over runs, not means: 50's one big run lifts its mean (400) above 60's (200), not its median;
    # 60's one slow run lifts its mean delivery time (3066.7 s) above 50's (900 s), not its median.
    ({50.0: [(100, 100.0), (100, 100.0), (1000, 100.0)], 60.0: [(200, 100.0)] * 3}, 60.0),
    ({50.0: [(100, 900.0), (100, 900.0)], 60.0: [(100, 100.0), (100, 100.0), (100, 9000.0)]}, 60.0),
])
def test_the_best_theta_has_the_most_deliveries_and_shortest_delivery_times_by_rank_sum(runs, best):
    table, chosen = analysis.threshold_table(thresholds(runs))
    assert chosen == best and table.loc[table["best"], "theta"].tolist() == [best]


def test_a_theta_that_delivered_nothing_has_no_delivery_time_and_ranks_last_on_it():
    table, best = analysis.threshold_table(thresholds({90.0: [(50, 700.0)], 100.0: [(0, np.nan), (0, np.nan)]}))
    assert table["delivery_time_rank"].tolist() == [1, 2] and table["delivered_rank"].tolist() == [1, 2]
    assert best == 90.0


def test_best_threshold_runs_are_relabelled_to_sit_beside_learning():
    frame = pd.DataFrame({"rule": "threshold", "theta": pd.Categorical(["80.0", "90.0", "80.0"]),
                          "tau_minutes": [15.0, 15.0, 20.0], "delivered": [1, 2, 3]})
    out = analysis.best_threshold_runs(frame, 80.0)
    assert out.to_dict("list") == {"rule": ["threshold(80)"] * 2, "tau_minutes": [15.0, 20.0], "delivered": [1, 3]}
