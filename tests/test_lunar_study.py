"""The lunar study (spec LUNAR-FORAGING.md sections 12, 14, 15): the per-condition statistics on
synthetic tables whose answers are known (the selected 30 are the top 30 by resources, means and
sds, R-T trips of both directions binned by entry time, the median run), every figure drawn from
its tables, --check re-deriving them, and the figures in ``reproduce --list``."""

import dataclasses
import importlib
import math
import re
import shutil
import sys
import types
from contextlib import contextmanager
from pathlib import Path

import lunar_synthetic as synthetic
import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.compute
import pytest

from dronefleet import figstyle, reproduce
from dronefleet.lunar import experiments, study, verdicts
from dronefleet.lunar.params import LunarParams

pytest.importorskip("matplotlib")

#: The synthetic experiments: their conditions as (layout, battery, eps).
CONDITIONS = {
    "e1": (("OPEN", 10.0, 0.05), ("HARD-RT", 10.0, 0.05), ("SOFT-RT", 10.0, 0.05)),
    "e2": (("SOFT-RT", 7.5, 0.05), ("SOFT-RT", 12.5, 0.05)),
    "e3": tuple((f"{kind}-{where}", 10.0, 0.05) for kind in ("HARD", "SOFT") for where in ("NT", "NR")),
    "eps1": (("OPEN", 10.0, 1.0), ("HARD-RT", 10.0, 1.0), ("SOFT-RT", 10.0, 1.0)),
    # E4: the five scenarios at the defaults and under two changes (a fourth item: the keys a configuration sets)
    "e4": tuple((layout, battery, eps, change) for change in ({}, {"kappa_soft": 5.0}, {"eps": 1.0})
                for layout, battery, eps in (("OPEN", 10.0, 0.05), ("HARD-RT", 10.0, 0.05), ("SOFT-RT", 10.0, 0.05),
                                             ("SOFT-RT", 7.5, 0.05), ("SOFT-RT", 12.5, 0.05))),
    "e5": (("OPEN", 10.0, 0.05, {"model": "baseline"}), ("HARD-RT", 10.0, 0.05, {"model": "baseline"})),
}


def _fake(patch):
    real = importlib.import_module("dronefleet.lunar.simulate")
    fake = types.ModuleType("dronefleet.lunar.simulate")
    fake.simulate, fake.table_schemas = synthetic.simulate, real.table_schemas
    patch.setitem(sys.modules, "dronefleet.lunar.simulate", fake)
    patch.setattr(experiments, "grid_path", lambda experiment: Path(f"lunar-{experiment}.toml"))
    # lunar-verdicts: E1-E3's conditions on each reading's configuration
    patch.setattr(verdicts, "conditions", lambda base: [
        dataclasses.replace(base, layout=layout, battery_wh=battery, eps=eps)
        for layout, battery, eps in dict.fromkeys(c for e in ("e1", "e2", "e3") for c in CONDITIONS[e])])


@pytest.fixture
def fake_simulator(monkeypatch):
    """dronefleet.lunar.simulate replaced by the synthetic tables, the sweeps by :data:`CONDITIONS`."""
    _fake(monkeypatch)


class Context:
    """A :class:`dronefleet.contract.StudyContext` over the synthetic sweeps, in this process."""

    def __init__(self, root, quick=True):
        self.root, self.quick, self.jobs, self.memo, self.lines = Path(root), quick, 1, {}, []
        self.log = self.lines.append

    def figure_dir(self, figure):
        (self.root / figure).mkdir(parents=True, exist_ok=True)
        return self.root / figure

    def load_sweep(self, path, changes=None):
        experiment = Path(path).stem.removeprefix("lunar-")
        configs = [LunarParams(**{"layout": layout, "battery_wh": battery, "eps": eps, **(keys[0] if keys else {}),
                                  **(changes or {})}) for layout, battery, eps, *keys in CONDITIONS[experiment]]
        return types.SimpleNamespace(runs=[types.SimpleNamespace(config=c) for c in configs])

    def map(self, function, items):
        return ((item, function(item), None) for item in items)

    def write_table(self, frame, path):
        frame.to_parquet(path, index=False)
        return path

    def read_table(self, figure, name):  # as reproduce reads it: every column and the row count checked
        return reproduce._read_parquet(self.root / figure / f"{name}.parquet", figure, name)


def synthetic_summary(conditions=(("OPEN", 10.0, 0.05), ("SOFT-RT", 7.5, 0.05)), runs=50):
    frames = []
    for layout, battery, eps in conditions:
        params = LunarParams(layout=layout, battery_wh=battery, eps=eps, runs=runs, duration_s=600.0)
        summary = synthetic.simulate(params)["summary"].to_pandas()
        summary.insert(0, "condition", experiments.condition_of(layout, battery, eps))
        frames.append(summary)
    return pd.concat(frames, ignore_index=True)


def test_the_selected_are_each_conditions_30_runs_with_most_resources():
    summary = synthetic_summary()
    chosen = experiments.selected(summary)
    for _, mine in summary.groupby("condition"):
        keep = chosen[mine.index]
        assert keep.sum() == 30
        assert mine["resources"][keep].min() >= mine["resources"][~keep].max()
        # not simply the first 30 runs: the synthetic resources are scrambled by run
        assert set(mine["run"][keep]) != set(range(30))
    assert experiments.selected_count(50) == 30 and experiments.selected_count(5) == 3


def test_ties_at_the_cut_keep_the_lower_run_index():
    summary = pd.DataFrame({"condition": "X", "run": np.arange(5), "resources": [7, 9, 7, 7, 1]})
    assert experiments.selected(summary).tolist() == [True, True, True, False, False]  # 3 of 5


def test_curves_are_the_mean_and_sd_over_the_selected_runs_and_over_all():
    conditions = (("OPEN", 10.0, 0.05),)
    summary = synthetic_summary(conditions)
    params = LunarParams(layout="OPEN", runs=50, duration_s=600.0)
    timeseries = synthetic.simulate(params)["timeseries"].to_pandas().assign(condition="OPEN")
    curves = experiments.curves(timeseries, summary)
    top = summary.sort_values(["resources", "run"], ascending=[False, True])["run"][:30]
    t = timeseries["t"].unique()[3]
    for selection, runs in (("selected", set(top)), ("all", set(range(50)))):
        values = timeseries[(timeseries["t"] == t) & timeseries["run"].isin(runs)]["resources"].to_numpy(float)
        row = curves[(curves["selection"] == selection) & (curves["metric"] == "resources") & (curves["t"] == t)]
        assert len(row) == 1 and row["runs"].item() == len(runs)
        assert row["mean"].item() == pytest.approx(values.mean(), rel=1e-12)
        assert row["sd"].item() == pytest.approx(values.std(ddof=1), rel=1e-12)
    # the first record's alignment is NaN in every run: no runs, no mean there
    first = curves[(curves["metric"] == "alignment_T") & (curves["t"] == timeseries["t"].min())]
    assert (first["runs"] == 0).all() and first["mean"].isna().all()
    assert set(curves["metric"]) == set(experiments.CURVE_METRICS)


def test_rt_trips_of_both_directions_are_binned_by_entry_time():
    params = LunarParams(layout="SOFT-RT", runs=4, duration_s=1000.0)
    trips = synthetic.simulate(params)["trips"].to_pandas()
    rt = experiments.rt_trips(trips, params.tau).assign(condition="SOFT-RT")
    assert set(zip(rt["origin"], rt["dest"])) == {("R", "T"), ("T", "R")}   # N-T left out
    assert np.allclose(rt["t_entered"], rt["tick_entered"] * params.tau)
    summary = pd.DataFrame({"condition": "SOFT-RT", "run": range(4), "resources": [1, 5, 3, 2]})
    bins = experiments.trip_bins(rt, summary, bin_s=300.0)
    length = bins[(bins["metric"] == "length_m") & (bins["selection"] == "all")].set_index("bin_start_s")
    for start in (0.0, 300.0, 600.0):
        mine = rt[(rt["t_entered"] >= start) & (rt["t_entered"] < start + 300.0)]
        assert length.loc[start, "trips"] == len(mine) > 0
        assert length.loc[start, "mean"] == pytest.approx(mine["length_m"].mean(), rel=1e-12)
    selected = bins[(bins["metric"] == "length_m") & (bins["selection"] == "selected")]
    chosen = rt[rt["run"].isin([1, 2])]   # 2 of 4 runs (30 of 50, rounded): those with most resources
    assert selected["trips"].sum() == len(chosen)
    assert set(bins["metric"]) == set(experiments.TRIP_METRICS)


def test_the_median_run_is_the_middle_of_the_selected():
    summary = pd.DataFrame({"condition": ["A"] * 5 + ["B"] * 2, "run": [0, 1, 2, 3, 4, 0, 1],
                            "resources": [10, 50, 30, 40, 20, 4, 4]})
    # A: the 3 selected are 50, 40, 30 -> median 40 (run 3); B: 1 of 2 selected (run 0)
    assert experiments.median_runs(summary).to_dict("records") == [
        {"condition": "A", "run": 3, "resources": 40}, {"condition": "B", "run": 0, "resources": 4}]
    fifty = synthetic_summary(runs=50)
    medians = experiments.median_runs(fifty).set_index("condition")
    for condition, mine in fifty[experiments.selected(fifty)].groupby("condition"):
        ordered = sorted(zip(mine["resources"], mine["run"]))
        assert (medians.loc[condition, "resources"], medians.loc[condition, "run"]) == ordered[14]


def test_run_stats_leave_out_nan_deaths_per_session():
    stats = experiments.run_stats(synthetic_summary(runs=8))
    row = stats[(stats["column"] == "deaths_per_session") & (stats["selection"] == "all")
                & (stats["condition"] == "OPEN")]
    assert row["runs"].item() == 6   # runs 0 and 4 had no session


def test_the_highlighted_robots_are_one_per_role_that_travelled_farthest_while_mobile():
    frames = pd.DataFrame({"robot": [0, 0, 0, 1, 1, 1, 2, 2, 2, 3, 3, 3, 4, 4, 4], "t": [10.0, 20.0, 30.0] * 5,
                           "x": [0, 5, 5, 0, 1, 2, 0, 9, 9, 0, 3, 6, 0, 9, 18], "y": [0.0] * 15,
                           "status": ["alive"] * 15,
                           "role": ["F_OUT"] * 6 + ["B"] * 3 + ["R"] * 3 + ["F_IN", "F_IN", "B"]})

    def picked(window):
        return experiments.highlighted(frames, 30.0, window).to_dict("records")

    # robot 2 is a beacon; robot 4 drove 9 m as F_IN, then became one (its last 9 m do not count);
    # roles in the thesis's order (out, in, recharge)
    assert picked(300.0) == [{"robot": 0, "role": "F_OUT"}, {"robot": 4, "role": "F_IN"}, {"robot": 3, "role": "R"}]
    assert picked(15.0) == [{"robot": 1, "role": "F_OUT"}, {"robot": 3, "role": "R"}]   # robot 0 still in (15, 30]


def test_the_exploitation_snapshot_is_the_last_whose_window_shows_every_role_driving(monkeypatch):
    times = np.arange(10.0, 201.0, 10.0)

    def frames(r_stops):
        # robots 0, 1, 2 drive as F_OUT, F_IN, R; robot 2 stands still (charging) from r_stops on
        rows = [{"robot": robot, "t": t, "status": "alive", "role": role, "y": 0.0,
                 "x": min(t, r_stops) if robot == 2 else t}
                for robot, role in enumerate(("F_OUT", "F_IN", "R")) for t in times]
        return pd.DataFrame(rows)

    monkeypatch.setattr(study, "PATH_WINDOW_S", 60.0)
    # half of the run (100 s) shows robot 2 standing: the last end whose window holds its step 20 -> 30 s
    # is 80 (the frames of the window: 20 s .. 80 s)
    assert study._exploitation_time(frames(30.0), "lunar-fig05") == 80.0
    assert study._exploitation_time(frames(30.0), "lunar-fig06") == 80.0
    assert study._exploitation_time(frames(500.0), "lunar-fig06") == 200.0
    assert study._exploitation_time(frames(10.0), "lunar-fig05") == 100.0   # never drives: half of the run


def test_chunks_cover_the_configurations_runs():
    parts = experiments.chunks(LunarParams(runs=23, first_run=4), size=10)
    assert [(p.first_run, p.runs) for p in parts] == [(4, 10), (14, 10), (24, 3)]


def test_a_condition_holding_a_run_twice_is_refused(fake_simulator):
    from dronefleet.config import SweepError

    with pytest.raises(SweepError, match="condition 'OPEN' holds run 0 twice"):
        experiments.run_configs([LunarParams(layout="OPEN", runs=2, duration_s=100.0),
                                 LunarParams(layout="OPEN", runs=2, duration_s=100.0, seed=3)], "e1")


@pytest.fixture(scope="module")
def drawn(tmp_path_factory):
    """Every lunar figure tidied and drawn from the synthetic experiments (--quick sizes), once."""
    with pytest.MonkeyPatch.context() as patch:
        _fake(patch)
        context = Context(tmp_path_factory.mktemp("lunar-study"))
        study.run_together(context, list(study.FIGURES))
        files = {}
        for figure in study.FIGURES:
            study.tidy(context, figure)
            files[figure] = study.draw(context, figure)
    # the fake ends here: the module's later tests (the real quick study) need the real sweeps
    return context, files


@pytest.fixture
def synthetic_results(drawn, fake_simulator, tmp_path):
    """:func:`drawn`'s results in a copy of their own (a test may change them)."""
    context, files = drawn
    copy = Context(tmp_path / "results")
    shutil.copytree(context.root, copy.root)
    return copy, {figure: [copy.root / path.relative_to(context.root) for path in paths]
                  for figure, paths in files.items()}


def test_every_figure_is_drawn_from_its_tables(synthetic_results):
    context, files = synthetic_results
    for figure in study.FIGURES:
        names = {path.name for path in files[figure]}
        assert f"{figure}.png" in names and f"{figure}.pdf" in names and f"{figure}.svg" in names, figure
        assert all(path.stat().st_size > 0 for path in files[figure])
        for png in (path for path in files[figure] if path.suffix == ".png"):   # a page wide, at print size
            width = int.from_bytes(png.read_bytes()[16:20], "big")
            assert width == round(figstyle.DOUBLE_COLUMN * figstyle.DPI), png.name
    assert (context.root / "lunar-fig07" / "lunar-fig07-alignment.svg").exists()
    runs = pd.read_parquet(context.root / "lunar-fig07" / "runs.parquet")
    assert list(runs.columns[:8]) == [*experiments.CONDITION_COLUMNS, "v0", "run"]
    assert set(runs["condition"]) == {"OPEN", "HARD-RT", "SOFT-RT"}
    assert len(runs) == 3 * study.QUICK_CHANGES["runs"] and runs["selected"].sum() == 3 * 3
    assert set(pd.read_parquet(context.root / "lunar-fig08" / "bins.parquet")["condition"]) == {
        "OPEN", "HARD-RT", "SOFT-RT", "SOFT-RT 7.5 Wh", "SOFT-RT 12.5 Wh"}
    assert set(pd.read_parquet(context.root / "lunar-fig11" / "runs.parquet")["condition"]) == {
        "HARD-RT", "SOFT-RT", "HARD-NT", "HARD-NR", "SOFT-NT", "SOFT-NR"}
    assert set(pd.read_parquet(context.root / "lunar-control" / "runs.parquet")["condition"]) == {
        "OPEN", "HARD-RT", "SOFT-RT", "OPEN eps=1", "HARD-RT eps=1", "SOFT-RT eps=1"}


def test_fig09_draws_each_capacitys_median_run(synthetic_results):
    context, _ = synthetic_results
    d = context.root / "lunar-fig09"
    median, snapshots = pd.read_parquet(d / "median.parquet"), pd.read_parquet(d / "snapshots.parquet")
    assert set(median["condition"]) == {"SOFT-RT", "SOFT-RT 7.5 Wh", "SOFT-RT 12.5 Wh"}
    for row in median.itertuples():
        mine = snapshots[snapshots["condition"] == row.condition]
        assert set(mine["run"]) == {row.run} and set(mine["label"]) == {"end"} and len(mine) == 50


def test_the_e0_figures_draw_the_milestones_and_the_exploitation_window(synthetic_results):
    context, _ = synthetic_results
    fig04 = pd.read_parquet(context.root / "lunar-fig04" / "snapshots.parquet")
    assert sorted(set(fig04["label"])) == ["first_R", "first_T", "first_row5"]
    fig05 = pd.read_parquet(context.root / "lunar-fig05" / "snapshots.parquet")
    assert set(fig05["label"]) == {"frame"} and fig05["t"].max() <= 300.0 + 1e-9
    assert fig05["t"].max() - fig05["t"].min() < study.PATH_WINDOW_S
    highlighted = pd.read_parquet(context.root / "lunar-fig06" / "highlighted.parquet")["robot"].tolist()
    assert len(highlighted) == 3 and all(robot >= 20 for robot in highlighted)   # no beacon


def test_check_re_derives_every_table_and_finds_a_changed_value(synthetic_results):
    context, _ = synthetic_results
    for figure in study.FIGURES:
        assert study.check(context, figure) == [], figure
    curves = context.root / "lunar-fig07" / "curves.parquet"
    table = pd.read_parquet(curves)
    derived = float(table.loc[5, "mean"])
    table.loc[5, "mean"] = derived + 1.0
    table.to_parquet(curves, index=False)
    assert study.check(context, "lunar-fig07") == [
        f"lunar-fig07 curves row 5: mean committed {derived + 1.0!r}, re-derived {derived!r}"]
    runs = context.root / "lunar-fig08" / "runs.parquet"
    table = pd.read_parquet(runs)
    best = table[table["condition"] == "OPEN"].sort_values("resources").index[-1]
    table.loc[best, "trips"] += 1
    table.to_parquet(runs, index=False)
    found = study.check(context, "lunar-fig08")
    assert len(found) == 1 and found[0].startswith("lunar-fig08 OPEN run ") and "trips committed" in found[0]


def test_fig08_holds_every_runs_records_and_check_compares_them(synthetic_results):
    context, _ = synthetic_results
    d = context.root / "lunar-fig08"
    runs = pd.read_parquet(d / "runs.parquet")
    per_run = {"robots": 50, "deaths": 1, "recharge_triggers": 1, "beacon_costs": 2}   # the synthetic's
    for name, rows in per_run.items():
        table = pd.read_parquet(d / f"{name}.parquet")
        assert list(table.columns) == list(study.TABLE_COLUMNS[name]), name
        assert len(table) == rows * len(runs), name
        assert table.groupby(["condition", "run"]).size().eq(rows).all(), name
    deaths = pd.read_parquet(d / "deaths.parquet")
    best = runs[runs["condition"] == "OPEN"].sort_values(["resources", "run"]).iloc[-1]["run"]
    row = deaths.index[(deaths["condition"] == "OPEN") & (deaths["run"] == best)][0]
    t = float(deaths.loc[row, "t"])
    deaths.loc[row, "t"] = t + 1.0
    deaths.to_parquet(d / "deaths.parquet", index=False)
    assert study.check(context, "lunar-fig08") == [
        f"lunar-fig08 OPEN run {best} deaths row 0: t committed {t + 1.0!r}, re-derived {t!r}"]


def test_fig08_without_deaths_or_recharging_interruptions_is_written_drawn_and_checked(fake_simulator, monkeypatch,
                                                                                      tmp_path):
    # --quick's short runs may have neither: those tables are empty, not refused as a broken run's
    for name in ("_deaths", "_recharge_triggers"):
        made = getattr(synthetic, name)
        monkeypatch.setattr(synthetic, name, lambda params, runs, made=made: made(params, runs).slice(0, 0))
    context = Context(tmp_path)
    study.run_together(context, ["lunar-fig08"])
    study.tidy(context, "lunar-fig08")
    for name in set(study.MAY_BE_EMPTY) & set(study.RAW["lunar-fig08"]):
        assert len(context.read_table("lunar-fig08", name)) == 0, name
    assert len(context.read_table("lunar-fig08", "robots")) > 0
    assert (tmp_path / "lunar-fig08" / "lunar-fig08.png") in study.draw(context, "lunar-fig08")
    assert study.check(context, "lunar-fig08") == []


def test_check_without_tables_says_what_to_run(tmp_path):
    from dronefleet.config import SweepError

    with pytest.raises(SweepError, match="run dronefleet reproduce lunar-fig07 --quick first"):
        study.check(Context(tmp_path), "lunar-fig07")


def test_a_tampered_layout_is_refused_in_one_line_naming_the_file(synthetic_results):
    from dronefleet.config import SweepError

    context, _ = synthetic_results
    runs = context.root / "lunar-fig07" / "runs.parquet"
    table = pd.read_parquet(runs)
    table.loc[0, "layout"] = "MOON"
    table.to_parquet(runs, index=False)
    with pytest.raises(SweepError, match=f"{runs}: the configuration layout='MOON', .* world.layout = 'MOON' is not "
                                         "allowed"):
        study.draw(context, "lunar-fig07")


@pytest.mark.parametrize("value", ["zz", "../x", "e0"])
def test_a_table_naming_an_experiment_not_the_figures_is_refused_naming_it(synthetic_results, value):
    # the experiment names the sweep file --check runs again: never a path from the table
    from dronefleet.config import SweepError

    context, _ = synthetic_results
    runs = context.root / "lunar-fig07" / "runs.parquet"
    table = pd.read_parquet(runs)
    table.loc[0, "experiment"] = value
    table.to_parquet(runs, index=False)
    for call in (study.check, study.draw):
        with pytest.raises(SweepError, match=re.escape(f"{runs}: experiment {value!r} is not one of this "
                                                       "figure's (e1)")):
            call(context, "lunar-fig07")


def test_the_quick_mode_is_stated():
    assert study.QUICK == "5 runs of 600 s per condition (the 3 with most resources kept)"
    assert math.isclose(study.e0_config(True).duration_s, 600.0) and study.e0_config(False).duration_s == 3600.0
    assert study.e0_config(False).frames and study.e0_config(False).layout == "SOFT-RT"


def test_reproduce_lists_the_lunar_figures():
    listing = reproduce.list_studies()
    assert "lunar: " in listing
    assert " ".join(study.FIGURES) in listing
    assert reproduce.owner("lunar-fig07") is study


def test_the_synthetic_tables_have_the_simulators_columns_and_types():
    from dronefleet.lunar.simulate import table_schemas

    tables = synthetic.simulate(LunarParams(runs=2, duration_s=60.0, frames=True))
    for name, schema in table_schemas().items():
        assert tables[name].schema.equals(schema), name


@pytest.fixture
def kept(monkeypatch):
    """The figures the lunar figure functions draw from here on (a list), kept after they are saved."""
    from dronefleet import figstyle
    from dronefleet.lunar import figures

    kept, original = [], figures._figure

    @contextmanager
    def keeping(path, *args, **kwargs):
        with original(path, *args, **kwargs) as (mpl, fig, axes):
            kept.append(fig)
            yield mpl, fig, axes
    monkeypatch.setattr(figures, "_figure", keeping)
    monkeypatch.setattr(figstyle, "_figure", keeping)   # E4's figure takes it from there at draw time
    return kept


def test_a_milestone_the_run_never_reached_is_an_empty_field_saying_so(tmp_path, kept):
    from dronefleet.lunar import figures
    from dronefleet.lunar.layout import build

    params = LunarParams(runs=1, duration_s=60.0)
    snapshots = synthetic.simulate(params)["snapshots"].to_pandas()
    files = figures.panels({"first entry into T": snapshots[snapshots["label"] == "first_T"],
                            "first recharged robot heads to N": None}, build(params), params.v0, tmp_path / "milestones")
    assert [path.name for path in files] == ["milestones.png", "milestones.pdf", "milestones.svg"]
    texts = [text.get_text() for ax in kept[0].axes for text in ax.texts]
    assert "not reached in this run" in texts


def test_a_trip_entering_at_the_end_of_the_run_is_in_the_last_bin_not_one_after_it():
    tau, bin_s = LunarParams().tau, experiments.BIN_S
    # entries at ticks 1, 4688 (300.03 s), 4687 (299.97 s) and 56250 (T_run = 3600 s, as tick * tau rounds it)
    ticks = [1, 4687, 4688, 56_250]
    trips = pd.DataFrame({"condition": "SOFT-RT", "run": 0, "origin": "R", "dest": "T", "tick_entered": ticks,
                          **{metric: [1.0, 2.0, 3.0, 4.0] for metric in experiments.TRIP_METRICS}})
    trips = experiments.rt_trips(trips, tau)
    bins = experiments.trip_bins(trips, pd.DataFrame({"condition": ["SOFT-RT"], "run": [0], "resources": [1]}), bin_s)
    length = bins[(bins["metric"] == "length_m") & (bins["selection"] == "all")]
    assert dict(zip(length["bin_start_s"], length["mean"])) == {0.0: 1.5, 300.0: 3.0, 3300.0: 4.0}
    assert length["bin_start_s"].max() + bin_s == 3600.0   # the last bin closes at T_run


def _draw(context, figure, kept):
    """``figure`` drawn again from ``context``'s tables: its matplotlib figures."""
    del kept[:]
    study.draw(context, figure)
    return list(kept)


def test_fig08_whiskers_are_standard_errors_and_say_so(synthetic_results, kept):
    context, _ = synthetic_results
    (fig,) = _draw(context, "lunar-fig08", kept)
    bins = pd.read_parquet(context.root / "lunar-fig08" / "bins.parquet")
    bins = bins[(bins["selection"] == "selected") & (bins["metric"] == "soc_cost")]
    ax = fig.axes[0]
    assert ax.containers, "no whiskers drawn"
    for container in ax.containers:
        rows = bins[bins["condition"] == container.get_label()].sort_values("bin_start_s")
        (bars,) = container.lines[2]
        half = np.array([abs(segment[1, 1] - segment[0, 1]) / 2 for segment in bars.get_segments()])
        assert np.allclose(half, (rows["sd"] / np.sqrt(rows["trips"])).dropna().to_numpy()), container.get_label()
    assert "standard error" in fig.legends[0].get_title().get_text()
    curves, _ = _draw(context, "lunar-fig07", kept)   # the bands of the curves too
    assert "standard error" in curves.legends[0].get_title().get_text()


def _time_axes(fig):
    return [ax for ax in fig.axes if "time [min]" in ax.get_xlabel()]


@pytest.mark.parametrize("figure, count", [("lunar-fig07", 5 + 3), ("lunar-fig08", 4), ("lunar-fig11", 6),
                                           ("lunar-control", 1)])
def test_every_time_axis_marks_20_minutes_with_a_label(synthetic_results, kept, figure, count):
    context, _ = synthetic_results
    axes = [ax for fig in _draw(context, figure, kept) for ax in _time_axes(fig)]
    assert len(axes) == count
    for ax in axes:
        assert any(list(line.get_xdata()) == [20.0, 20.0] for line in ax.lines), ax.get_ylabel()
        assert any(text.get_text().strip() == "20 min" and text.get_position()[0] == 20.0 for text in ax.texts)


def test_panels_of_one_quantity_share_their_y_scale(synthetic_results, kept):
    context, _ = synthetic_results
    _, alignment = _draw(context, "lunar-fig07", kept)
    assert len({ax.get_ylim() for ax in alignment.axes if ax.get_visible()}) == 1
    (placement,) = _draw(context, "lunar-fig11", kept)
    rows = {}
    for ax in placement.axes:
        rows.setdefault(ax.get_ylabel(), set()).add(ax.get_ylim())
    assert len(rows) == 3 and all(len(limits) == 1 for limits in rows.values())   # soft and hard alike
    (control,) = _draw(context, "lunar-control", kept)
    curves, bars = control.axes[:2]
    assert curves.get_ylim() == bars.get_ylim()   # resources returned, over time and at the end


#: Spec and code words a figure must not show: the labels are words.
JARGON = re.compile(r"row ?5|n_T|T_run|_row5|first_|eps=1")


@pytest.mark.parametrize("figure", study.FIGURES)
def test_no_figure_text_is_spec_jargon(synthetic_results, kept, figure):
    from matplotlib.text import Text

    context, _ = synthetic_results
    texts = [text.get_text() for fig in _draw(context, figure, kept) for text in fig.findobj(Text)]
    assert texts and not [text for text in texts if JARGON.search(text)], figure


def _quivers(ax):
    from matplotlib.quiver import Quiver

    return [artist for artist in ax.collections if isinstance(artist, Quiver)]


def test_guidance_vectors_are_arrows_of_one_length_shaded_by_magnitude(synthetic_results, kept):
    from dronefleet.lunar import figures

    context, _ = synthetic_results
    (fig,) = _draw(context, "lunar-fig04", kept)
    snapshots = pd.read_parquet(context.root / "lunar-fig04" / "snapshots.parquet")
    first = snapshots[(snapshots["label"] == "first_T") & (snapshots["role"] == "B")]
    vectors = _quivers(fig.axes[0])[:3]     # the keys T, N, R, then the mobile robots' headings
    for key, quiver in zip(figures.KEY_COLOURS, vectors):
        assert np.allclose(np.hypot(quiver.U, quiver.V), figures.ARROW_M), key
        magnitude = np.hypot(first[f"vx_{key}"], first[f"vy_{key}"]).to_numpy()
        magnitude = magnitude[magnitude > 0]
        shades = quiver.get_facecolors()
        strongest, weakest = np.argmax(magnitude), np.argmin(magnitude)
        if magnitude[strongest] > magnitude[weakest]:   # the stronger vector is the darker shade
            assert shades[strongest][:3].sum() < shades[weakest][:3].sum(), key
    bars = [ax for ax in fig.axes if ax.get_title() in figures.KEY_COLOURS]   # a colour bar per key
    assert sorted(ax.get_title() for ax in bars) == ["N", "R", "T"]
    assert "guidance vector magnitude [m/s]" in {ax.get_ylabel() for ax in bars}


def test_mobile_robots_are_drawn_with_their_heading(synthetic_results, kept):
    from dronefleet.lunar import figures

    context, _ = synthetic_results
    (fig,) = _draw(context, "lunar-fig03", kept)
    rows = pd.read_parquet(context.root / "lunar-fig03" / "snapshots.parquet")
    mobile = rows[(rows["status"] == "alive") & (rows["role"] != "B") & (rows["mode"] != "charging")]
    (headings,) = [q for q in _quivers(fig.axes[0]) if q.N == len(mobile)]
    assert np.allclose(np.arctan2(headings.V, headings.U), mobile["heading"])
    assert np.allclose(np.hypot(headings.U, headings.V), figures.ARROW_M)


def test_frames_are_recorded_every_frame_every_s_and_every_n_t_without_it():
    from dronefleet.lunar.simulate import simulate

    def frame_ticks(**changes):
        params = LunarParams(runs=1, n_robots=4, duration_s=25.0, frames=True, **changes)
        snapshots = simulate(params)["snapshots"].to_pandas()
        times = np.sort(snapshots.loc[snapshots["label"] == "frame", "t"].unique())
        return np.round(times / params.tau).astype(int).tolist(), params.n_T

    ticks, n_t = frame_ticks()
    assert ticks == list(range(n_t, 390 + 1, n_t))   # the default: every n_T = 156 ticks, as before
    ticks, _ = frame_ticks(frame_every_s=0.32)
    assert ticks == list(range(5, 390 + 1, 5))       # 0.32 s = 5 ticks


def test_e0_paths_follow_one_robot_per_role(synthetic_results):
    context, _ = synthetic_results
    for figure in ("lunar-fig05", "lunar-fig06"):
        highlighted = pd.read_parquet(context.root / figure / "highlighted.parquet")
        assert highlighted["role"].tolist() == list(experiments.HIGHLIGHTED_ROLES), figure
        frames = pd.read_parquet(context.root / figure / "snapshots.parquet")
        assert np.allclose(np.diff(np.sort(frames["t"].unique())), study.E0["frame_every_s"])



@pytest.fixture(scope="module")
def quick_fig07(tmp_path_factory):
    """``reproduce lunar-fig07 --quick`` with the real simulator: the results root."""
    from dronefleet import cli

    out = tmp_path_factory.mktemp("lunar-quick")
    assert cli.main(["reproduce", "lunar-fig07", "--quick", "--jobs", "1", "--out", str(out)]) == 0
    return out


def test_reproduce_quick_writes_the_tables_and_check_finds_them_identical(quick_fig07):
    from dronefleet import cli

    d = quick_fig07 / "quick" / "lunar-fig07"
    for name in ("runs", "timeseries", "curves", "stats"):
        assert (d / f"{name}.parquet").is_file(), name
    for suffix in ("png", "pdf", "svg"):
        assert (d / f"lunar-fig07.{suffix}").stat().st_size > 0
    runs = pd.read_parquet(d / "runs.parquet")
    assert len(runs) == 3 * study.QUICK_CHANGES["runs"] and (runs["resources"] > 0).all()
    # exit 0: every value re-derived and re-run identical (1: a line per difference)
    assert cli.main(["reproduce", "lunar-fig07", "--quick", "--check", "--out", str(quick_fig07)]) == 0


def test_a_tampered_table_is_refused_in_one_line_by_redraw(quick_fig07, tmp_path, capsys):
    from dronefleet import cli

    copy = tmp_path / "root"
    shutil.copytree(quick_fig07, copy)
    runs = copy / "quick" / "lunar-fig07" / "runs.parquet"
    table = pd.read_parquet(runs)
    table.loc[2, "layout"] = "MOON"
    table.to_parquet(runs, index=False)
    capsys.readouterr()
    assert cli.main(["reproduce", "lunar-fig07", "--quick", "--redraw", "--out", str(copy)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("dronefleet: error: ") and err.count("\n") == 1 and str(runs) in err and "'MOON'" in err


def test_e4_pairs_each_change_with_the_defaults_per_scenario_and_e5_draws_the_baseline(synthetic_results):
    context, _ = synthetic_results
    runs = pd.read_parquet(context.root / "lunar-e4" / "runs_by_change.parquet")
    assert list(dict.fromkeys(runs["change"])) == ["default", "kappa_soft=5", "eps=1"]
    assert len(runs) == 3 * 5 * study.QUICK_CHANGES["runs"]
    effects = pd.read_parquet(context.root / "lunar-e4" / "effects.parquet")
    assert len(effects) == 2 * 5 * 3 and set(effects["runs"]) == {study.QUICK_CHANGES["runs"]}
    row = effects[(effects["change"] == "eps=1") & (effects["condition"] == "SOFT-RT 7.5 Wh")
                  & (effects["metric"] == "resources")].iloc[0]
    mine = runs[runs["condition"] == "SOFT-RT 7.5 Wh"].pivot(index="run", columns="change", values="resources")
    assert row["effect"] == pytest.approx((mine["eps=1"] - mine["default"]).mean())
    assert set(pd.read_parquet(context.root / "lunar-e5" / "runs.parquet")["condition"]) == {
        "OPEN", "HARD-RT", "OPEN baseline", "HARD-RT baseline"}


def test_an_e4_change_not_the_sweeps_is_refused_naming_it(synthetic_results):
    from dronefleet.config import SweepError

    context, _ = synthetic_results
    path = context.root / "lunar-e4" / "effects.parquet"
    table = pd.read_parquet(path)
    table.loc[0, "change"] = "v0=9"
    table.to_parquet(path, index=False)
    for call in (study.check, study.draw):
        with pytest.raises(SweepError, match=re.escape(f"{path}: change 'v0=9' is none of")):
            call(context, "lunar-e4")


def test_the_verdicts_are_measured_from_seeded_runs_and_check_finds_a_changed_one(synthetic_results):
    context, files = synthetic_results
    assert "lunar-verdicts" in study.FIGURES and reproduce.owner("lunar-verdicts") is study
    assert {path.name for path in files["lunar-verdicts"]} >= {"lunar-verdicts.png", "lunar-verdicts.svg"}
    d = context.root / "lunar-verdicts"
    # the runs are measured again by --check, not committed: the folder holds the verdicts alone
    assert sorted(p.name for p in d.glob("*.parquet")) == ["verdicts.parquet"]
    table = pd.read_parquet(d / "verdicts.parquet")
    assert table["claim"].tolist() == list(verdicts.CLAIMS)
    assert set(table["verdict_defaults"]) | set(table["verdict_thesis"]) <= set(verdicts.VERDICTS)
    # the synthetic runs reach no late window: those claims are not measured, not a crash
    assert "nothing to measure in these runs" in set(table["numbers_defaults"])
    assert study.check(context, "lunar-verdicts") == []
    changed = "holds" if table.loc[0, "verdict_thesis"] != "holds" else "does not hold"
    committed = table.loc[0, "verdict_thesis"]
    table.loc[0, "verdict_thesis"] = changed
    table.to_parquet(d / "verdicts.parquet", index=False)
    assert study.check(context, "lunar-verdicts") == [
        f"lunar-verdicts verdicts row 0: verdict_thesis committed {changed!r}, re-derived {committed!r}"]


def test_verdicts_check_runs_each_reading_again_and_finds_a_changed_run(synthetic_results, monkeypatch):
    context, _ = synthetic_results
    table = pd.read_parquet(context.root / "lunar-verdicts" / "verdicts.parquet")
    simulate = sys.modules["dronefleet.lunar.simulate"].simulate

    def more_resources(config):
        tables = simulate(config)
        summary = tables["summary"]
        column = summary.schema.get_field_index("resources")
        return {**tables, "summary": summary.set_column(column, "resources",
                                                          pa.compute.add(summary["resources"], 7))}

    monkeypatch.setattr(sys.modules["dronefleet.lunar.simulate"], "simulate", more_resources)
    found = study.check(context, "lunar-verdicts")
    changed = [row for row in range(len(table)) if any(f"row {row}: numbers_" in line for line in found)]
    assert found and changed and all(line.startswith("lunar-verdicts verdicts row ") for line in found)
