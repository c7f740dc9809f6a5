"""The verdicts on the item-delivery paper's statements (dronefleet/items/verdicts.py): every
statement of docs/items-paper-checklist.md has a test, the rules of a verdict, and statements
applied to tables built by hand, where the answer is known."""

import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from dronefleet.items import verdicts as v

CHECKLIST = Path(__file__).resolve().parent.parent / "docs" / "items-paper-checklist.md"


def test_every_statement_of_the_checklist_has_a_test_and_no_other():
    ids = re.findall(r"^\| (I\d+) \|", CHECKLIST.read_text(), re.MULTILINE)
    assert ids == list(v.STATEMENTS) == [f"I{k}" for k in range(1, len(ids) + 1)]


def test_a_verdict_is_the_defaults_then_the_options_that_pass():
    yes, no, unknown = (v.Result("defaults", True, ""), v.Result("defaults", False, ""),
                        v.Result("defaults", None, ""))
    option = v.Result("cas_targets='shared'", True, "")
    assert v.verdict_of([yes, v.Result("x", False, "")]) == (v.HOLDS, "-")
    assert v.verdict_of([no, option, v.Result("y", False, "")]) == (v.UNDER, "cas_targets='shared'")
    assert v.verdict_of([no, v.Result("y", False, "")]) == (v.FAILS, "-")
    assert v.verdict_of([unknown]) == (v.NOT_MEASURED, "-")


def test_paired_differences_agree_only_beyond_twice_their_standard_error():
    index = pd.Index(range(4), name="trial")
    a = pd.Series([2.0, 3.0, 2.0, 3.0], index=index)
    mean, se, n = v.paired(a, a - 1.0)
    assert (mean, se, n) == (1.0, 0.0, 4) and v._beyond(mean, se)
    mean, se, _ = v.paired(a, pd.Series([1.0, 3.0, 2.0, 2.0], index=index))   # d = 1, 0, 0, 1
    assert mean == 0.5 and se == pytest.approx(np.std([1, 0, 0, 1], ddof=1) / 2) and not v._beyond(mean, se)


def runs(rates):
    """A committed ``runs`` table of E1 and E2: ``rates(algorithm, cas_variant, n, c, trial)`` -> rate."""
    rows = []
    for experiment in ("e1", "e2"):
        for algorithm, variant in (("R", "max_expected"), ("GR", "max_expected"), ("CAS", "max_expected"),
                                   ("CAS", "rate")):
            for n in (1, 2):
                for c in range(1, 21):
                    for trial in range(1, 5):
                        rows.append({"experiment": experiment, "algorithm": algorithm, "cas_variant": variant,
                                     "lam_hat_source": "value", "n_robots": n, "capacity": c, "speed": 0.2,
                                     "sigma_e": 0.08, "mu_l": 0.1, "trial": trial,
                                     "rate": rates(algorithm, variant, n, c, trial)})
    return pd.DataFrame(rows)


def data_of(rates):
    table = runs(rates)
    return v.Data({"e1": table[table.experiment == "e1"], "e2": table[table.experiment == "e2"]},
                  pd.DataFrame(), pd.DataFrame(columns=["experiment", "algorithm", *v.PAIR_KEYS, "rate"]))


def test_r_against_cas_by_capacity_holds_only_when_both_halves_do():
    noise = lambda trial: 0.01 * trial         # noqa: E731  the same for both: pairs cancel it

    def the_papers(algorithm, variant, n, c, trial):   # R ahead below c = 10, CAS above
        ahead = {"R": 1.0 if c < 10 else 0.0, "CAS": 1.0 if c > 10 else 0.0}.get(algorithm, 0.0)
        return 50.0 + ahead + noise(trial) + (0.1 * trial if algorithm == "R" else 0.0)

    results = v.STATEMENTS["I11"](data_of(the_papers))
    assert [r.option for r in results] == ["defaults", "cas_variant='rate'", "cas_targets='shared'"]
    assert results[0].passes and results[1].passes and not results[2].passes   # no extra cells: not shared
    everywhere = lambda a, variant, n, c, trial: 50.0 + (a == "CAS") + 0.01 * trial   # noqa: E731
    assert not v.STATEMENTS["I11"](data_of(everywhere))[0].passes


def test_gr_above_every_other_in_every_cell_fails_on_a_single_cell():
    def rates(algorithm, variant, n, c, trial):
        worse = 0.0 if algorithm == "GR" else 1.0 + 0.1 * trial
        if algorithm == "CAS" and variant == "max_expected" and (n, c) == (2, 7):
            worse = -1.0 - 0.1 * trial            # CAS above GR in this one cell, beyond its se
        return 60.0 - worse
    results = v.STATEMENTS["I9"](data_of(rates))
    assert not results[0].passes and "e1 CAS above GR in 1 of 40 cells" in results[0].numbers
    assert results[1].passes                      # the rate rule is below GR everywhere


def test_the_grid_statement_counts_the_points_of_both_spacings():
    results = v.STATEMENTS["I20"](None)
    assert [r.passes for r in results] == [False, False]
    assert "441" in results[0].numbers and "121" in results[0].numbers and "400" in results[1].numbers


def test_the_extra_cells_are_the_study_sweeps_with_the_option_and_quick_shrinks_them():
    full = v.extra_configs()
    assert {name for name, _ in full} == set(v.EXTRA)
    shared = [c for name, c in full if name == "e4a-shared"]
    assert {c.cas_targets for c in shared} == {"shared"} and {c.mode for c in shared} == {"delivery"}
    assert {(c.trials, c.steps) for _, c in full} == {(20, 1000)}
    quick = v.extra_configs(quick=True)
    assert {(c.trials, c.steps) for _, c in quick} == {(2, 200)} and len(quick) < len(full) / 3


def test_check_re_derives_the_committed_verdicts_and_names_a_changed_one(tmp_path, capsys):
    """``reproduce items-verdicts --check`` on copies of the committed tables: identical, then a
    verdict edited in the copy is found, naming the row and both values."""
    import shutil

    from dronefleet import cli

    results = Path(__file__).resolve().parent.parent / "results"
    for figure in (*v.FIGURE_TABLES.values(), "items-ttests", "items-verdicts"):
        (tmp_path / figure).mkdir()
        for table in (results / figure).glob("*.parquet"):
            shutil.copy(table, tmp_path / figure / table.name)
    argv = ["reproduce", "items-verdicts", "--check", "--jobs", "1", "--out", str(tmp_path)]
    assert cli.main(argv) == 0
    path = tmp_path / "items-verdicts" / "verdicts.parquet"
    table = pd.read_parquet(path)
    table.loc[0, "verdict"] = v.FAILS
    table.to_parquet(path)
    capsys.readouterr()
    assert cli.main(argv) == 1
    captured = capsys.readouterr()
    assert f"items-verdicts verdicts row 0: verdict committed '{v.FAILS}', re-derived '{v.HOLDS}'" in \
        captured.out + captured.err
