"""The items study in ``dronefleet reproduce`` (items-fig01..items-fig12, items-ttests): its contract,
the experiments' sweep files, the tables (pairing by trial index), the t-tests, --check, Figs 1-2."""

import math

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from dronefleet import cli, reproduce, sweeps
from dronefleet.contract import FigureStudy
from dronefleet.items import experiments, scenario, study

pytest.importorskip("matplotlib")


@pytest.fixture(scope="module")
def quick_fig04(tmp_path_factory):
    """``reproduce items-fig04 --quick`` once: (results root, exit code)."""
    out = tmp_path_factory.mktemp("items-study")
    code = cli.main(["reproduce", "items-fig04", "--quick", "--jobs", "1", "--out", str(out)])
    return out, code


@pytest.fixture(scope="module")
def quick_e0(tmp_path_factory):
    out = tmp_path_factory.mktemp("items-e0")
    assert cli.main(["reproduce", "items-fig01", "items-fig02", "--quick", "--out", str(out)]) == 0
    return out / "quick"


def test_the_study_meets_the_figure_study_contract():
    hook = scenario.study()
    for name in FigureStudy.__annotations__:
        assert hasattr(hook, name), name
    for name in ("run_together", "tidy", "draw", "check"):
        assert callable(getattr(hook, name))
    assert hook.FIGURES == scenario.FIGURES == (*(f"items-fig{k:02d}" for k in range(1, 13)), "items-ttests",
                                                "items-verdicts")
    assert reproduce.studies()["items"] is hook
    assert set(hook.CHECK_CONFIGS) == set(hook.FIGURES) - {"items-fig01", "items-fig02", "items-verdicts"}
    listing = reproduce.list_studies()
    assert [line.split(":")[0] for line in listing.splitlines() if not line.startswith(" ")] == [
        "delivery", "replenishment", "items", "lunar"]
    assert "items-fig12 items-ttests items-verdicts" in listing


def test_the_sweep_files_are_the_grids_of_section_11():
    sizes = {}
    for experiment in experiments.EXPERIMENTS:
        configs = [run.config for run in sweeps.load_sweep(experiments.grid_path(experiment)).runs]
        assert {c.trials for c in configs} == {20} and {c.steps for c in configs} == {1000}
        sizes[experiment] = len(configs)
    # E1/E2: 200 cells x (R, GR, CAS x 2 rules); E3: 1000 cells x 4; E4a: 200 cells x (R + 2 x (GRIC, GR) + 4 CAS)
    assert sizes == {"e1": 800, "e2": 800, "e3": 4000, "e4a": 1800, "e4b": 450, "e5": 54}
    e4a = [run.config for run in sweeps.load_sweep(experiments.grid_path("e4a")).runs]
    assert sorted({c.capacity for c in e4a}) == list(range(1, 21))
    assert {(c.cas_variant, c.lam_hat_source) for c in e4a if c.algorithm == "CAS"} == {
        (v, s) for v in ("max_expected", "rate") for s in ("value", "mu")}


def test_reproduce_items_fig04_quick_writes_its_table_and_files(quick_fig04):
    out, code = quick_fig04
    assert code == 0
    d = out / "quick" / "items-fig04"
    for name in ("items-fig04", "items-fig04-cas-rate"):  # the defaults (CAS max_expected), the other CAS rule
        for suffix in ("png", "pdf", "svg"):
            assert (d / f"{name}.{suffix}").stat().st_size > 0
    runs = pd.read_parquet(d / "runs.parquet")
    assert list(runs.columns) == ["experiment", *experiments.CONFIG_COLUMNS, *experiments.RESULT_COLUMNS]
    assert set(runs["capacity"]) == set(study.PANELS) and set(runs["n_robots"]) == set(study.QUICK_KEEP["n_robots"])
    assert set(runs["algorithm"]) == {"R", "GR", "CAS"}
    assert len(runs) == 2 * 4 * 4 * study.QUICK_CHANGES["trials"]  # n x c x (R, GR, CAS x 2) x trials


def test_the_same_trial_index_has_the_same_seed_in_every_algorithm_and_cell(quick_fig04):
    runs = pd.read_parquet(quick_fig04[0] / "quick" / "items-fig04" / "runs.parquet")
    seeds = runs.groupby("trial")["seed"].unique()
    assert all(len(s) == 1 for s in seeds)
    assert {t: s[0] for t, s in seeds.items()} == {t: 2015 * 2**32 + t for t in (1, 2)}
    # and a configuration's trials are distinct draws
    assert runs.groupby(["algorithm", "cas_variant", "n_robots", "capacity"])["seed"].nunique().eq(2).all()


def test_the_t_test_on_a_hand_made_example():
    a = np.array([12.0, 15.0, 11.0, 18.0, 14.0, 16.0])
    b = np.array([10.0, 14.0, 11.5, 15.0, 12.0, 13.0])
    got = experiments.paired_ttest(a, b)
    d = a - b
    t = d.mean() / (d.std(ddof=1) / math.sqrt(len(d)))
    assert got["t_paired"] == pytest.approx(t, rel=1e-12)
    assert got["p_paired"] == pytest.approx(stats.ttest_rel(a, b).pvalue, rel=1e-12)
    assert got["p_paired"] == pytest.approx(2 * stats.t.sf(abs(t), len(d) - 1), rel=1e-9)
    assert got["p_unpaired"] == pytest.approx(stats.ttest_ind(a, b).pvalue, rel=1e-12)
    assert got["pairs"] == 6 and got["mean_diff"] == pytest.approx(d.mean())


def test_the_t_test_table_pairs_runs_by_robots_and_trial():
    rng = np.random.default_rng(3)
    rows = []
    for algorithm in ("GR", "CAS", "R"):
        for n in (1, 2, 3):
            for trial in (1, 2, 3, 4):
                rows.append({"experiment": "e1", "algorithm": algorithm, "cas_variant": "max_expected",
                             "lam_hat_source": "value", "n_robots": n, "capacity": 5, "trial": trial,
                             "rate": 10.0 * n + trial + rng.normal() + (3.0 if algorithm == "GR" else 0.0)})
    runs = pd.DataFrame(rows)
    table = study.ttest_table(runs.sample(frac=1.0, random_state=1))  # the order of rows does not matter
    assert list(zip(table["a"], table["b"])) == [("GR", "CAS"), ("GR", "R")]
    for row in table.itertuples():
        key = ["n_robots", "trial"]
        a = runs[runs.algorithm == row.a].sort_values(key)["rate"].to_numpy()
        b = runs[runs.algorithm == row.b].sort_values(key)["rate"].to_numpy()
        assert row.pairs == 12
        assert row.p_paired == pytest.approx(stats.ttest_rel(a, b).pvalue, rel=1e-12)
        assert row.p_unpaired == pytest.approx(stats.ttest_ind(a, b).pvalue, rel=1e-12)


def test_check_passes_on_a_fresh_quick_run(quick_fig04):
    out, _ = quick_fig04
    lines = []
    assert reproduce.check("items-fig04", out, quick=True, log=lambda *a, **k: lines.append(" ".join(map(str, a)))) \
        == []
    assert any(line.endswith("identical") for line in lines)


def test_check_reports_a_tampered_value_and_exits_1(quick_fig04, tmp_path, capsys):
    out, _ = quick_fig04
    runs = pd.read_parquet(out / "quick" / "items-fig04" / "runs.parquet")
    changed = (runs.algorithm == "R") & (runs.n_robots == 5) & (runs.capacity == 5) & (runs.trial == 2)
    assert changed.sum() == 1
    runs.loc[changed, "served"] += 1
    (tmp_path / "quick" / "items-fig04").mkdir(parents=True)
    runs.to_parquet(tmp_path / "quick" / "items-fig04" / "runs.parquet")
    assert cli.main(["reproduce", "items-fig04", "--quick", "--check", "--out", str(tmp_path)]) == 1
    output = capsys.readouterr().out
    assert "items-fig04 algorithm=R,n_robots=5,capacity=5 trial 2: served committed" in output
    assert "values that differ: 1" in output


def test_fig1_is_the_closed_form_logistic(quick_e0):
    curve = pd.read_parquet(quick_e0 / "items-fig01" / "curve.parquet")
    e0 = experiments.E0
    t = curve["step"].to_numpy()
    assert t.tolist() == list(range(e0["steps"] + 1))
    closed = e0["K"] / (1.0 + (e0["K"] - e0["x0"]) / e0["x0"] * np.exp(-e0["lambda_g"] * t))
    np.testing.assert_allclose(curve["x"], closed, rtol=1e-14)
    assert curve["x"].iloc[0] == e0["x0"]


def test_fig2_paths_start_at_x0_and_its_noise_free_curve_is_fig1s(quick_e0):
    paths = pd.read_parquet(quick_e0 / "items-fig02" / "paths.parquet")
    e0 = experiments.E0
    assert paths["path"].nunique() == e0["paths"] == 100
    assert (paths.loc[paths["step"] == 0, "x"] == e0["x0"]).all()
    assert paths["step"].max() == 400 and (paths["x"] >= 0).all()
    assert paths.groupby("step")["x"].std().iloc[-1] > 0  # the paths spread
    fig1 = pd.read_parquet(quick_e0 / "items-fig01" / "curve.parquet")
    fig2 = pd.read_parquet(quick_e0 / "items-fig02" / "curve.parquet")
    assert fig2.equals(fig1)
    # each path is Eq. 10 with its own deviates: step 1 from x0
    x1 = paths[paths["step"] == 1].sort_values("path")["x"].to_numpy()
    drift = e0["x0"] + e0["lambda_g"] * e0["x0"] * (1 - e0["x0"] / e0["K"]) + 0.5 * e0["sigma_e"] ** 2 * e0["x0"]
    z = (x1 - drift) / (e0["sigma_e"] * e0["x0"])
    assert abs(z.mean()) < 0.4 and 0.7 < z.std() < 1.3


def test_check_re_derives_figs_1_and_2(quick_e0):
    assert reproduce.check("items-fig02", quick_e0.parent, quick=True) == []


@pytest.mark.parametrize("column, value, named", [("algorithm", "ZZ", "'ZZ'"), ("n_robots", 0, "n_robots = 0")])
def test_a_table_holding_a_configuration_the_model_refuses_is_one_line(quick_fig04, tmp_path, capsys, column, value,
                                                                       named):
    out, _ = quick_fig04
    runs = pd.read_parquet(out / "quick" / "items-fig04" / "runs.parquet")
    runs.loc[3, column] = value
    d = tmp_path / "quick" / "items-fig04"
    d.mkdir(parents=True)
    runs.to_parquet(d / "runs.parquet")
    assert cli.main(["reproduce", "items-fig04", "--quick", "--redraw", "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "runs.parquet" in err[0] and named in err[0]
    assert not list(d.glob("*.png"))


@pytest.mark.parametrize("value", ["zz", "../x", "e2"])
@pytest.mark.parametrize("command", ["--check", "--redraw"])
def test_a_table_naming_an_experiment_not_the_figures_is_one_line(quick_fig04, tmp_path, capsys, value, command):
    # the experiment names the sweep file --check runs again: never a path from the table
    out, _ = quick_fig04
    runs = pd.read_parquet(out / "quick" / "items-fig04" / "runs.parquet")
    runs["experiment"] = value
    d = tmp_path / "quick" / "items-fig04"
    d.mkdir(parents=True)
    runs.to_parquet(d / "runs.parquet")
    assert cli.main(["reproduce", "items-fig04", "--quick", command, "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"dronefleet: error: {d / 'runs.parquet'}: experiment {value!r} is not one of this figure's (e1)"]


def test_redrawing_gives_the_same_bytes(quick_fig04):
    out, _ = quick_fig04
    d = out / "quick" / "items-fig04"
    before = {path: path.read_bytes() for path in d.iterdir() if path.suffix in (".png", ".pdf", ".svg")}
    assert len(before) == 6
    for path in before:
        path.unlink()
    assert cli.main(["reproduce", "items-fig04", "--quick", "--redraw", "--out", str(out)]) == 0
    assert {path: path.read_bytes() for path in before} == before
