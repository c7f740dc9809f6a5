"""The lunar replay page: its data is the chosen run's frames (field, regions, obstacle, beacons'
vectors, robots by role and charge) and resources series, the same whether the folder kept the
frames or the run is simulated again; a too large or tampered run is refused in one line before
anything is written; ``--trial`` picks the run; the page plays in headless Chromium."""

import json

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from test_replay import _refused, chromium, counters, embedded, needs_chromium

from dronefleet import cli
from dronefleet.lunar import replay as lunar_replay
from dronefleet.lunar import scenario
from dronefleet.lunar.layout import build
from dronefleet.records import CONFIG_KEY, REPLAY_FILE

#: Two runs of 2 minutes of SOFT-RT (with and without frames in the folder) and one of HARD-NT.
RUNS = {
    "frames": ["--set", "runs=2", "--set", "first_run=3", "--set", "duration_s=120", "--set", "frames=true"],
    "plain": ["--set", "runs=2", "--set", "first_run=3", "--set", "duration_s=120"],
    "hard": ["--set", "runs=1", "--set", "duration_s=60", "--set", "layout=HARD-NT", "--set", "n_robots=20"],
}


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    folder = tmp_path_factory.mktemp("lunar")
    out = {}
    for name, argv in RUNS.items():
        out[name] = folder / name
        assert cli.main(["run", "lunar", *argv, "--out", str(out[name]), "--replay"]) == 0
    return out


def summary_of(run):
    return pq.read_table(run / "summary.parquet").to_pandas().set_index("run")


@pytest.mark.parametrize("name", RUNS)
def test_the_page_holds_the_frames_of_the_first_run(name, runs):
    run = runs[name]
    config = scenario.read_config(run / "summary.parquet")
    data = embedded(run / REPLAY_FILE)
    assert data == json.loads(json.dumps(scenario.replay_data(run)))
    assert data["run"] == config.first_run and f"lunar run {config.first_run} of" in data["title"]
    n, frames = config.n_robots, len(data["times"])
    assert frames == config.ticks // config.n_T and data["duration_s"] == pytest.approx(config.ticks * config.tau)
    for column in ("x", "y", "soc", "state", "load", *(f"v{a}_{k}" for k in "TNR" for a in "xy")):
        assert len(data[column]) == frames * n, column
    geometry = build(config)
    assert data["field"] == list(geometry.field) and data["layout"] == config.layout
    assert data["regions"]["T"] == [*geometry.centres["T"], geometry.radii["T"]]
    assert data["obstacle_kind"] == geometry.kind and np.allclose(data["obstacle"], geometry.obstacle, atol=1e-4)
    w, h = geometry.field
    state = np.array(data["state"])
    placed = state != lunar_replay.ROLE_CODES["unspawned"]
    assert all(0 <= x <= w for x in np.array(data["x"])[placed]) and all(0 <= y <= h for y in np.array(data["y"])[placed])
    assert set(state) <= set(lunar_replay.ROLE_CODES.values()) and (state == lunar_replay.ROLE_CODES["B"]).any()
    # only beacons hold vectors, and some hold one
    vectors = np.hypot(np.array(data["vx_T"]), np.array(data["vy_T"]))
    assert (vectors[state != lunar_replay.ROLE_CODES["B"]] == 0).all() and (vectors > 0).any()
    # the chart ends at the run's resources
    assert data["resources"][-1] == summary_of(run).loc[config.first_run, "resources"]
    assert data["resources"] == sorted(data["resources"]) and len(data["series_t"]) == len(data["resources"])


def test_a_run_without_frames_is_simulated_again_into_the_same_page(runs):
    with_frames, plain = (scenario.replay_data(runs[name], 4) for name in ("frames", "plain"))
    assert with_frames["run"] == plain["run"] == 4
    assert {k: v for k, v in with_frames.items() if k != "title"} == {k: v for k, v in plain.items() if k != "title"}


def test_replay_trial_picks_the_run_and_refuses_one_the_folder_does_not_hold(runs, tmp_path, capsys):
    run, out = runs["plain"], tmp_path / "page.html"
    assert cli.main(["replay", str(run), "--trial", "4", "--out", str(out)]) == 0
    data = embedded(out)
    assert data["run"] == 4 and data["resources"][-1] == summary_of(run).loc[4, "resources"]
    out.unlink()
    for trial in ("2", "5"):
        _refused(capsys, ["replay", str(run), "--trial", trial, "--out", str(out)], f"--trial {trial}: RUN_DIR")
    assert not out.exists()


def _tamper(run, tmp_path, summary=None, config=None):
    """A copy of ``run`` whose summary rows (``summary``: frame -> frame) or config (dict -> dict) are changed."""
    copy = tmp_path / "tampered"
    copy.mkdir()
    for name in scenario.TABLES:
        table = pq.read_table(run / f"{name}.parquet")
        metadata = table.schema.metadata
        if config is not None:
            metadata = {**metadata, CONFIG_KEY: json.dumps(config(json.loads(metadata[CONFIG_KEY])))}
        if name == "summary" and summary is not None:
            table = pa.Table.from_pandas(summary(table.to_pandas()), schema=table.schema, preserve_index=False)
        pq.write_table(table.replace_schema_metadata(metadata), copy / f"{name}.parquet")
    return copy


def test_a_summary_the_run_does_not_give_is_refused_in_one_line(runs, tmp_path, capsys):
    def more(frame):
        frame.loc[frame["run"] == 3, "resources"] += 1
        return frame
    tampered, out = _tamper(runs["plain"], tmp_path, summary=more), tmp_path / "page.html"
    _refused(capsys, ["replay", str(tampered), "--out", str(out)],
             f"table {str(tampered / 'summary.parquet')!r}: run 3 simulated again from its config gives another summary")
    assert not out.exists()


def test_a_config_whose_occlusion_tests_exceed_the_limit_is_refused_before_it_is_simulated(runs, tmp_path, capsys):
    def occluding(config):   # 500 robots for 600 s with bodies occluding: minutes of simulation
        config["robots"]["n_robots"], config["run"]["duration_s"] = 500, 600.0
        config["options"]["los_bodies"] = True
        return config
    tampered, out = _tamper(runs["plain"], tmp_path, config=occluding), tmp_path / "page.html"
    assert "at most 6e+11" in _refused(capsys, ["replay", str(tampered), "--out", str(out)], "occlusion-tests")
    assert not out.exists()


def test_frames_that_are_not_whole_are_refused_in_one_line(runs, tmp_path, capsys):
    copy = tmp_path / "cut"
    copy.mkdir()
    for name in scenario.TABLES:
        table = pq.read_table(runs["frames"] / f"{name}.parquet")
        if name == "snapshots":   # one robot of one frame of run 4 missing
            frames = table.to_pandas()
            lost = frames.index[(frames["run"] == 4) & (frames["label"] == "frame")][7]
            table = pa.Table.from_pandas(frames.drop(index=lost), schema=table.schema, preserve_index=False)
        pq.write_table(table.replace_schema_metadata(table.schema.metadata), copy / f"{name}.parquet")
    _refused(capsys, ["replay", str(copy), "--trial", "4", "--out", str(tmp_path / "page.html")],
             f"table {str(copy / 'snapshots.parquet')!r}: the frames of run 4 do not hold each of its 50 robots")


def test_a_run_too_large_for_a_page_is_refused_before_the_run(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(lunar_replay, "MAX_VALUES", 1000)
    _refused(capsys, ["run", "lunar", "--set", "runs=1", "--set", "duration_s=30", "--out", str(tmp_path / "run"),
                      "--replay"],
             "--replay: a replay page of 4 frames x 50 robots x 11 values = 2,200 values is too large; at most 1,000")
    assert not (tmp_path / "run").exists()


@pytest.mark.parametrize("frames", ["true", "false"])
def test_a_run_shorter_than_a_frame_interval_is_drawn_from_its_end_snapshot(tmp_path, frames):
    # 5 s is 78 ticks, n_T is 156: the run records no frame, only its end
    run = tmp_path / "run"
    assert cli.main(["run", "lunar", "--set", "runs=1", "--set", "n_robots=3", "--set", "duration_s=5",
                     "--set", f"frames={frames}", "--out", str(run), "--replay"]) == 0
    config = scenario.read_config(run / "summary.parquet")
    assert config.ticks < config.n_T
    data = embedded(run / REPLAY_FILE)
    assert data["times"] == [pytest.approx(config.ticks * config.tau)] and len(data["x"]) == 3
    assert data == json.loads(json.dumps(scenario.replay_data(run)))


@needs_chromium
def test_the_page_plays_in_chromium_and_ends_at_the_runs_totals(runs, tmp_path):
    run = runs["hard"]
    page = run / REPLAY_FILE
    shots = []
    for t in (5, 55):
        chromium(page, f"t={t}", [f"--screenshot={tmp_path / 'shot.png'}"], tmp_path / "profile")
        shots.append((tmp_path / "shot.png").read_bytes())
        assert shots[-1].startswith(b"\x89PNG")
    assert shots[0] != shots[1]
    summary = summary_of(run).iloc[0]
    dom = chromium(page, "t=60", ["--dump-dom"], tmp_path / "profile")
    assert 'data-rendered="' in dom
    shown = counters(dom)
    assert shown["resources returned"] == f"{summary['resources']:,}"
    assert shown["beacons"] == f"{embedded(page)['n_beacons'][-1]:,}"
