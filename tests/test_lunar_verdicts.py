"""The verdicts of the thesis's claims (dronefleet/lunar/verdicts.py): every checklist id has a
measurement, and the rules of a verdict on small tables whose verdict is known."""

import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from dronefleet.lunar import verdicts as v
from dronefleet.lunar.params import LunarParams

CHECKLIST = Path(__file__).resolve().parent.parent / "docs" / "lunar-thesis-checklist.md"
RUNS = np.arange(50)


def test_every_checklist_claim_has_a_function():
    ids = re.findall(r"^\| (C\d+) \|", CHECKLIST.read_text(encoding="utf-8"), flags=re.MULTILINE)
    assert len(ids) == 70
    assert sorted(v.CLAIMS, key=lambda c: int(c[1:])) == sorted(ids, key=lambda c: int(c[1:]))


def _runs(summaries: dict[str, dict[str, np.ndarray]]) -> v.Runs:
    """Runs of summary rows only: {condition: {column: per-run values}}."""
    frames = [pd.DataFrame({"condition": condition, "run": RUNS, **columns})
              for condition, columns in summaries.items()]
    configs = {condition: LunarParams(layout=condition.split()[0]) for condition in summaries}
    return v.Runs({"summary": pd.concat(frames, ignore_index=True)}, configs)


def _resources(open_minus_obstructed: np.ndarray) -> v.Runs:
    """OPEN, HARD-RT, SOFT-RT with run-to-run spread far above the given paired differences."""
    base = 1000.0 + 300.0 * np.sin(RUNS)
    obstructed = base - open_minus_obstructed
    return _runs({"OPEN": {"resources": base}, "HARD-RT": {"resources": obstructed},
                  "SOFT-RT": {"resources": obstructed}})


def test_a_small_paired_difference_holds_beyond_twice_its_standard_error():
    # OPEN returns 5 more in every run: the runs' own spread (300) does not hide it once paired
    verdict, numbers = v.CLAIMS["C24"](_resources(5.0 + 0.1 * np.cos(RUNS)))
    assert verdict == v.HOLDS, numbers


def test_a_difference_within_twice_its_standard_error_is_the_direction_only():
    # mean +1, sd 20 over 50 runs: se 2.8, so 1 < 2 se
    verdict, numbers = v.CLAIMS["C24"](_resources(1.0 + 20.0 * np.where(RUNS % 2, 1.0, -1.0)))
    assert verdict == v.DIRECTION, numbers


def test_the_opposite_sign_does_not_hold():
    verdict, _ = v.CLAIMS["C24"](_resources(-5.0 + 0.1 * np.cos(RUNS)))
    assert verdict == v.FAILS


def test_comparisons_pair_runs_by_index_not_by_row_order():
    runs = _resources(5.0 + 0.1 * np.cos(RUNS))
    summary = runs.tables["summary"]
    runs.tables["summary"] = summary.sample(frac=1.0, random_state=1).reset_index(drop=True)
    assert v.CLAIMS["C24"](runs)[0] == v.HOLDS


def test_paired_rule_numbers():
    a = pd.Series([3.0, 5.0, 4.0], index=[2, 0, 1])
    b = pd.Series([1.0, 1.0, 1.0, 9.0], index=[0, 1, 2, 3])   # run 3 has no partner
    mean, se, n = v.paired(a, b)
    assert n == 3 and mean == pytest.approx(3.0) and se == pytest.approx(1.0 / np.sqrt(3))
    assert v.sign_verdict(2.1, 1.0) == v.HOLDS
    assert v.sign_verdict(1.9, 1.0) == v.DIRECTION
    assert v.sign_verdict(-0.1, 1.0) == v.FAILS


def test_a_threshold_on_the_selected_runs():
    # the 30 best runs return 700, the 20 others 100: the mean over all (460) is below 600, the selected one above
    resources = np.where(RUNS < 30, 700, 100)
    table = {"resources": resources, "trips": resources // 6}
    runs = _runs({"OPEN": table, "HARD-RT": table, "SOFT-RT": table})
    assert v.CLAIMS["C18"](runs)[0] == v.HOLDS
    assert v.CLAIMS["C19"](runs)[0] == v.HOLDS        # 700 // 6 = 116 unloads
    worse = {"resources": resources - 200, "trips": resources // 6}
    assert v.CLAIMS["C18"](_runs({"OPEN": table, "HARD-RT": worse, "SOFT-RT": table}))[0] == v.FAILS


def test_robots_at_soc_zero_fail_survival():
    clean = {"resources": RUNS * 10, "depletions": np.zeros(50, dtype=int)}
    # a death in a run that is not selected (the lowest resources) does not count; one in a selected run does
    spared = {"resources": RUNS * 10, "depletions": np.where(RUNS == 0, 1, 0)}
    hit = {"resources": RUNS * 10, "depletions": np.where(RUNS == 49, 1, 0)}
    assert v.CLAIMS["C38"](_runs({"OPEN": clean, "HARD-RT": clean, "SOFT-RT": spared}))[0] == v.HOLDS
    assert v.CLAIMS["C38"](_runs({"OPEN": clean, "HARD-RT": hit, "SOFT-RT": clean}))[0] == v.FAILS


def test_claims_without_the_data_are_not_measured_with_a_reason():
    for claim in ("C17", "C49"):
        verdict, reason = v.CLAIMS[claim](v.Runs({}, {}))
        assert verdict == v.NOT_MEASURED and reason


def test_the_conditions_are_those_of_the_e1_to_e3_sweep_files_on_the_base():
    configs = v.conditions(LunarParams(v0=0.125))
    names = [v.ex.condition_of(c.layout, c.battery_wh, c.eps, c.model) for c in configs]
    assert names == ["OPEN", "HARD-RT", "SOFT-RT", "SOFT-RT 7.5 Wh", "SOFT-RT 12.5 Wh",
                     "HARD-NT", "SOFT-NT", "HARD-NR", "SOFT-NR"]
    assert all(c.runs == 50 and c.v0 == 0.125 for c in configs)


def _rt_trips(lengths: dict[str, float], early_lengths: dict[str, float]) -> v.Runs:
    """Two R-T trips per run and condition: one entered early (at 100 s), one late (at 3000 s)."""
    tau = LunarParams().tau
    rows = [{"condition": c, "run": j, "origin": "R", "dest": "T", "tick_entered": round(t / tau),
             "length_m": length + 0.01 * np.cos(j)}
            for c in lengths for j in RUNS
            for t, length in ((100.0, early_lengths[c]), (3000.0, lengths[c]))]
    configs = {c: LunarParams(layout="SOFT-RT", battery_wh=float(c.split()[1]) if " " in c else 10.0)
               for c in lengths}
    return v.Runs({"trips": pd.DataFrame(rows)}, configs)


def test_trip_claims_read_the_late_trips_only():
    # C43: the late R-T length falls as the battery grows; the early trips say the opposite and are ignored
    late = {"SOFT-RT 7.5 Wh": 30.0, "SOFT-RT": 28.0, "SOFT-RT 12.5 Wh": 26.0}
    early = {"SOFT-RT 7.5 Wh": 10.0, "SOFT-RT": 20.0, "SOFT-RT 12.5 Wh": 40.0}
    assert v.CLAIMS["C43"](_rt_trips(late, early))[0] == v.HOLDS
    assert v.CLAIMS["C43"](_rt_trips(early, late))[0] == v.FAILS
