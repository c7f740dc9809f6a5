"""``dronefleet reproduce``: every figure in quick mode, its tidy tables, redrawing without simulating,
and where it writes (``--out``, by default not the committed results; ``--update-results``)."""

import runpy
import shutil
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest

from dronefleet import cli, reproduce, sweeps
from dronefleet.delivery import analysis, simulation, records as delivery_records
from dronefleet.delivery.fleet import seeded_path

pytest.importorskip("matplotlib")

ROOT = Path(__file__).resolve().parent.parent
FORMATS = ("png", "pdf", "svg")
#: The delivery and replenishment figures (the items study's are tested in test_items_study.py:
#: their quick run alone takes minutes).
FIGURES = (*reproduce.DELIVERY_FIGURES, *reproduce.REPLENISHMENT_FIGURES)
DRAWINGS = {"fig16": ["fig16"], "fig17": ["fig17"], "fig18": ["fig18"],
        "fig19": ["fig19"], "fig20": ["fig20"],
        **{figure: [figure] for figure in reproduce.REPLENISHMENT_FIGURES}}
TABLES = {"fig16": ["outcomes", "backlog"], "fig17": ["accuracy"], "fig18": ["winner_soh"],
          "fig19": ["thresholds", "outcomes", "backlog"], "fig20": ["pending"],
          **{figure: ["runs", "bounds"] for figure in reproduce.REPLENISHMENT_FIGURES}}


@pytest.fixture(scope="module")
def quick(tmp_path_factory):
    """Every figure reproduced in quick mode once; the results root and what it printed."""
    results = tmp_path_factory.mktemp("reproduce")
    lines = []
    drawn = reproduce.reproduce(FIGURES, results, quick=True, jobs=2,
                                log=lambda *a, **k: lines.append(" ".join(map(str, a))))
    return results / "quick", drawn, lines


@pytest.mark.parametrize("figure", FIGURES)
def test_quick_mode_writes_non_empty_tables_and_figures_in_every_format(quick, figure):
    root, drawn, _ = quick
    for name in TABLES[figure]:
        table = pd.read_parquet(root / figure / f"{name}.parquet")
        assert len(table) > 0, name
    for name in DRAWINGS[figure]:
        for suffix in FORMATS:
            path = root / figure / f"{name}.{suffix}"
            assert path in drawn[figure]
            assert path.stat().st_size > 10_000


def test_the_tidy_tables_hold_every_run_and_week(quick):
    root, _, _ = quick
    outcomes = pd.read_parquet(root / "fig16" / "outcomes.parquet")
    assert len(outcomes) == 3 * 6 * len(reproduce.QUICK_SEEDS)
    assert sorted(outcomes.tau_minutes.unique()) == [15.0, 20.0, 25.0, 30.0, 35.0, 40.0]
    backlog = pd.read_parquet(root / "fig16" / "backlog.parquet")
    assert len(backlog) == len(outcomes) * 2  # two weeks
    accuracy = pd.read_parquet(root / "fig17" / "accuracy.parquet")
    assert sorted(accuracy.rule.unique()) == ["least_confident", "most_confident", "random"]
    assert accuracy.week.tolist().count(1) == 3 and (accuracy.uavs == 25 * len(reproduce.QUICK_SEEDS)).all()
    grid = pd.read_parquet(root / "fig18" / "winner_soh.parquet")
    assert len(grid) == 10 * 81 * 91
    assert (grid.runs == len(reproduce.QUICK_SEEDS)).all()
    thresholds = pd.read_parquet(root / "fig19" / "thresholds.parquet")
    assert thresholds.theta.tolist() == [50.0, 60.0, 70.0, 80.0, 90.0, 100.0] and thresholds.best.sum() == 1
    pending = pd.read_parquet(root / "fig20" / "pending.parquet")
    assert sorted(pending.rule.unique()) == ["least_confident", "reservation"]
    assert len(pending) == 2 * len(reproduce.QUICK_SEEDS) * 2


def test_figure_20_starts_from_the_rules_sweeps_learned_fleets(quick):
    root, _, _ = quick
    study = reproduce.Study(root.parent, quick=True)
    rules, reservations = study.sweep("rules"), study.sweep("reservations")
    for run in reservations.runs:
        path = run.path(study.out("reservations"), "summary")
        config = delivery_records.read_config(path)
        learned = next(r for r in rules.runs if r.config.rule == "least_confident"
                       and r.config.tau_minutes == 15.0 and r.config.seed == run.config.seed)
        assert seeded_path(config.fleet_file, config.seed) == learned.path(study.out("rules"), "fleet")
        assert pd.read_parquet(path).period.tolist() == [2]


def test_figure_18_is_the_grid_over_the_final_least_confident_policies(quick):
    root, _, _ = quick
    study = reproduce.Study(root.parent, quick=True)
    fleet = study.table("rules", "fleet", rule="least_confident", tau_minutes=15.0)
    final = fleet[fleet.week == 2]
    expected = analysis.winner_soh_grid(final, study.sweep("rules").runs[0].config)
    pd.testing.assert_frame_equal(pd.read_parquet(root / "fig18" / "winner_soh.parquet"), expected)


def test_a_second_run_reuses_every_run(quick, capsys):
    root, drawn, _ = quick
    lines = []
    reproduce.reproduce(["fig19"], root.parent, quick=True, jobs=1,
                        log=lambda *a, **k: lines.append(" ".join(map(str, a))))
    assert any("sweep thresholds" in line and "ran 0 " in line and "72 reused" in line for line in lines)


def test_figure_19_shows_the_best_theta_by_default_and_the_one_theta_names(quick, tmp_path):
    root, _, _ = quick
    best = pd.read_parquet(root / "fig19" / "thresholds.parquet").query("best").theta.item()
    for name in ("outcomes", "backlog"):
        rules = pd.read_parquet(root / "fig19" / f"{name}.parquet").rule.unique().tolist()
        assert sorted(rules) == ["least_confident", f"threshold({best:g})"]
    other = 100.0 if best != 100.0 else 50.0
    shutil.copytree(root, tmp_path / "quick")  # a copy: the module's tables stay the default's
    reproduce.reproduce(["fig19"], tmp_path, quick=True, jobs=1, theta=other, log=lambda *a, **k: None)
    for name in ("outcomes", "backlog"):
        rules = pd.read_parquet(tmp_path / "quick" / "fig19" / f"{name}.parquet").rule.unique().tolist()
        assert sorted(rules) == ["least_confident", f"threshold({other:g})"]
    # The table still marks the criterion's choice.
    pd.testing.assert_frame_equal(pd.read_parquet(tmp_path / "quick" / "fig19" / "thresholds.parquet"),
                                  pd.read_parquet(root / "fig19" / "thresholds.parquet"))


@pytest.mark.parametrize("arguments, message", [
    (["fig19", "--theta", "75"], "--theta 75 is not a threshold of thresholds.toml: one of 50, 60, 70, 80, 90, 100"),
    (["fig19", "--theta", "80.0000001"], "--theta 80.0000001 is not a threshold of thresholds.toml: one of 50,"),
    (["fig19", "--theta", "nan"], "--theta nan is not a threshold of thresholds.toml: one of 50,"),
    (["fig16", "--theta", "80"], "--theta 80 chooses Figure 19's threshold: reproduce fig19 (or all) with it"),
    (["fig19", "--theta", "80", "--redraw"], "--theta 80 chooses the runs in fig19's tables, which --redraw"),
    (["fig19", "--theta", "80", "--check"], "--check re-runs runs and --theta chooses what fig19 draws"),
])
def test_a_theta_that_cannot_apply_is_refused_in_one_line_before_any_run(tmp_path, monkeypatch, capsys,
                                                                         arguments, message):
    def forbidden(*args, **kwargs):
        raise AssertionError("no run may start with a --theta that cannot apply")

    monkeypatch.setattr(reproduce, "run_sweep", forbidden)
    assert cli.main(["reproduce", *arguments, "--quick", "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert message in err and len(err.splitlines()) == 1
    assert not any(tmp_path.iterdir())


def test_redrawing_reads_only_the_parquet_tables(quick, monkeypatch):
    root, drawn, _ = quick
    before = {path: path.read_bytes() for paths in drawn.values() for path in paths}

    def forbidden(*args, **kwargs):
        raise AssertionError("redrawing must not simulate or read a sweep")

    monkeypatch.setattr(simulation, "simulate", forbidden)
    monkeypatch.setattr(reproduce, "run_sweep", forbidden)
    monkeypatch.setattr(reproduce, "dataset", forbidden)
    for paths in drawn.values():
        for path in paths:
            path.unlink()
    assert cli.main(["reproduce", *FIGURES, "--quick", "--redraw", "--out", str(root.parent)]) == 0
    assert {path: path.read_bytes() for path in before} == before  # the same bytes again


def test_figures_drawn_side_by_side_in_worker_processes_are_the_bytes_drawn_in_one_process(quick):
    root, drawn, _ = quick  # drawn with jobs=2: one figure per process, in this one and two workers
    before = {path: path.read_bytes() for paths in drawn.values() for path in paths}
    for path in before:
        path.unlink()
    assert cli.main(["reproduce", *FIGURES, "--quick", "--redraw", "--jobs", "1", "--out", str(root.parent)]) == 0
    assert {path: path.read_bytes() for path in before} == before


def test_the_tables_of_one_sweep_inspect_its_runs_files_once(quick, monkeypatch):
    root, _, _ = quick
    inspected = []
    damage = sweeps.damage
    monkeypatch.setattr(sweeps, "damage", lambda run, out: inspected.append(run) or damage(run, out))
    study = reproduce.Study(root.parent, quick=True, jobs=1)
    for table in ("summary", "orders", "fleet"):
        assert len(study.table("rules", table)) > 0
    runs = study.sweep("rules").runs
    assert sorted(run.id for run in inspected) == sorted(run.id for run in runs)  # once each, not once per table


def test_redraw_without_tables_says_what_to_run(tmp_path, capsys):
    assert cli.main(["reproduce", "fig17", "--redraw", "--out", str(tmp_path)]) == 2
    assert "run dronefleet reproduce fig17 without --redraw first" in capsys.readouterr().err


def test_every_figure_of_every_study_has_its_experiments_script(tmp_path, monkeypatch, capsys):
    """``experiments/<figure>.py`` for each figure of ``reproduce --list``, a link to reproduce.py that
    reaches that figure: asked to redraw where no tables are, it is refused naming the figure."""
    scripts = ROOT / "experiments"
    # besides, the lunar analyses of docs/lunar-readings.md (not a figure)
    assert sorted(p.stem for p in scripts.glob("*.py")) == sorted((*reproduce.FIGURES, "reproduce", "lunar-diagnosis"))
    for figure in reproduce.FIGURES:
        script = scripts / f"{figure}.py"
        assert script.resolve() == (scripts / "reproduce.py").resolve()
        monkeypatch.setattr(sys, "argv", [str(script), "--redraw", "--out", str(tmp_path)])
        with pytest.raises(SystemExit) as stop:  # in this process: one interpreter start per figure is seconds
            runpy.run_path(str(script), run_name="__main__")
        assert stop.value.code == 2
        assert f"run dronefleet reproduce {figure} without --redraw first" in capsys.readouterr().err
    assert not any(tmp_path.iterdir())
    # one as a user runs it, in its own process
    done = subprocess.run([sys.executable, str(scripts / "items-ttests.py"), "--redraw", "--out", str(tmp_path)],
                          capture_output=True, text=True)
    assert done.returncode == 2 and "run dronefleet reproduce items-ttests without --redraw first" in done.stderr


def test_quick_sweeps_are_the_study_sweeps_with_fewer_seeds_and_weeks(tmp_path):
    study = reproduce.Study(tmp_path, quick=True)
    full = reproduce.Study(tmp_path)
    for name in ("rules", "thresholds", "reservations"):
        q, f = study.sweep(name), full.sweep(name)
        assert q.grid == f.grid and q.seeds == reproduce.QUICK_SEEDS and len(f.seeds) == 20
        assert {r.config.horizon_weeks for r in q.runs} == {2.0} and {r.config.horizon_weeks for r in f.runs} == {8.0}
    assert len(full.sweep("rules").runs) == 360 and len(full.sweep("thresholds").runs) == 720
    assert isinstance(study.sweep("rules"), sweeps.Sweep)


def test_without_matplotlib_nothing_runs(tmp_path, monkeypatch, capsys):
    from dronefleet import figstyle

    def missing():
        raise ImportError("drawing figures needs matplotlib, a dependency of dronefleet: pip install matplotlib")

    def forbidden(*args, **kwargs):
        raise AssertionError("no run may start without matplotlib")

    monkeypatch.setattr(figstyle, "require_matplotlib", missing)  # looked up at each call
    monkeypatch.setattr(reproduce, "run_sweep", forbidden)
    assert cli.main(["reproduce", "fig16", "--quick", "--out", str(tmp_path)]) == 2
    assert "pip install matplotlib" in capsys.readouterr().err
    assert not any(tmp_path.iterdir())


@pytest.mark.parametrize("figure, runs", [("fig16", 36), ("fig17", 6), ("fig18", 2), ("fig19", 72 + 12),
                                          ("fig20", 4)])
def test_each_figure_lists_its_runs_and_they_re_derive(quick, figure, runs):
    root, _, _ = quick  # quick mode: 2 seeds
    table = pd.read_parquet(root / figure / "runs.parquet")
    assert len(table) == runs and not table.duplicated(["sweep", "run"]).any()
    assert {"delivered", "median_delivery_time_s", "seed"} <= set(table.columns)
    lines = []
    assert reproduce.check(figure, root.parent, quick=True, log=lambda *a, **k: lines.append(" ".join(map(str, a)))) == []
    assert any(line.endswith("identical") for line in lines)  # seeds 0-1 of CHECK_RUNS, the others skipped


def _copy_tables(source, root, figure):
    (root / figure).mkdir(parents=True)
    for name in TABLES[figure]:
        shutil.copy(source / figure / f"{name}.parquet", root / figure)


def test_reproduce_writes_to_its_own_folder_by_default_never_to_the_committed_results(quick, tmp_path, monkeypatch):
    root, drawn, _ = quick
    monkeypatch.chdir(tmp_path)
    _copy_tables(root, tmp_path / "dronefleet-results" / "quick", "fig20")
    _copy_tables(root, tmp_path / "results" / "quick", "fig20")  # as if committed
    committed = {path: path.read_bytes() for path in (tmp_path / "results").rglob("*") if path.is_file()}
    assert cli.main(["reproduce", "fig20", "--quick", "--redraw"]) == 0
    assert sorted(path.name for path in (tmp_path / "dronefleet-results" / "quick" / "fig20").glob("fig20.*")) == \
        [f"fig20.{suffix}" for suffix in sorted(FORMATS)]
    assert {path: path.read_bytes() for path in (tmp_path / "results").rglob("*") if path.is_file()} == committed


def test_update_results_refreshes_the_committed_figures(quick, tmp_path, monkeypatch):
    root, drawn, _ = quick
    monkeypatch.chdir(tmp_path)
    _copy_tables(root, tmp_path / "results" / "quick", "fig17")
    assert cli.main(["reproduce", "fig17", "--quick", "--redraw", "--update-results"]) == 0
    for suffix in FORMATS:
        assert (tmp_path / "results" / "quick" / "fig17" / f"fig17.{suffix}").read_bytes() == \
            (root / "fig17" / f"fig17.{suffix}").read_bytes()
    assert not (tmp_path / "dronefleet-results").exists()


def test_check_reads_the_committed_results_unless_out_names_another_root(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert cli.main(["reproduce", "fig17", "--check"]) == 2
    assert f"{Path('results') / 'fig17' / 'runs.parquet'} is missing" in capsys.readouterr().err
    assert cli.main(["reproduce", "fig17", "--check", "--out", "elsewhere"]) == 2
    assert f"{Path('elsewhere') / 'fig17' / 'runs.parquet'} is missing" in capsys.readouterr().err
    assert not any(tmp_path.iterdir())


def test_out_and_update_results_exclude_each_other(tmp_path, capsys):
    with pytest.raises(SystemExit) as exit:
        cli.main(["reproduce", "fig17", "--out", str(tmp_path), "--update-results"])
    assert exit.value.code == 2
    assert "not allowed with argument" in capsys.readouterr().err


@pytest.mark.parametrize("redraw", [[], ["--redraw"]])
def test_an_out_under_a_file_is_refused_in_one_line(redraw, tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(reproduce.replenishment, "run_together", lambda *a: pytest.fail("a figure ran"))
    (tmp_path / "notes.txt").write_text("mine\n")
    assert cli.main(["reproduce", "fig10", "--quick", "--out", str(tmp_path / "notes.txt" / "results"), *redraw]) == 2
    assert capsys.readouterr().err == (f"dronefleet: error: cannot write "
                                       f"{str(tmp_path / 'notes.txt' / 'results' / 'quick')!r}: Not a directory\n")
    assert (tmp_path / "notes.txt").read_text() == "mine\n"


def test_committed_results_are_written_only_with_update_results_and_only_where_they_are(tmp_path, monkeypatch,
                                                                                         capsys):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(reproduce, "reproduce", lambda *a, **k: pytest.fail("reproduce ran"))
    assert cli.main(["reproduce", "fig17", "--quick", "--update-results"]) == 2
    assert capsys.readouterr().err == (f"dronefleet: error: --update-results refreshes the committed results/, and "
                                       f"{str(tmp_path)!r} has none: run it from the repository's root, or write "
                                       "elsewhere with --out DIR\n")
    (tmp_path / "results").mkdir()
    for out in ("results", str(tmp_path / "results"), "results/../results"):
        assert cli.main(["reproduce", "fig17", "--quick", "--out", out]) == 2
        assert capsys.readouterr().err == (f"dronefleet: error: --out {str(Path(out))!r} is the committed results/: "
                                           "refresh them with --update-results, or write elsewhere with another "
                                           "--out\n")
    assert not any((tmp_path / "results").iterdir())


def test_an_out_that_is_a_file_is_refused_in_one_line(tmp_path, capsys):
    taken = tmp_path / "notes.txt"
    taken.write_text("mine\n")
    assert cli.main(["reproduce", "fig10", "--quick", "--out", str(taken)]) == 2
    err = capsys.readouterr().err
    assert err == f"dronefleet: error: --out {str(taken)!r} is a file: give the folder to write the results under\n"
    assert taken.read_text() == "mine\n"


@pytest.mark.parametrize("failing", ["table", "drawing"])
def test_a_write_that_fails_is_one_line_and_leaves_no_part_of_its_file(tmp_path, capsys, monkeypatch, failing):
    import errno

    import matplotlib.figure
    import pyarrow.parquet as pq

    def full(writer, path, *args, **kwargs):  # pq.write_table(table, path), Figure.savefig(self, path)
        Path(path).write_bytes(b"x" * 100)
        raise OSError(errno.ENOSPC, "No space left on device")
    monkeypatch.setattr(*((pq, "write_table") if failing == "table" else (matplotlib.figure.Figure, "savefig")),
                        full)
    assert cli.main(["reproduce", "fig09", "--quick", "--jobs", "1", "--out", str(tmp_path)]) == 2
    folder = tmp_path / "quick" / "fig09"
    named = folder / ("runs.parquet" if failing == "table" else "fig09.png")  # a figure's first file
    assert capsys.readouterr().err == f"dronefleet: error: cannot write {str(named)!r}: No space left on device\n"
    left = sorted(p.name for p in folder.iterdir())
    assert left == ([] if failing == "table" else ["bounds.parquet", "runs.parquet"])  # no hidden temporary
