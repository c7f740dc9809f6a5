"""Sampled designs (dronefleet.designs) and their sensitivity analysis (dronefleet.analyze): the
sampling and analysis path checked against functions of known indices (Ishigami's, a linear one),
points mapped to ranges, integers and levels, bad designs refused in one line before any run, a
tiny design sweep of every scenario run locally, as job-array tasks and on Dask into one dataset,
and ``analyze sensitivity`` end to end (table, parquet, figure at the paper standard)."""

import math
from types import SimpleNamespace

import distributed
import numpy as np
import pandas as pd
import pyarrow.parquet as pq
import pytest

import dronefleet
from dronefleet import analyze, cli, designs, figstyle, scenarios, sweeps as sw
from dronefleet.config import SweepError
from test_paper_figures import shown_texts

PI = math.pi
#: A sweep file's head and [set] per scenario: runs of seconds, as tests/conftest.py's tiny grids.
HEADS = {
    "delivery": 'seeds = [0, 1]\n[set]\nhorizon_weeks = 0.02\nn_uavs = 3\n',
    "replenishment": 'scenario = "replenishment"\n[set]\ntrials = 2\nticks = 200\n',  # no root seed
    "items": 'scenario = "items"\nseeds = [1, 3]\n[set]\ntrials = 2\nsteps = 50\n',
    "lunar": 'scenario = "lunar"\nseeds = [0, 2]\n[set]\nruns = 2\nn_robots = 30\nduration_s = 60.0\n',
}
#: Two keys per scenario for tiny designs: a float range and an integer range or levels.
RANGES = {
    "delivery": 'tau_minutes = [15.0, 40.0]\nrule = ["least_confident", "random"]\n',
    "replenishment": 'work_ratio = [0.1, 1.0]\nn_chargers = [1, 3]\n',
    "items": 'speed = [0.1, 0.3]\ncapacity = [2, 10]\n',
    "lunar": 'eps = [0.0, 0.2]\nlayout = ["OPEN", "SOFT-RT"]\n',
}


def tiny(name, design=None, ranges=None):
    """A tiny design sweep of scenario ``name``: by default 4 runs, 2 points x 2 root seeds (a
    replenishment run has no root seed: 4 points)."""
    design = design or f'method = "lhs"\nsamples = {4 if name == "replenishment" else 2}'
    return (f'[sweep]\nname = "tinydesign"\nruns_per_task = 2\n{HEADS[name]}'
            f'[design]\n{design}\n[design.ranges]\n{RANGES[name] if ranges is None else ranges}')


def write(tmp_path, text, name="design.toml"):
    path = tmp_path / name
    path.write_text(text)
    return path


@pytest.fixture
def no_array(monkeypatch):
    for name, _ in sw.TASK_VARIABLES:
        monkeypatch.delenv(name, raising=False)


# ---------------------------------------------------------------------------- sampling and analysis path


def unit_design(table, ranges):
    """A design read as a sweep file's [design] is, over keys of the types of ``ranges``' values."""
    scenario = SimpleNamespace(defaults={key: (0 if isinstance(spec[0], int) and not isinstance(spec[0], bool) else
                                               spec[0] if isinstance(spec[0], (str, bool)) else 0.0)
                                         for key, spec in ranges.items()})
    return designs.read_design({**table, "ranges": ranges}, ranges, scenario, "[design]", sw.MAX_RUNS)


def ishigami(x1, x2, x3, a=7.0, b=0.1):
    return np.sin(x1) + a * np.sin(x2) ** 2 + b * x3 ** 4 * np.sin(x1)


def test_sobol_indices_of_the_ishigami_function_are_its_known_ones():
    # Ishigami & Homma (1990), a = 7, b = 0.1, x uniform on [-pi, pi]: the analytic indices (Saltelli et al. 2008, 4.9)
    a, b = 7.0, 0.1
    v1 = 0.5 * (1 + b * PI ** 4 / 5) ** 2
    v2 = a ** 2 / 8
    v13 = b ** 2 * PI ** 8 * (1 / 18 - 1 / 50)
    total = v1 + v2 + v13
    design = unit_design({"method": "sobol", "samples": 1024, "sampling_seed": 3},
                         {"x1": [-PI, PI], "x2": [-PI, PI], "x3": [-PI, PI]})
    points = pd.DataFrame(design.points, columns=list(design.keys))
    points["y"] = ishigami(points["x1"], points["x2"], points["x3"])
    table = analyze.indices(design, points, ("y",), resamples=200).set_index(["index", "key", "other_key"])["value"]
    expected = {("S1", "x1", ""): v1 / total, ("S1", "x2", ""): v2 / total, ("S1", "x3", ""): 0.0,
                ("ST", "x1", ""): (v1 + v13) / total, ("ST", "x2", ""): v2 / total, ("ST", "x3", ""): v13 / total,
                ("S2", "x1", "x3"): v13 / total, ("S2", "x1", "x2"): 0.0, ("S2", "x2", "x3"): 0.0}
    for where, value in expected.items():
        assert table[where] == pytest.approx(value, abs=0.05), where
    assert len(table) == 3 + 3 + 3


@pytest.mark.parametrize("method", ["sobol", "morris"])
def test_the_same_points_give_the_same_intervals(method):
    design = unit_design({"method": method, "samples": 16}, {"x1": [-PI, PI], "x2": [-PI, PI], "x3": [-PI, PI]})
    points = pd.DataFrame(design.points, columns=list(design.keys))
    points["y"] = ishigami(points["x1"], points["x2"], points["x3"])
    first = analyze.indices(design, points, ("y",), resamples=20)
    assert first["ci_low"].notna().any()
    pd.testing.assert_frame_equal(first, analyze.indices(design, points, ("y",), resamples=20))


def test_morris_screening_of_a_linear_function_gives_its_slopes_per_whole_range():
    design = unit_design({"method": "morris", "samples": 20, "morris_levels": 4},
                         {"a": [0.0, 2.0], "b": [10.0, 11.0], "c": [5.0, 6.0]})
    points = pd.DataFrame(design.points, columns=list(design.keys))
    points["y"] = 3.0 * points["a"] - 4.0 * points["b"]  # c does nothing
    table = analyze.indices(design, points, ("y",), resamples=50).set_index(["index", "key"])["value"]
    # mu* is the change over a key's whole range: 3 x 2 for a, 4 x 1 for b; sigma 0 for a linear function (up to
    # the values' rounding to 6 significant digits)
    assert table["mu_star", "a"] == pytest.approx(6.0, rel=1e-3)
    assert table["mu_star", "b"] == pytest.approx(4.0, rel=1e-3)
    assert table["mu", "b"] == pytest.approx(-4.0, rel=1e-3)
    assert table["mu_star", "c"] == 0.0
    assert table["sigma", "a"] == pytest.approx(0.0, abs=1e-3)


@pytest.mark.parametrize("method, samples, expected", [("sobol", 8, 8 * (2 * 3 + 2)), ("morris", 5, 5 * 4),
                                                       ("lhs", 7, 7), ("sobol-seq", 16, 16)])
def test_each_method_gives_its_number_of_points_seeded(method, samples, expected):
    ranges = {"f": [0.0, 1.0], "n": [1, 3], "w": ["x", "y", "z"]}
    design = unit_design({"method": method, "samples": samples, "sampling_seed": 1}, ranges)
    assert len(design.points) == expected == designs.n_points(method, samples, 3)
    assert design.points == unit_design({"method": method, "samples": samples, "sampling_seed": 1}, ranges).points
    assert design.points != unit_design({"method": method, "samples": samples, "sampling_seed": 2}, ranges).points


def test_points_map_to_their_ranges_integers_and_levels_equally_likely():
    design = unit_design({"method": "lhs", "samples": 3000}, {"f": [2.0, 5.0], "n": [1, 3], "w": ["x", "y", "z"]})
    f, n, w = zip(*design.points)
    assert all(2.0 <= x <= 5.0 and float(f"{x:.6g}") == x for x in f)  # 6 significant digits
    assert all(type(x) is int for x in n) and all(type(x) is str for x in w)
    for values, levels in ((n, (1, 2, 3)), (w, ("x", "y", "z"))):  # a Latin hypercube: exactly a third each
        assert [values.count(level) for level in levels] == [1000, 1000, 1000]
    assert designs.Factor("n", 1, 3, integer=True).values(np.array([0.0, 1.0])) == [1, 3]


def test_points_that_round_alike_share_one_run(tmp_path):
    sweep = sw.load_sweep(write(tmp_path, tiny("replenishment", 'method = "sobol"\nsamples = 4',
                                               'work_ratio = [0.1, 1.0]\nn_chargers = [1, 2]\n')))
    assert len(sweep.design.points) == 4 * 6
    distinct = len(set(sweep.design.points))
    assert len(sweep.runs) == distinct < 24
    assert sweep.describe() == f"sobol design: 4 samples of 2 keys = 24 points ({distinct} distinct) = {distinct} runs"
    assert sweep.runs[0].keys == ("n_chargers", "work_ratio")  # replenishment has no root seed
    assert sw.load_sweep(write(tmp_path, tiny("items"), "items.toml")).runs[0].keys == ("capacity", "speed", "root_seed")


# ---------------------------------------------------------------------------- bad designs


@pytest.mark.parametrize("design, ranges, fragment", [
    ('method = "saltelli"\nsamples = 4', None, "method = 'saltelli' is not a method. Allowed: sobol, morris, lhs, "
                                               "sobol-seq"),
    ('method = "lhs"\nsamples = 4', 'work_ratio = [1.0, 0.5]\n', "work_ratio = [1.0, 0.5]: low must be below high"),
    ('method = "lhs"\nsamples = 4', 'work_ratio = [1.0, 1.0]\n', "low must be below high"),
    ('method = "lhs"\nsamples = 4', 'warp_factor = [1.0, 2.0]\n', "warp_factor"),
    ('method = "sobol"\nsamples = 32768', None, "gives 196,608 points x 1 seed = 196,608 runs; a sweep may hold at most 100,000 runs"),
    ('method = "sobol"\nsamples = 100', None, "samples = 100: a sobol design takes a power of 2"),
    ('method = "lhs"\nsamples = 1', None, "samples must be an integer >= 2, got 1"),
    ('method = "lhs"\nsamples = 4\nmorris_levels = 6', None, 'morris_levels is an integer >= 2, for method = "morris" only'),
    ('method = "lhs"\nsamples = 4\nrepeats = 2', None, "unknown key 'repeats'. Allowed: method, samples"),
    ('method = "lhs"\nsamples = 4', 'n_chargers = [1.5, 3]\n', "n_chargers must be a range [low, high] of two integers"),
    ('method = "lhs"\nsamples = 4', 'strategy = ["mobile"]\n', "strategy is a word: give its levels"),
    ('method = "lhs"\nsamples = 4', '', "ranges is empty or missing: give [design.ranges]"),
    ('method = "lhs"\nsamples = 4', 'ticks = [0, 10]\n', "ticks"),  # the scenario refuses the point's value
])
def test_bad_designs_are_refused_in_one_line_before_any_run(tmp_path, capsys, design, ranges, fragment):
    path = write(tmp_path, tiny("replenishment", design, ranges))
    for command in ("plan", "run"):
        assert cli.main(["sweep", command, str(path), "--results", str(tmp_path / "out")]) == 2
        err = capsys.readouterr().err
        assert len(err.splitlines()) == 1 and fragment in err, err
    assert not (tmp_path / "out" / "tinydesign" / "summary").exists()


def test_a_grid_and_a_design_together_are_refused(tmp_path, capsys):
    path = write(tmp_path, tiny("replenishment") + "[grid]\nstrategy = [\"mobile\"]\n")
    assert cli.main(["sweep", "plan", str(path), "--results", str(tmp_path)]) == 2
    assert "give [grid] (values to combine) or [design] (ranges to sample), not both" in capsys.readouterr().err


def test_the_root_seed_is_no_design_key(tmp_path):
    with pytest.raises(SweepError, match="seed cannot be set here: it is the seed key, given by"):
        sw.load_sweep(write(tmp_path, tiny("items", ranges="seed = [1, 9]\n")))


def test_a_key_fixed_and_sampled_is_refused(tmp_path):
    with pytest.raises(SweepError, match="ticks is both fixed"):
        sw.load_sweep(write(tmp_path, tiny("replenishment", ranges="ticks = [100, 300]\n")))


# ---------------------------------------------------------------------------- every scenario, every executor


def table_files(out, tables):
    return {p.relative_to(out): p.read_bytes() for table in tables for p in sorted((out / table).rglob("*.parquet"))}


@pytest.mark.parametrize("name", sorted(scenarios.SCENARIOS))
def test_a_design_sweep_runs_locally_as_job_array_tasks_and_on_dask_into_one_dataset(name, tmp_path, monkeypatch,
                                                                                      capsys, no_array):
    path = write(tmp_path, tiny(name))
    tables = scenarios.SCENARIOS[name].tables
    assert cli.main(["sweep", "plan", str(path), "--results", str(tmp_path / "array")]) == 0
    assert "lhs design: " in capsys.readouterr().out
    assert cli.main(["sweep", "run", str(path), "--results", str(tmp_path / "local"), "--jobs", "2"]) == 0
    for task in ("0", "1"):  # what the job array's script runs, task by task
        monkeypatch.setenv("SLURM_ARRAY_TASK_ID", task)
        assert cli.main(["sweep", "run", str(path), "--results", str(tmp_path / "array")]) == 0
    monkeypatch.delenv("SLURM_ARRAY_TASK_ID")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                                  dashboard_address=None) as cluster:
        assert cli.main(["sweep", "run", str(path), "--results", str(tmp_path / "dask"), "--executor", "dask",
                         "--scheduler", cluster.scheduler_address]) == 0
    local = tmp_path / "local" / "tinydesign"
    files = table_files(local, tables)
    assert len(files) == len(tables) * 4
    for results in ("local", "array", "dask"):
        out = tmp_path / results / "tinydesign"
        assert cli.main(["sweep", "status", str(path), "--results", str(tmp_path / results)]) == 0
        assert cli.main(["sweep", "collect", str(path), "--results", str(tmp_path / results)]) == 0
        assert table_files(out, tables) == files
        for name_ in ("collected.parquet", designs.SAMPLES_FILE):
            assert (out / name_).read_bytes() == (local / name_).read_bytes()
    samples = pq.read_table(local / designs.SAMPLES_FILE)
    sweep = sw.load_sweep(path)
    assert samples.column_names == ["sample", *sweep.design.keys, *(f"unit_{k}" for k in sweep.design.keys)]
    assert list(zip(*(samples.column(k).to_pylist() for k in sweep.design.keys))) == list(sweep.design.points)
    assert designs.DESIGN_KEY in samples.schema.metadata


# ---------------------------------------------------------------------------- analyze sensitivity


MORRIS = ('method = "morris"\nsamples = 3', 'work_ratio = [0.1, 1.0]\ncharger_capacity_factor = [1.0, 3.0]\n')


def test_analyze_sensitivity_prints_writes_and_draws_the_indices(tmp_path, capsys, no_array, drawn_figures):
    kept = drawn_figures(analyze)
    path = write(tmp_path, tiny("replenishment", *MORRIS))
    assert cli.main(["sweep", "run", str(path), "--results", str(tmp_path), "--jobs", "2"]) == 0
    capsys.readouterr()
    assert cli.main(["analyze", "sensitivity", str(path), "--results", str(tmp_path), "--metric", "energy",
                     "--metric", "efficiency", "--resamples", "50"]) == 0
    printed = capsys.readouterr().out
    assert "morris design: 3 samples of 2 keys = 9 points" in printed and "95% bootstrap intervals of 50" in printed
    out = tmp_path / "tinydesign"
    written = pd.read_parquet(out / analyze.INDICES_FILE)
    assert list(written.columns) == ["metric", "index", "key", "other_key", "value", "ci_low", "ci_high"]
    assert set(written["index"]) == {"mu_star", "mu", "sigma"} and set(written["metric"]) == {"energy", "efficiency"}
    star = written[written["index"] == "mu_star"]
    assert (star["ci_low"] <= star["value"]).all() and (star["value"] <= star["ci_high"]).all()
    # the Python API gives the same table, and each point's value is its run's mean over its trials
    result = dronefleet.sensitivity(path, ["energy", "efficiency"], results=tmp_path, resamples=50, write=False)
    pd.testing.assert_frame_equal(result.indices, written)
    first = result.samples.iloc[0]
    runs = [r for r in sw.load_sweep(path).runs if (r.value("work_ratio"), r.value("charger_capacity_factor")) ==
            (first["work_ratio"], first["charger_capacity_factor"])]
    energy = np.concatenate([pq.read_table(run.path(out, "summary")).column("energy").to_numpy() for run in runs])
    assert len(runs) == 1 and len(energy) == 2 and first["energy"] == pytest.approx(energy.mean())  # its 2 trials
    for suffix in figstyle.FORMATS:
        assert (out / f"sensitivity.{suffix}").is_file()
    (fig,) = kept  # the paper-figure standard: a page wide for two metrics, no text below 7 pt or outside it
    assert fig.get_size_inches()[0] == figstyle.DOUBLE_COLUMN
    texts = shown_texts(fig)
    renderer, frame = fig.canvas.get_renderer(), fig.bbox
    assert {"(a)", "(b)"} <= {t.get_text() for t in texts}
    for text in texts:
        assert text.get_fontsize() >= figstyle.MIN_FONT_SIZE, text.get_text()
        box = text.get_window_extent(renderer)
        assert frame.x0 - 1 <= box.x0 and box.x1 <= frame.x1 + 1 and frame.y0 - 1 <= box.y0 <= box.y1 <= frame.y1 + 1


@pytest.mark.parametrize("args, fragment", [
    (["--metric", "warp"], "--metric 'warp' is not a metric of the replenishment summary. Allowed: work, energy"),
    (["--metric", "trial"], "--metric 'trial' is not a metric"),
    (["--metric", "work"], "no run of sweep tinydesign is done"),
])
def test_analyze_refuses_bad_metrics_and_unfinished_sweeps_in_one_line(tmp_path, capsys, args, fragment):
    path = write(tmp_path, tiny("replenishment", *MORRIS))
    assert cli.main(["analyze", "sensitivity", str(path), "--results", str(tmp_path), *args]) == 2
    err = capsys.readouterr().err
    assert len(err.splitlines()) == 1 and fragment in err, err


def test_analyze_refuses_a_sweep_with_runs_not_done(tmp_path, capsys, no_array):
    path = write(tmp_path, tiny("replenishment", *MORRIS))
    assert cli.main(["sweep", "run", str(path), "--results", str(tmp_path), "--task-id", "0"]) == 0
    capsys.readouterr()
    assert cli.main(["analyze", "sensitivity", str(path), "--results", str(tmp_path), "--metric", "work"]) == 2
    n = len(sw.load_sweep(path).runs)
    assert f"{n - 2} of the {n} runs of sweep tinydesign are not done" in capsys.readouterr().err


@pytest.mark.parametrize("text, fragment", [
    (tiny("replenishment"), "has a lhs design, which gives no indices: sensitivity analysis takes method sobol or "
                            "morris"),
    ('[sweep]\nscenario = "replenishment"\n[grid]\nwork_ratio = [0.5, 1.0]\n', "is a grid sweep"),
])
def test_analyze_refuses_sweeps_without_indices(tmp_path, capsys, text, fragment):
    assert cli.main(["analyze", "sensitivity", str(write(tmp_path, text)), "--results", str(tmp_path),
                     "--metric", "work"]) == 2
    assert fragment in capsys.readouterr().err


def test_a_constant_metric_is_refused(tmp_path):
    design = unit_design({"method": "morris", "samples": 4}, {"a": [0.0, 1.0], "b": [0.0, 1.0]})
    points = pd.DataFrame(design.points, columns=list(design.keys)).assign(y=2.0)
    with pytest.raises(SweepError, match="'y' is 2 at every sample point of the design: it has no variance"):
        analyze.indices(design, points, ("y",))
