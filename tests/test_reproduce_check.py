"""The committed figures re-derive: a few committed runs of each figure re-run to the same numbers.

Each ``results/<figure>/runs.parquet`` (written by ``dronefleet reproduce``) holds the summary
of every run the figure is drawn from; ``reproduce.check`` re-runs the runs of
``reproduce.CHECK_RUNS`` (Figure 16: least_confident tau 15 seed 0, random tau 25 seed 3,
most_confident tau 40 seed 7) and compares every value. A change of the engine that moves
any trajectory fails here until ``dronefleet reproduce all`` regenerates ``results/``.
"""

from pathlib import Path

import pandas as pd
import pytest

from dronefleet import cli, reproduce

RESULTS = Path(__file__).resolve().parents[1] / "results"


def snapshot(root):
    """Every file under ``root`` with its size and modification time."""
    return {path: (path.stat().st_size, path.stat().st_mtime_ns) for path in root.rglob("*") if path.is_file()}


#: The figures committed under results/ (the items study's are not yet: test_items_study.py checks a fresh run).
COMMITTED = (*reproduce.DELIVERY_FIGURES, *reproduce.REPLENISHMENT_FIGURES)


@pytest.mark.parametrize("figure", COMMITTED)
def test_committed_runs_of_each_figure_rerun_to_the_same_numbers(figure):
    before = snapshot(RESULTS)
    lines = []
    assert reproduce.check(figure, RESULTS, log=lambda *words, **_: lines.append(" ".join(map(str, words)))) == []
    # every listed run is in the committed table and was compared, value by value
    compared = [line for line in lines if line.endswith("identical")]
    assert len(compared) == len(reproduce.CHECK_RUNS[figure]), lines
    assert all(int(line.rsplit(": ", 1)[1].split()[0]) >= 15 for line in compared)  # the whole summary
    assert snapshot(RESULTS) == before  # the committed files are not touched


def test_figure_16_checks_the_three_runs_of_the_issue():
    assert set(reproduce.CHECK_RUNS["fig16"]) == {("rules", "rule=least_confident,tau_minutes=15.0,seed=0"),
                                                  ("rules", "rule=random,tau_minutes=25.0,seed=3"),
                                                  ("rules", "rule=most_confident,tau_minutes=40.0,seed=7")}


def test_a_number_that_does_not_re_derive_is_listed_and_the_check_exits_1(tmp_path, capsys):
    runs = pd.read_parquet(RESULTS / "fig16" / "runs.parquet")
    changed = runs.run == "rule=random,tau_minutes=25.0,seed=3"
    assert changed.sum() == 1
    runs.loc[changed, "delivered"] += 1
    (tmp_path / "fig16").mkdir()
    runs.to_parquet(tmp_path / "fig16" / "runs.parquet")
    assert cli.main(["reproduce", "fig16", "--check", "--out", str(tmp_path)]) == 1
    out = capsys.readouterr().out
    committed = int(runs.loc[changed, "delivered"].iloc[0])
    assert (f"differs: fig16 rules rule=random,tau_minutes=25.0,seed=3: delivered committed {committed}, "
            f"re-run {committed - 1}") in out
    assert "rules rule=least_confident,tau_minutes=15.0,seed=0:" in out and "values that differ: 1" in out
    assert sorted(p.name for p in tmp_path.rglob("*")) == ["fig16", "runs.parquet"]  # nothing else written


def test_a_figure_without_its_runs_table_is_refused(tmp_path, capsys):
    assert cli.main(["reproduce", "fig17", "--check", "--out", str(tmp_path)]) == 2
    assert "fig17/runs.parquet is missing: run dronefleet reproduce fig17 first" in capsys.readouterr().err
    assert not any(tmp_path.iterdir())


@pytest.mark.parametrize("figure, content", [("fig16", b"x\n"), ("fig16", b""), ("fig16", b"PAR1" * 3),
                                             ("fig09", b"x\n")])
def test_a_runs_table_that_is_not_parquet_is_refused_in_one_line(tmp_path, capsys, figure, content):
    path = tmp_path / figure / "runs.parquet"
    path.parent.mkdir()
    path.write_bytes(content)
    assert cli.main(["reproduce", figure, "--check", "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err and len(err.splitlines()) == 1, err
    assert f"{str(path)!r} is not a readable parquet file (" in err and f"run dronefleet reproduce {figure} " in err
    assert sorted(p.name for p in tmp_path.rglob("*")) == [figure, "runs.parquet"]  # nothing else written
