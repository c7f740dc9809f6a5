"""The items replay page: its data is the chosen trial of the run (its world, counts, robots and
served series), too large or tampered runs are refused in one line before anything is written,
``--trial`` picks the trial (items and replenishment), and the page plays in headless Chromium."""

import importlib
import json

import numpy as np
import pyarrow.parquet as pq
import pytest
from test_replay import _refused, chart_of, chromium, counters, embedded, needs_chromium

from dronefleet import cli
from dronefleet.items import kernel as k
from dronefleet.items import replay as items_replay
from dronefleet.items.replay import trial_world
from dronefleet.items.scenario import replay_data
from dronefleet.items.scenario import read_config
from dronefleet.items.simulate import grid_positions, run_cell
from dronefleet.records import CONFIG_KEY, REPLAY_FILE
from dronefleet.replenishment.scenario import replay_data as replenishment_data

#: One run per mode: FP Poisson with GR, IDP Bernoulli on a 6 x 6 grid with GRIC, logistic FP with SF.
RUNS = {
    "foraging": 'scenario = "items"\n[run]\ntrials = 3\nfirst_trial = 2\nsteps = 200\n',
    "delivery": 'scenario = "items"\n[run]\ntrials = 2\nsteps = 150\n[world]\nmode = "delivery"\n'
                'grid_spacing = 0.2\n[generation]\ntruth = "bernoulli"\n[robots]\nalgorithm = "GRIC"\nn_robots = 3\n',
    "logistic": 'scenario = "items"\n[run]\ntrials = 2\nsteps = 150\n[world]\nlocations = 8\n'
                '[generation]\ntruth = "logistic"\n[robots]\nalgorithm = "SF"\nn_robots = 4\n',
}


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    folder = tmp_path_factory.mktemp("items")
    out = {}
    for name, text in RUNS.items():
        (folder / f"{name}.toml").write_text(text)
        out[name] = folder / name
        assert cli.main(["run", str(folder / f"{name}.toml"), "--out", str(out[name]), "--replay"]) == 0
    return out


def summary_of(run):
    return pq.read_table(run / "summary.parquet").to_pandas().set_index("trial")


def trials_of(run):
    config = read_config(run / "summary.parquet")
    return range(config.first_trial, config.first_trial + config.trials)


@pytest.mark.parametrize("name", RUNS)
def test_the_page_holds_each_trial_of_the_run(name, runs):
    run = runs[name]
    config, summary = read_config(run / "summary.parquet"), summary_of(run)
    assert embedded(run / REPLAY_FILE) == json.loads(json.dumps(replay_data(run)))  # the first trial
    for trial in (trials_of(run)[0], trials_of(run)[-1]):
        data = replay_data(run, trial)
        steps, n, m = config.steps, config.n_robots, config.n_locations
        assert data["trial"] == trial and f"trial {trial} of" in data["title"] and data["duration_s"] == steps
        assert len(data["loc_x"]) == len(data["loc_y"]) == m and data["home"] == [0.5, 0.5]
        assert len(data["x"]) == len(data["y"]) == len(data["payload"]) == (steps + 1) * n
        assert len(data["counts"]) == (steps + 1) * m and len(data["served"]) == len(data["generated"]) == steps + 1
        # counts at step 0 are the initial ones: nothing generated yet, or the logistic x0
        assert data["counts"][:m] == [config.x0 if name == "logistic" else 0] * m
        # the series end at the trial's totals in the run's summary
        assert data["served"][-1] == summary.loc[trial, "served"] > 0
        assert data["generated"][-1] == summary.loc[trial, "generated"]
        assert all(0 <= v <= 1 for v in data["x"] + data["y"] + data["loc_x"] + data["loc_y"])
        assert max(data["payload"]) <= config.capacity and data["x"][:n] == [0.5] * n


@pytest.mark.parametrize("changes", [["count_at=pickup"], ["mode=delivery", "grid_spacing=0.25"],
                                     ["algorithm=R", "truth=bernoulli"], ["sharing=destinations", "obs_range=0.3"]])
def test_the_series_end_at_the_summarys_totals_whatever_the_options(changes, tmp_path):
    (tmp_path / "items.toml").write_text('scenario = "items"\n[run]\ntrials = 1\nsteps = 120\n')
    run = tmp_path / "run"
    assert cli.main(["run", str(tmp_path / "items.toml"), "--out", str(run),
                     *[arg for change in changes for arg in ("--set", change)]]) == 0
    data, summary = replay_data(run), summary_of(run).loc[1]
    assert data["served"][-1] == summary["served"] > 0 and data["generated"][-1] == summary["generated"]
    assert all(a <= b for a, b in zip(data["served"], data["served"][1:]))


@pytest.mark.parametrize("name", RUNS)
def test_the_world_is_the_trials(name, runs):
    # the trial run again on the page's world (stream (a) not read) gives the summary's row
    run = runs[name]
    config, summary = read_config(run / "summary.parquet"), summary_of(run)
    trial = trials_of(run)[-1]
    data = replay_data(run, trial)
    positions = np.column_stack([[0.5, *data["loc_x"]], [0.5, *data["loc_y"]]])
    if name == "delivery":
        assert np.allclose(positions, grid_positions(config), atol=1e-6)
    world = trial_world(config, trial)
    assert np.allclose(positions, world[0], atol=1e-6)
    if data["loc_rate"] is not None:
        assert np.allclose(data["loc_rate"], world[1][1:], atol=1e-4)
    totals = run_cell(config.replace(first_trial=trial, trials=1), world=world)["totals"][0]
    for column, c in (("served", k.T_SERVED), ("generated", k.T_GENERATED), ("visits", k.T_VISITS),
                      ("trips", k.T_TRIPS)):
        assert totals[c] == summary.loc[trial, column], column


def test_robots_move_on_straight_lines_between_nodes(runs):
    # the page's positions against a step-by-step reading of the kernel's trace
    run = runs["foraging"]
    config = read_config(run / "summary.parquet")
    data, world = replay_data(run), trial_world(config, 2)
    positions = world[0]
    trace = run_cell(config.replace(first_trial=2, trials=1), world=world, trace=True)["trace"]
    n = config.n_robots
    x, y = np.reshape(data["x"], (-1, n)), np.reshape(data["y"], (-1, n))
    origin, total, moved = np.zeros(n, dtype=int), np.zeros(n, dtype=int), 0
    previous = np.zeros((n, 4), dtype=int)   # at home, not in transit
    for t, row in enumerate(trace):
        for i, (node, dest, left, _) in enumerate(row):
            if node >= 0:
                expected = positions[node]
            else:
                a, b = positions[origin[i]], positions[dest]
                if previous[i, 0] >= 0 or previous[i, 2] == 1:   # left a node at step t: t(a, b) steps left
                    origin[i] = previous[i, 0] if previous[i, 0] >= 0 else previous[i, 1]
                    a, total[i] = positions[origin[i]], left
                    assert left == max(1, int(np.ceil(np.hypot(*(b - a)) / config.speed - 1e-9)))
                    moved += 1
                expected = a + (total[i] - left) / total[i] * (b - a)
            assert np.allclose([x[t, i], y[t, i]], expected, atol=1e-4), (t, i)
        previous = row
    assert moved > 10


def test_replay_trial_picks_the_trial_and_refuses_one_the_run_does_not_hold(runs, tmp_path, capsys):
    run, out = runs["foraging"], tmp_path / "page.html"
    assert cli.main(["replay", str(run), "--trial", "4", "--out", str(out)]) == 0
    data = embedded(out)
    assert data["trial"] == 4 and data["served"][-1] == summary_of(run).loc[4, "served"]
    out.unlink()
    for trial in ("1", "5"):
        _refused(capsys, ["replay", str(run), "--trial", trial, "--out", str(out)],
                 f"--trial {trial}: RUN_DIR {str(run)!r} holds trials 2 to 4")
    assert not out.exists()


def test_replay_trial_of_a_replenishment_run(tmp_path, capsys):
    (tmp_path / "r.toml").write_text('scenario = "replenishment"\n[run]\ntrials = 2\nfirst_trial = 3\nticks = 300\n')
    run = tmp_path / "run"
    assert cli.main(["run", str(tmp_path / "r.toml"), "--out", str(run)]) == 0
    assert cli.main(["replay", str(run), "--trial", "4"]) == 0
    data = embedded(run / REPLAY_FILE)
    assert "trial 4 of" in data["title"] and data == json.loads(json.dumps(replenishment_data(run, 4)))
    assert data["work"][-1] == pq.read_table(run / "summary.parquet").to_pandas().set_index("trial").loc[4, "work"]
    _refused(capsys, ["replay", str(run), "--trial", "5", "--out", str(tmp_path / "page.html")],
             "--trial 5: RUN_DIR")
    assert not (tmp_path / "page.html").exists()


@pytest.mark.parametrize("scenario, text", [
    ("replenishment", 'scenario = "replenishment"\n[run]\ntrials = 2\nfirst_trial = 3\nticks = 300\n'),
    ("items", RUNS["foraging"])], ids=["replenishment", "items"])
def test_run_replay_trial_writes_the_page_of_that_trial(scenario, text, tmp_path, capsys):
    (tmp_path / "c.toml").write_text(text)
    run = tmp_path / "run"
    last = 4  # the last of trials 3-4 and 2-4
    assert cli.main(["run", str(tmp_path / "c.toml"), "--out", str(run), "--replay", "--trial", str(last)]) == 0
    data = embedded(run / REPLAY_FILE)
    assert f"trial {last} of" in data["title"]
    column = "work" if scenario == "replenishment" else "served"
    assert data[column][-1] == summary_of(run).loc[last, column]


@pytest.mark.parametrize("argv, fragment", [
    (["--replay", "--trial", "5"], "--trial 5: the run holds trials 3 to 4"),
    (["--replay", "--trial", "2"], "--trial 2: the run holds trials 3 to 4"),
    (["--trial", "4"], "--trial 4 chooses the trial of the replay page: give it with --replay"),
])
def test_run_replay_trial_out_of_range_is_refused_before_the_run(argv, fragment, tmp_path, capsys, monkeypatch):
    (tmp_path / "r.toml").write_text('scenario = "replenishment"\n[run]\ntrials = 2\nfirst_trial = 3\nticks = 300\n')
    module = importlib.import_module("dronefleet.replenishment.simulate")
    monkeypatch.setattr(module, "simulate", lambda *a, **kw: pytest.fail("the run was simulated"))
    _refused(capsys, ["run", str(tmp_path / "r.toml"), "--out", str(tmp_path / "run"), *argv], fragment)
    assert not (tmp_path / "run").exists()


def test_run_replay_trial_of_a_delivery_run_is_refused_before_the_run(tmp_path, capsys):
    _refused(capsys, ["run", "--set", "horizon_weeks=0.01", "--out", str(tmp_path / "run"), "--replay", "--trial", "1"],
             "--trial 1: a delivery run is one replicate")
    assert not (tmp_path / "run").exists()


def test_replay_trial_of_a_delivery_run_is_refused(tmp_path, capsys):
    run = tmp_path / "run"
    assert cli.main(["run", "--set", "horizon_weeks=0.01", "--set", "n_uavs=2", "--out", str(run)]) == 0
    _refused(capsys, ["replay", str(run), "--trial", "2"], "--trial 2: a delivery run is one replicate")
    assert not (run / REPLAY_FILE).exists()


def _tamper(run, tmp_path, change, tables=("summary", "robots")):
    """A copy of ``run`` whose tables' config is changed by ``change`` (dict -> dict)."""
    copy = tmp_path / "tampered"
    copy.mkdir()
    for name in ("summary", "robots"):
        table = pq.read_table(run / f"{name}.parquet")
        if name in tables:
            config = change(json.loads(table.schema.metadata[CONFIG_KEY]))
            table = table.replace_schema_metadata({CONFIG_KEY: json.dumps(config)})
        pq.write_table(table, copy / f"{name}.parquet")
    return copy


def _no_simulation(monkeypatch):
    module = importlib.import_module("dronefleet.items.simulate")  # the package's name is the function
    monkeypatch.setattr(module, "run_cell", lambda *a, **kw: pytest.fail("a trial was simulated"))


@pytest.mark.parametrize("change, fragment", [
    (lambda c: {**c, "run": {**c["run"], "steps": 1_000_000}},
     "a replay page of (steps 1000000 + 1) x (5 robots + 20 locations) = 25,000,025 values is too large; "
     "at most 2,000,000"),
    (lambda c: {**c, "run": {**c["run"], "first_trial": 7}}, "has no row of trial 7"),
    (lambda c: {**c, "run": {**c["run"], "trials": 0}}, "run.trials = 0 is out of range"),
    (lambda c: {"scenario": "replenishment"}, "not a complete replenishment run folder"),
])
def test_a_tampered_run_is_refused_in_one_line_before_any_simulation(change, fragment, runs, tmp_path, capsys,
                                                                      monkeypatch):
    tampered, out = _tamper(runs["foraging"], tmp_path, change), tmp_path / "page.html"
    _no_simulation(monkeypatch)
    _refused(capsys, ["replay", str(tampered), "--out", str(out)], fragment)
    assert not out.exists() and sorted(p.name for p in tampered.iterdir()) == ["robots.parquet", "summary.parquet"]


@pytest.mark.parametrize("change", [lambda c: {**c, "robots": {**c["robots"], "algorithm": "R"}},
                                    lambda c: {**c, "run": {**c["run"], "seed": 7}}])
def test_a_config_that_does_not_give_the_summarys_trial_is_refused_in_one_line(change, runs, tmp_path, capsys):
    tampered, out = _tamper(runs["foraging"], tmp_path, change), tmp_path / "page.html"
    served = int(summary_of(tampered).loc[2, "served"])
    _refused(capsys, ["replay", str(tampered), "--out", str(out)],
             f"summary.parquet': trial 2 has generated {int(summary_of(tampered).loc[2, 'generated'])}, "
             f"served {served}, but its config gives generated")
    assert not out.exists()


def test_run_replay_of_a_run_too_large_for_a_page_is_refused_before_the_run(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(items_replay, "MAX_VALUES", 100)
    (tmp_path / "items.toml").write_text(RUNS["foraging"])
    _refused(capsys, ["run", str(tmp_path / "items.toml"), "--out", str(tmp_path / "run"), "--replay"],
             "--replay: a replay page of (steps 200 + 1) x (5 robots + 20 locations) = 5,025 values is too large; "
             "at most 100")
    assert not (tmp_path / "run").exists()


def test_run_replay_of_a_scenario_without_a_page_is_refused_before_the_run(tmp_path, capsys, monkeypatch):
    from dronefleet.items import scenario

    monkeypatch.delattr(scenario, "replay_data")
    (tmp_path / "items.toml").write_text(RUNS["foraging"])
    _refused(capsys, ["run", str(tmp_path / "items.toml"), "--out", str(tmp_path / "run"), "--replay"],
             "scenario 'items' has no replay page; scenarios with one: delivery, replenishment")
    assert not (tmp_path / "run").exists()


# ------------------------------------------------------------------ in a real browser


@needs_chromium
@pytest.mark.parametrize("name", RUNS)
def test_the_page_plays_in_chromium_without_errors(name, runs, tmp_path):
    page, steps = runs[name] / REPLAY_FILE, read_config(runs[name] / "summary.parquet").steps
    shots = []
    for t in (5, steps // 2):
        shot = tmp_path / f"{t}.png"
        chromium(page, f"t={t}", [f"--screenshot={shot}"], tmp_path / "profile")
        shots.append(shot.read_bytes())
        assert shots[-1].startswith(b"\x89PNG")
    assert shots[0] != shots[1]
    dom = chromium(page, f"t={steps}", ["--dump-dom"], tmp_path / "profile")
    assert f'data-rendered="{steps}"' in dom
    # the counters at the end are the trial's totals
    summary, shown = summary_of(runs[name]).iloc[0], counters(dom)
    assert shown["step"] == str(steps)
    assert shown["foraged" if name == "logistic" else "served"] == f"{int(summary['served']):,}"
    assert shown["net growth (A19)" if name == "logistic" else "generated"] == f"{int(summary['generated']):,}"
    # the side chart: the served share (logistic: foraged) over the steps, on labelled axes
    axes, paths = chart_of(dom)
    assert axes["x"][1] == ["step"] and axes["x"][0][0] == 0 and axes["x"][0][-1] <= steps
    assert axes["y"][1] == ["foraged [items]" if name == "logistic" else "served [% of generated]"]
    assert len(paths) == 1 and paths[0].count("M") == 1
