"""Figures 9-12 of the replenishment study: the grids of docs/replenishment-model.md section 10 (sweep files),
``dronefleet reproduce fig09..fig12`` (tables, figure files, --redraw, --check) and the bounds they draw."""

import importlib
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow as pa
import pytest

from dronefleet import cli, figstyle, reproduce, sweeps
from dronefleet.datafiles import read_parquet
from dronefleet.replenishment import Params, bounds, experiments, fixed_work_ceiling, study
from dronefleet.replenishment import figures as rfigures

simulate_module = importlib.import_module("dronefleet.replenishment.simulate")  # the package exports the function

pytest.importorskip("matplotlib")

FIGURES = experiments.FIGURES
TINY_TRIALS, TINY_TICKS = 2, 300


def grid(figure, changes=None):
    """The configurations (Params) of the figure's sweep file, in run order."""
    return [run.config.params for run in sweeps.load_sweep(experiments.grid_path(figure), changes).runs]


def points(configs, *columns):
    return sorted(tuple(getattr(p, c) for c in columns) for p in configs)


def test_the_grids_are_those_of_section_10():
    grids = {figure: grid(figure) for figure in FIGURES}
    assert {f: len(g) for f, g in grids.items()} == {"fig09": 36, "fig10": 18, "fig11": 10, "fig12": 11}
    for g in grids.values():
        assert {p.trials for p in g} == {50} and {p.ticks for p in g} == {6000}
        assert {p.n_workers for p in g} == {6} and {p.worker_capacity for p in g} == {100.0}
        assert len(set(g)) == len(g)
        fixed = [p for p in g if p.strategy == "fixed"]
        assert all(p.n_chargers == 0 and p.transfer_loss == 0.0 for p in fixed)
    fig9 = grids["fig09"]
    assert points([p for p in fig9 if p.mobile], "n_chargers", "charger_capacity_factor") == sorted(
        (n, phi) for n in (1, 2, 4, 6, 8, 10, 12) for phi in (1.0, 1.5, 2.0, 4.0, 6.0))
    assert [p.strategy for p in fig9].count("fixed") == 1
    assert {(p.work_ratio, p.charge_rate, p.transfer_loss) for p in fig9} == {(1.0, 1.0, 0.0)}
    r = [0.1, 0.25, 0.5, 1.0, 1.5, 2.0, 3.0, 4.0, 10.0]
    k = [0.1, 0.25, 0.5, 0.75, 1.0]
    for figure, column, values in (("fig10", "work_ratio", r), ("fig11", "charge_rate", k)):
        configs = grids[figure]
        for strategy, n_m in (("fixed", 0), ("mobile", 6)):
            mine = [p for p in configs if p.strategy == strategy]
            assert sorted(getattr(p, column) for p in mine) == values
            assert {p.n_chargers for p in mine} == {n_m}
        assert all(p.charger_capacity_factor == 2.0 and p.transfer_loss == 0.0 for p in configs)
        other = "charge_rate" if column == "work_ratio" else "work_ratio"
        assert {getattr(p, other) for p in configs} == {1.0}
    fig12 = grids["fig12"]
    mobile = [p for p in fig12 if p.mobile]
    assert [p.transfer_loss for p in mobile] == [round(0.1 * i, 1) for i in range(10)]
    assert {(p.n_chargers, p.charger_capacity_factor) for p in mobile} == {(6, 2.0)}
    assert [p for p in fig12 if not p.mobile] == [Params(ticks=6000).validate()]  # the default fixed one


def test_a_grid_file_with_an_unknown_key_or_a_refused_value_names_it(tmp_path):
    path = tmp_path / "g.toml"
    head = '[sweep]\nscenario = "replenishment"\n[set]\ntrials = 2\n[[grid]]\nstrategy = ["mobile"]\nn_chargers = [2]\n'
    path.write_text(head + 'work_rate = [1.0]\n')
    with pytest.raises(sweeps.SweepError, match="unknown key 'work_rate'"):
        sweeps.load_sweep(path)
    path.write_text(head + 'transfer_loss = [0.5, 1.0]\n')
    with pytest.raises(sweeps.SweepError, match=r"transfer_loss = 1\.0.*\[0, 1\)"):
        sweeps.load_sweep(path)


@pytest.fixture(scope="module")
def tiny(tmp_path_factory):
    """Figures 9-12 reproduced in quick mode at 2 trials x 300 ticks; the results root."""
    results = tmp_path_factory.mktemp("replenishment")
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(study, "QUICK_TRIALS", TINY_TRIALS)
        patch.setattr(study, "QUICK_TICKS", TINY_TICKS)
        drawn = reproduce.reproduce(FIGURES, results, quick=True, jobs=1, log=lambda *a, **k: None)
    return results, drawn


@pytest.mark.parametrize("figure", FIGURES)
def test_quick_mode_writes_every_trial_and_bound_and_the_figure(tiny, figure):
    results, drawn = tiny
    root = results / "quick" / figure
    configs = grid(figure)
    runs = pd.read_parquet(root / "runs.parquet")
    assert len(runs) == len(configs) * TINY_TRIALS
    assert (runs.groupby(list(experiments.CONFIG_COLUMNS)).trial.apply(tuple) == (1, 2)).all()
    assert (runs.seed == 876 * runs.trial).all() and (runs.ticks == TINY_TICKS).all()
    assert set(experiments.METRIC_COLUMNS) <= set(runs.columns) and runs.work.gt(0).any()
    assert len(pd.read_parquet(root / "bounds.parquet")) == len(configs)
    assert drawn[figure] == [root / f"{figure}.{suffix}" for suffix in ("png", "pdf", "svg")]
    assert [path.read_bytes()[:4] for path in drawn[figure]] == [b"\x89PNG", b"%PDF", b"<?xm"]


def test_figures_run_together_equal_each_run_alone_and_share_configurations(tiny, tmp_path, monkeypatch):
    results, _ = tiny
    calls = []
    real = experiments._trials_of
    monkeypatch.setattr(experiments, "_trials_of", lambda config: calls.append(config) or real(config))
    monkeypatch.setattr(study, "QUICK_TRIALS", TINY_TRIALS)
    monkeypatch.setattr(study, "QUICK_TICKS", TINY_TICKS)
    for figure in ("fig10", "fig11"):  # alone, each in its own reproduce call
        reproduce.reproduce([figure], tmp_path / "alone", quick=True, jobs=1, log=lambda *a, **k: None)
    alone = len(calls)
    calls.clear()
    reproduce.reproduce(FIGURES, tmp_path / "together", quick=True, jobs=1, log=lambda *a, **k: None)
    together = [params for figure in FIGURES for params in grid(figure, {"ticks": TINY_TICKS, "trials": TINY_TRIALS})]
    assert len(calls) == len(set(calls)) == len(set(together)) < len(together)  # shared ones once
    assert alone == len(grid("fig10")) + len(grid("fig11"))
    for figure in FIGURES:
        for table in ("runs", "bounds"):
            name = f"quick/{figure}/{table}.parquet"
            pd.testing.assert_frame_equal(pd.read_parquet(tmp_path / "together" / name),
                                          pd.read_parquet(results / name))
    for figure in ("fig10", "fig11"):
        name = f"quick/{figure}/runs.parquet"
        pd.testing.assert_frame_equal(pd.read_parquet(tmp_path / "alone" / name),
                                      pd.read_parquet(results / name))


def test_a_configurations_trials_in_the_table_are_those_of_simulate(tiny):
    results, _ = tiny
    runs = pd.read_parquet(results / "quick" / "fig12" / "runs.parquet")
    mine = runs[(runs.strategy == "mobile") & (runs.transfer_loss == 0.3)]
    alone = simulate_module.simulate(Params(strategy="mobile", n_chargers=6, transfer_loss=0.3, ticks=TINY_TICKS),
                                     TINY_TRIALS)
    for column in ("trial", "seed", *experiments.METRIC_COLUMNS):
        assert mine[column].tolist() == alone[column].tolist(), column


def test_redraw_needs_only_the_tables(tiny, tmp_path, monkeypatch):
    results, drawn = tiny
    copy = tmp_path / "quick"
    for figure in FIGURES:
        (copy / figure).mkdir(parents=True)
        for table in ("runs", "bounds"):
            shutil.copy(results / "quick" / figure / f"{table}.parquet", copy / figure)

    def forbidden(*args, **kwargs):
        raise AssertionError("redrawing must not simulate")

    monkeypatch.setattr(simulate_module, "simulate", forbidden)
    monkeypatch.setattr(experiments, "run_configs", forbidden)
    assert cli.main(["reproduce", *FIGURES, "--quick", "--redraw", "--out", str(tmp_path)]) == 0
    for figure in FIGURES:
        for path in drawn[figure]:  # every format, the same bytes
            assert (copy / figure / path.name).read_bytes() == path.read_bytes()


def test_redraw_without_tables_says_what_to_run(tmp_path, capsys):
    assert cli.main(["reproduce", "fig10", "--redraw", "--out", str(tmp_path)]) == 2
    assert "run dronefleet reproduce fig10 without --redraw first" in capsys.readouterr().err


@pytest.mark.parametrize("figure", FIGURES)
def test_check_re_derives_every_value_of_two_configurations(tiny, figure):
    results, _ = tiny
    lines = []
    assert reproduce.check(figure, results, quick=True, log=lambda *a, **k: lines.append(" ".join(map(str, a)))) == []
    compared = [line for line in lines if line.endswith("identical")]
    assert len(compared) == 2
    assert all(f"{TINY_TRIALS * (2 + len(experiments.METRIC_COLUMNS))} values" in line for line in compared)


def test_check_lists_a_tampered_value_and_exits_1(tiny, tmp_path, capsys):
    results, _ = tiny
    runs = pd.read_parquet(results / "quick" / "fig11" / "runs.parquet")
    changed = (runs.strategy == "mobile") & (runs.charge_rate == 0.1) & (runs.trial == 2)
    assert changed.sum() == 1
    runs.loc[changed, "efficiency"] = np.nextafter(runs.loc[changed, "efficiency"], 2.0)  # one ulp
    (tmp_path / "quick" / "fig11").mkdir(parents=True)
    runs.to_parquet(tmp_path / "quick" / "fig11" / "runs.parquet")
    assert cli.main(["reproduce", "fig11", "--quick", "--check", "--out", str(tmp_path)]) == 1
    out = capsys.readouterr().out
    assert "differs: fig11 strategy=mobile,charge_rate=0.1 trial 2: efficiency committed" in out
    assert "values that differ: 1" in out


@pytest.mark.parametrize("figure", ("fig10", "fig11", "fig12"))
def test_the_bound_lines_are_bounds_at_each_grid_point(tiny, figure, tmp_path, drawn_figures):
    results, _ = tiny
    runs = pd.read_parquet(results / "quick" / figure / "runs.parquet")
    table = pd.read_parquet(results / "quick" / figure / "bounds.parquet")
    curve = study.CURVES[figure]
    x = curve["x"]
    kept = drawn_figures(rfigures)
    rfigures.work_and_efficiency(runs, table, tmp_path / "f", **curve)
    work_ax, efficiency_ax = kept[0].axes
    configs = grid(figure, {"ticks": TINY_TICKS})
    for strategy in ("fixed", "mobile"):
        mine = sorted((p for p in configs if p.strategy == strategy), key=lambda p: getattr(p, x))
        expected = [bounds(p) for p in mine]
        label = f"{rfigures.LABELS[strategy]}: bound"
        for ax, attribute in ((work_ax, "work"), (efficiency_ax, "efficiency")):
            (line,) = [line for line in ax.lines if line.get_label() == label]
            ys = [getattr(b, attribute) for b in expected]
            if curve.get("fixed_line") and strategy == "fixed":
                assert len(mine) == 1 and list(line.get_ydata()) == ys * 2  # across the axis
            else:
                assert list(line.get_xdata()) == [getattr(p, x) for p in mine]
                assert list(line.get_ydata()) == ys
    if figure == "fig12":  # efficiency counts the loss: work energy / (total + lost)
        (means,) = [line for line in efficiency_ax.lines if line.get_label() == "mobile chargers: trials and mean"]
        expected = runs[runs.strategy == "mobile"].groupby("transfer_loss").efficiency_with_loss.mean()
        assert list(means.get_ydata()) == expected.tolist()


def test_the_figures_have_no_titles_and_each_strategy_its_own_colour_and_marker(tiny, tmp_path, drawn_figures):
    results, _ = tiny
    root = results / "quick"
    kept = drawn_figures(rfigures)
    rfigures.heatmaps(pd.read_parquet(root / "fig09" / "runs.parquet"), tmp_path / "fig09")
    rfigures.work_and_efficiency(pd.read_parquet(root / "fig10" / "runs.parquet"),
                                 pd.read_parquet(root / "fig10" / "bounds.parquet"), tmp_path / "fig10",
                                 **study.CURVES["fig10"])
    assert len(kept) == 2
    for fig in kept:
        assert fig._suptitle is None
        assert all(ax.get_title(loc) == "" for ax in fig.axes for loc in ("left", "center", "right"))
    work_ax = kept[1].axes[0]
    means = {line.get_label(): line for line in work_ax.lines if line.get_label().endswith("trials and mean")}
    fixed, mobile = means["fixed chargers: trials and mean"], means["mobile chargers: trials and mean"]
    assert (fixed.get_color(), mobile.get_color()) == (figstyle.STRATEGY_STYLES["fixed"].colour,
                                                       figstyle.STRATEGY_STYLES["mobile"].colour)
    assert fixed.get_marker() != mobile.get_marker()  # apart in greyscale too


# ---------------------------------------------------------------- the committed figures against the bounds

RESULTS = Path(__file__).resolve().parents[1] / "results"


def committed(figure, table):
    """The committed ``results/<figure>/<table>.parquet`` as pandas, through the project's reader."""
    def number(arrow_type):
        return pa.types.is_integer(arrow_type) or pa.types.is_floating(arrow_type)

    metrics = ("bound_work", "bound_efficiency") if table == "bounds" else ("work", "efficiency_with_loss")
    columns = {**dict.fromkeys((*experiments.CONFIG_COLUMNS[1:], *metrics), number), "strategy": reproduce.flat}
    return read_parquet(RESULTS / figure / f"{table}.parquet", columns).to_pandas()


def test_every_committed_fig12_mean_lies_below_its_bound_and_the_drawn_bound_is_e_cs():
    runs = committed("fig12", "runs")
    means = runs[runs.strategy == "mobile"].groupby("transfer_loss")[["work", "efficiency_with_loss"]].mean()
    assert list(means.index) == pytest.approx([0.1 * i for i in range(10)])
    drawn = committed("fig12", "bounds").set_index(["strategy", "transfer_loss"])
    for loss, mean in means.iterrows():
        limit = bounds(Params(strategy="mobile", n_chargers=6, transfer_loss=loss))
        assert 0.0 < mean.efficiency_with_loss < limit.efficiency, loss
        assert mean.work < limit.work, loss
        assert drawn.loc[("mobile", loss), "bound_efficiency"] == limit.efficiency  # the line of Fig 12b


def test_no_committed_fixed_trial_exceeds_the_strict_work_ceiling():
    # the per-cycle W_fix may be exceeded by part of a cycle (Fig 11, k = 0.1); the ceiling may not
    for figure in ("fig10", "fig11", "fig12"):
        runs = committed(figure, "runs")
        for (r, k), trials in runs[runs.strategy == "fixed"].groupby(["work_ratio", "charge_rate"]):
            assert trials.work.max() <= fixed_work_ceiling(Params(work_ratio=r, charge_rate=k)), (figure, r, k)
