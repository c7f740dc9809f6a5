"""E4 (sensitivity) and E5 (the Ch 4 baseline) of the lunar study (spec LUNAR-FORAGING.md section 14):
the conditions E4 runs, the paired effect of a change on a synthetic table whose answer is known,
and the ``model = "baseline"`` option (no energy, no role R, no F_IN -> R fallback)."""

import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from dronefleet import sweeps as sw
from dronefleet.config import SweepError
from dronefleet.lunar import experiments, sensitivity
from dronefleet.lunar import kernel as k
from dronefleet.lunar.params import LunarParams

SWEEPS = Path(__file__).resolve().parents[1] / "configs" / "sweeps"
#: E4's changes, in the sweep's order (spec section 14), the defaults first and the control last.
E4_CHANGES = ["default", "v0=0.125, p_move=5.8", "layout_scale=1", "kappa_soft=2", "kappa_soft=5", "p_move=29",
              "p_move=116", "p_move=232", "weight_form=bracket", "weight_form=literal", "broadcast=update",
              "turn_on=any", "los_bodies=true", "redecide=avoid_clear", "redecide=beacon_change", "fallback=literal",
              "avoidance=turn, broadcast_velocity=motion", "eps=1"]


def test_e4_runs_every_change_over_the_five_scenarios_with_the_same_runs():
    configs = [run.config for run in sw.load_sweep(SWEEPS / "lunar-e4.toml").runs]
    changes = list(dict.fromkeys(sensitivity.change_of(c) for c in configs))
    assert changes == E4_CHANGES
    for change in changes:
        mine = [c for c in configs if sensitivity.change_of(c) == change]
        assert [sensitivity.scenario_of(c) for c in mine] == list(sensitivity.SCENARIOS), change
        assert {(c.runs, c.first_run, c.seed, c.duration_s) for c in mine} == {(50, 0, 0, 3600.0)}, change
    assert len(configs) == 18 * 5


def test_a_change_is_named_by_the_keys_it_sets_and_not_by_the_scenario():
    assert sensitivity.change_of(LunarParams(layout="OPEN", battery_wh=7.5, runs=3, duration_s=600.0)) == "default"
    assert sensitivity.change_of(LunarParams(los_bodies=True, eps=1.0)) == "eps=1, los_bodies=true"
    assert sensitivity.scenario_of(LunarParams(layout="SOFT-RT", battery_wh=12.5, eps=1.0)) == "SOFT-RT 12.5 Wh"


def _runs(rows):
    return pd.DataFrame(rows, columns=["change", "condition", "run", "resources", "deaths", "mobile"])


def test_the_effect_is_the_mean_paired_difference_by_run_index_with_its_standard_error():
    # the change's rows in another order than the default's: the pairs are by run index, not row
    rows = [("default", "OPEN", j, r, d, m) for j, r, d, m in ((0, 100, 1, 5), (1, 200, 2, 6), (2, 300, 3, 7))]
    rows += [("p_move=29", "OPEN", j, r, d, m) for j, r, d, m in ((2, 330, 0, 7), (0, 110, 1, 6), (1, 205, 6, 6))]
    rows += [("default", "HARD-RT", 0, 50, 0, 1), ("p_move=29", "HARD-RT", 0, 40, 0, 1)]
    table = sensitivity.effects(_runs(rows))
    assert list(table.columns) == list(sensitivity.EFFECT_COLUMNS)
    assert list(zip(table["condition"], table["metric"])) == [
        ("OPEN", "resources"), ("OPEN", "deaths"), ("OPEN", "mobile"),
        ("HARD-RT", "resources"), ("HARD-RT", "deaths"), ("HARD-RT", "mobile")]
    resources = table.iloc[0]
    diffs = np.array([10.0, 5.0, 30.0])                       # runs 0, 1, 2
    assert resources["effect"] == pytest.approx(15.0) and resources["runs"] == 3
    assert resources["se"] == pytest.approx(np.std(diffs, ddof=1) / math.sqrt(3))
    assert (resources["default_mean"], resources["mean"]) == (200.0, 215.0)
    deaths = table.iloc[1]
    assert deaths["effect"] == pytest.approx((0 + 4 - 3) / 3)    # runs 0, 1, 2
    assert table.iloc[3]["effect"] == -10.0 and math.isnan(table.iloc[3]["se"])   # one pair: no error
    assert "default" not in set(table["change"])


def test_a_run_without_its_default_run_is_refused_naming_it():
    rows = [("default", "OPEN", 0, 100, 1, 5), ("eps=1", "OPEN", 0, 50, 1, 5), ("eps=1", "OPEN", 7, 50, 1, 5)]
    with pytest.raises(SweepError, match="eps=1, OPEN: run 0 has no run at the defaults"):
        sensitivity.effects(_runs(rows))


def test_the_baseline_is_a_condition_of_its_own():
    assert experiments.condition_of("OPEN", 10.0, 0.05, "baseline") == "OPEN baseline"
    assert experiments.condition_of("OPEN", 10.0, 0.05) == "OPEN"
    configs = [run.config for run in sw.load_sweep(SWEEPS / "lunar-e5.toml").runs]
    assert [experiments.condition_row(c, "e5")["condition"] for c in configs] == ["OPEN baseline", "HARD-RT baseline"]
    assert {(c.runs, c.battery_wh, c.eps) for c in configs} == {(50, 10.0, 0.05)}


def test_in_the_baseline_rows_2_and_3_never_fire():
    # at the nest, never charged, SOC below every cost: the full model goes to charge (row 3, then 2)
    here = dict(role=k.F_IN, mode=k.NORMAL, region=k.REG_N, n_in_range=1, role_k1=k.F_IN, role_k2=k.F_IN, soc=0.1,
                s_hat=np.array([0.5, 0.5, 0.5]), visited_r=False, full=False, loaded=False, no_r_guidance=False)
    assert k.choose_row(**here) == 2
    assert k.choose_row(**{**here, "soc": 0.9}) == 3
    assert k.choose_row(**here, baseline=True) == 8                  # Eq 4-5: F_IN at the nest -> F_OUT
    away = {**here, "region": k.NO_REGION}
    assert k.choose_row(**away) == 2 and k.choose_row(**away, baseline=True) == 0


def test_a_baseline_run_has_no_recharger_and_draws_no_energy():
    from dronefleet.lunar.simulate import simulate

    config = dict(layout="OPEN", n_robots=12, duration_s=40.0, runs=1)
    full = simulate(LunarParams(**config))["timeseries"].to_pandas()
    base = simulate(LunarParams(**config, model="baseline"))["timeseries"].to_pandas()
    assert full["n_r"].max() > 0 and full["soc_sum"].iloc[-1] < full["n_mobile"].iloc[-1] + full["n_beacons"].iloc[-1]
    assert base["n_r"].max() == 0
    alive = base["n_mobile"] + base["n_beacons"]
    assert (base["soc_sum"] == alive).all() and (base["n_dead"] == 0).all()
