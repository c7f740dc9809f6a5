"""The replay page: its data follows the run's tables, it is self-contained, the command refuses
bad input in one line, and it plays in a real browser (headless Chromium) without an error."""

import importlib
import json
import os
import re
import shutil
import subprocess

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from dronefleet import cli, replay
from dronefleet.delivery import replay as delivery_replay
from dronefleet.delivery.replay import replay_data as delivery_data
from dronefleet.records import CONFIG_KEY, REPLAY_FILE, run_dir_state
from dronefleet.replenishment import Params, simulate
from dronefleet.replenishment.kernel import BASE, TRANSFER, WORK, floor_colour
from dronefleet.replenishment import replay as replay_module
from dronefleet.replenishment.replay import AREAS
from dronefleet.replenishment.scenario import replay_data as replenishment_data

REPLENISHMENT = 'scenario = "replenishment"\n[run]\ntrials = 2\nfirst_trial = 3\nticks = 900\n'


@pytest.fixture(scope="module")
def delivery_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("delivery") / "run"
    assert cli.main(["run", "--set", "horizon_weeks=0.1", "--set", "n_uavs=5", "--seed", "2",
                     "--out", str(out), "--replay"]) == 0
    return out


@pytest.fixture(scope="module")
def replenishment_run(tmp_path_factory):
    folder = tmp_path_factory.mktemp("replenishment")
    (folder / "replenishment.toml").write_text(REPLENISHMENT)
    out = folder / "run"
    assert cli.main(["run", str(folder / "replenishment.toml"), "--out", str(out), "--replay"]) == 0
    return out


def embedded(path):
    """The JSON data embedded in a replay page."""
    return json.loads(re.search(r'id="run-data">(.*?)</script>', path.read_text(), re.S)[1])


def test_run_replay_writes_the_page_beside_the_tables_and_the_folder_stays_a_run(delivery_run, capsys):
    assert (delivery_run / REPLAY_FILE).is_file()
    assert run_dir_state(delivery_run, ("orders", "attempts", "fleet", "timeseries", "summary")) == "complete"
    # --overwrite takes the folder as a run; the new run comes without the old (now stale) page
    assert cli.main(["run", "--set", "horizon_weeks=0.01", "--set", "n_uavs=2", "--out", str(delivery_run),
                     "--overwrite"]) == 0
    assert not (delivery_run / REPLAY_FILE).exists()
    assert cli.main(["run", "--set", "horizon_weeks=0.1", "--set", "n_uavs=5", "--seed", "2",
                     "--out", str(delivery_run), "--overwrite", "--replay"]) == 0
    capsys.readouterr()


def test_a_folder_holding_only_a_replay_page_is_not_a_run(tmp_path):
    (tmp_path / REPLAY_FILE).write_text("<html></html>")
    assert run_dir_state(tmp_path, ("summary",)) == "other"


def test_delivery_flights_follow_the_attempts(delivery_run):
    data = delivery_data(delivery_run)
    attempts = pq.read_table(delivery_run / "attempts.parquet").to_pandas()
    orders = pq.read_table(delivery_run / "orders.parquet").to_pandas()
    f = data["flights"]
    assert len(f["takeoff_s"]) == len(attempts) and data["n_uavs"] == 5
    for uav in range(5):
        rows = slice(data["uav_start"][uav], data["uav_start"][uav + 1])
        own = attempts[attempts.uav == uav].sort_values("takeoff_s")
        assert f["takeoff_s"][rows] == np.round(own.takeoff_s, 1).tolist()
        assert f["turn_s"][rows] == np.round(own.turn_s, 1).tolist()
        assert f["return_s"][rows] == np.round(own.return_s, 1).tolist()
        outcome = [data["outcomes"][o] for o in f["outcome"][rows]]
        assert outcome == own.outcome.tolist()
        distance = orders.distance_m.to_numpy()[own.order_id]
        turn_m = np.array(f["turn_m"][rows])
        delivered = own.outcome.to_numpy() == "delivered"
        # a delivery turns at the order's distance, an abort short of it, at 10 m/s
        assert np.array_equal(turn_m[delivered], np.round(distance[delivered]))
        assert np.all(turn_m[~delivered] < distance[~delivered])
        assert np.allclose(turn_m[~delivered], 10.0 * (own.turn_s - own.takeoff_s)[~delivered], atol=0.5)
    assert "aborted" in attempts.outcome.tolist()
    assert data["arrival_s"] == sorted(np.round(orders.arrival_s, 1).tolist())


def test_replenishment_replay_is_the_runs_first_trial(replenishment_run):
    data = replenishment_data(replenishment_run)
    summary = pq.read_table(replenishment_run / "summary.parquet").to_pandas().set_index("trial")
    assert "trial 3 of" in data["title"]
    assert data["work"][-1] == summary.loc[3, "work"] != summary.loc[4, "work"]
    assert len(data["work"]) == 900 // 10 + 1 and len(data["x"]) == len(data["work"]) * 12
    assert data["stored"][0] == 6 * 100.0 + 6 * 200.0
    assert max(map(abs, data["x"] + data["y"])) <= data["wall_m"]


def test_a_long_replenishment_run_is_replayed_from_the_frames_alone(replenishment_run, monkeypatch):
    # 91 samples, at most 7 frames: every 13th sample. Only those are tracked, not all 91
    # (a long run's every sample would exhaust memory), and they are the same.
    full = replenishment_data(replenishment_run)
    monkeypatch.setattr(replay_module, "MAX_FRAMES", 7)
    tracked = []
    module = importlib.import_module("dronefleet.replenishment.simulate")  # the package's name is the function
    monkeypatch.setattr(module, "simulate",
                        lambda p, **k: tracked.append(p.sample_every) or simulate(p, **k))
    data = replenishment_data(replenishment_run)
    assert tracked == [130]
    assert data["frame_s"] == 13.0 and len(data["work"]) == 7
    assert data["work"] == full["work"][::13] and data["stored"] == full["stored"][::13]
    for name in ("x", "y", "energy", "phase"):
        assert data[name] == np.reshape(full[name], (91, 12))[::13].reshape(-1).tolist(), name


def test_the_track_changes_no_output_and_agrees_with_the_time_series():
    params = Params(strategy="mobile", n_workers=4, n_chargers=3, ticks=700, trials=2, sample_every=7)
    plain, tracked = simulate(params), simulate(params, track=True)
    for name, values in plain.items():
        assert np.array_equal(values, tracked[name]), name
    track, series = tracked["track"], tracked["series"][0]
    assert track["x"].shape == (700 // 7 + 1, 7)
    assert np.allclose(track["energy"].sum(axis=1), series[:, 8], rtol=1e-12)
    for phase in range(4):  # robots per phase: workers in columns 0-3, chargers 4-7
        assert np.array_equal((track["phase"][:, :4] == phase).sum(axis=1), series[:, phase])
        assert np.array_equal((track["phase"][:, 4:] == phase).sum(axis=1), series[:, 4 + phase])


@pytest.mark.parametrize("name, colour", [("base", BASE), ("transfer", TRANSFER), ("work", WORK)])
def test_the_page_draws_the_areas_where_the_kernel_reads_them(name, colour):
    x0, x1, y0, y1 = AREAS[name]
    inside = [((x0 + x1) / 2, 0.0), (x0 + 1e-9, y1 - 1e-9), (x1 - 1e-9, y0 + 1e-9)]
    assert all(floor_colour(x, y, True) == colour for x, y in inside)
    assert floor_colour(x0 - 0.01, 0.0, True) != colour and floor_colour(x1 + 0.01, 0.0, True) != colour


@pytest.mark.parametrize("run", ["delivery_run", "replenishment_run"])
def test_the_page_is_self_contained_and_embeds_the_data(run, request):
    run_dir = request.getfixturevalue(run)
    html = (run_dir / REPLAY_FILE).read_text()
    # nothing to fetch: no linked file, stylesheet, image, font or address
    assert not re.search(r"\b(src|href)\s*=|url\(|@import|https?:|//cdn", html, re.I)
    expected = replay.scenario_of_run(run_dir).replay_data(run_dir)
    assert embedded(run_dir / REPLAY_FILE) == json.loads(json.dumps(expected))
    assert "function makeScene" in html


def test_script_ends_in_the_data_are_escaped(tmp_path):
    html = replay.page({"title": "</script><b>", "duration_s": 1.0}, "function makeScene() {}")
    data = re.search(r'id="run-data">(.*?)</script>', html, re.S)[1]
    assert json.loads(data)["title"] == "</script><b>"


#: Text that would break out of (or never close) the data's script element, or fill in a placeholder.
HOSTILE_TEXT = "<!--<script></script><b>&amp;\u2028\u2029 /*SCENE*/ /*DATA*/ -->"


def test_no_text_in_the_data_can_open_a_comment_or_a_script(tmp_path):
    html = replay.page({"title": HOSTILE_TEXT, "duration_s": 1.0}, "function makeScene() {}")
    data = re.search(r'id="run-data">(.*?)</script>', html, re.S)[1]
    assert json.loads(data)["title"] == HOSTILE_TEXT
    for opening in ("<!--", "<script", "</script", "\u2028", "\u2029", "/*SCENE*/"):
        assert opening not in data.lower()
    assert html.count("function makeScene() {}") == 1


def _refused(capsys, argv, fragment):
    assert cli.main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("dronefleet: error: ") and err.count("\n") == 1 and fragment in err, err
    return err


def test_bad_run_folders_are_refused_in_one_line(tmp_path, capsys, delivery_run):
    _refused(capsys, ["replay", str(tmp_path / "absent")], "is missing")
    (tmp_path / "file").write_text("x")
    _refused(capsys, ["replay", str(tmp_path / "file")], "is a file")
    _refused(capsys, ["replay", str(tmp_path)], "is not a run folder")
    partial = tmp_path / "partial"
    shutil.copytree(delivery_run, partial)
    (partial / "fleet.parquet").unlink()
    _refused(capsys, ["replay", str(partial)], "not a complete delivery run folder")
    shutil.copy(delivery_run / "fleet.parquet", partial)
    summary = pq.read_table(partial / "summary.parquet")
    pq.write_table(summary.replace_schema_metadata({CONFIG_KEY: "[]"}), partial / "summary.parquet")
    _refused(capsys, ["replay", str(partial)], "is not a run folder: it has no summary.parquet written by")


@pytest.mark.parametrize("damage, fragment", [
    ("cut short", "orders.parquet not of the run in summary.parquet (another run's config, or unreadable)"),
    ("of the other scenario", "timeseries.parquet not of the run in summary.parquet"),
    ("of another run", "orders.parquet not of the run in summary.parquet"),
    ("corrupt inside", "orders.parquet' is damaged"),
])
def test_a_run_folder_with_an_unreadable_or_stray_table_is_refused_in_one_line(damage, fragment, tmp_path, capsys,
                                                                              delivery_run, replenishment_run):
    damaged = tmp_path / "run"
    shutil.copytree(delivery_run, damaged)
    orders = damaged / "orders.parquet"
    data = orders.read_bytes()
    if damage == "cut short":
        orders.write_bytes(data[:len(data) // 2])
    elif damage == "of the other scenario":
        shutil.copy(replenishment_run / "timeseries.parquet", damaged / "timeseries.parquet")
    elif damage == "of another run":  # the same columns, fewer orders: the attempts would index past them
        assert cli.main(["run", "--set", "horizon_weeks=0.01", "--set", "n_uavs=2", "--out", str(tmp_path / "o")]) == 0
        shutil.copy(tmp_path / "o" / "orders.parquet", orders)
    else:  # the first page's header overwritten, the footer (schema and config) intact
        orders.write_bytes(data[:4] + b"\xab" * 64 + data[4 + 64:])
    capsys.readouterr()
    _refused(capsys, ["replay", str(damaged), "--out", str(tmp_path / "page.html")], fragment)
    assert not (tmp_path / "page.html").exists()


def with_column(name, values):
    """A change of a table: column ``name`` replaced by ``values`` (a pyarrow array or a list)."""
    def change(table):
        return table.set_column(table.schema.get_field_index(name), name, pa.array(values))
    return change


def without(name):
    return lambda table: table.drop_columns([name])


def tamper_table(path, change):
    """Rewrite the parquet file ``path`` as ``change(table)``, its metadata (the run's config) kept."""
    table = pq.read_table(path)
    pq.write_table(change(table).replace_schema_metadata(table.schema.metadata), path)


def first_set(name, value):
    """Column ``name``'s first value set to ``value``."""
    def change(table):
        values = table[name].to_pylist()
        values[0] = value
        return with_column(name, pa.array(values, table.schema.field(name).type))(table)
    return change


# a table whose embedded config matches, its contents tampered with: what the page relies on is checked
TAMPERED_CONTENTS = [
    ("attempts", first_set("order_id", 10**6), "column 'order_id' holds 1000000 at row 0; allowed: an order of"),
    ("attempts", first_set("order_id", -1), "column 'order_id' holds -1 at row 0"),
    ("attempts", first_set("outcome", "teleported"), "column 'outcome' holds 'teleported' at row 0; allowed: "
                                                     "delivered, aborted, lost, in_flight"),
    ("attempts", first_set("outcome", None), "column 'outcome' holds null at row 0"),
    ("attempts", first_set("uav", 5), "column 'uav' holds 5 at row 0; allowed: a UAV of the run, 0 to 4"),
    ("attempts", first_set("takeoff_s", float("nan")), "column 'takeoff_s' holds nan at row 0"),
    ("attempts", first_set("takeoff_soc", 1e300), "column 'takeoff_soc' holds 1e+300 at row 0"),
    ("attempts", first_set("return_soc", float("inf")), "column 'return_soc' holds inf at row 0"),
    ("attempts", without("outcome"), "has no column 'outcome'"),
    ("attempts", lambda t: with_column("takeoff_s", t["takeoff_s"].cast(pa.string()))(t),
     "column 'takeoff_s' is string, not a float"),
    ("orders", first_set("order_id", 7), "column 'order_id' holds 7 at row 0; allowed: the row number"),
    ("orders", first_set("distance_m", -1.0), "column 'distance_m' holds -1.0 at row 0"),
    ("orders", without("distance_m"), "has no column 'distance_m'"),
    ("orders", first_set("distance_m", 1e308), "column 'distance_m' holds 1e+308 at row 0; allowed: finite, in [0, "),
    ("attempts", first_set("turn_s", 1e308), "column 'turn_s' holds 1e+308 at row 0; allowed: finite, in [0, "),
    ("attempts", first_set("return_s", -1.0), "column 'return_s' holds -1.0 at row 0"),
    ("timeseries", first_set("unallocated", None), "column 'unallocated' holds null at row 0"),
    ("timeseries", first_set("t_s", float("-inf")), "column 't_s' holds -inf at row 0"),
]


@pytest.mark.parametrize("table, change, fragment", TAMPERED_CONTENTS,
                         ids=[f"{table}-{fragment[:40]}" for table, _, fragment in TAMPERED_CONTENTS])
def test_a_table_whose_contents_the_page_cannot_draw_is_refused_in_one_line(table, change, fragment, tmp_path,
                                                                            capsys, delivery_run):
    damaged = tmp_path / "run"
    shutil.copytree(delivery_run, damaged)
    (damaged / REPLAY_FILE).unlink()
    tamper_table(damaged / f"{table}.parquet", change)
    err = _refused(capsys, ["replay", str(damaged), "--out", str(tmp_path / "page.html")], fragment)
    assert f"{table}.parquet'" in err
    assert not (tmp_path / "page.html").exists()


def test_a_run_too_large_to_play_is_refused_in_one_line_before_its_tables_are_read(tmp_path, capsys, delivery_run,
                                                                                  monkeypatch):
    flights = pq.ParquetFile(delivery_run / "attempts.parquet").metadata.num_rows
    monkeypatch.setattr(delivery_replay, "MAX_FLIGHTS", flights - 1)
    monkeypatch.setattr(pq, "read_table", lambda *a, **k: pytest.fail("a table was read"))
    _refused(capsys, ["replay", str(delivery_run), "--out", str(tmp_path / "page.html")],
             f"has {flights:,} attempts; a replay page draws at most {flights - 1:,}")
    assert not (tmp_path / "page.html").exists()


@pytest.mark.parametrize("table, limit, what", [("orders", "MAX_ORDERS", "orders"),
                                                 ("timeseries", "MAX_SAMPLES", "time-series samples")])
def test_a_table_too_long_to_read_is_refused_in_one_line_before_it_is_read(table, limit, what, tmp_path, capsys,
                                                                           delivery_run, monkeypatch):
    rows = pq.ParquetFile(delivery_run / f"{table}.parquet").metadata.num_rows
    monkeypatch.setattr(delivery_replay, limit, rows - 1)
    monkeypatch.setattr(pq, "read_table", lambda *a, **k: pytest.fail("a table was read"))
    _refused(capsys, ["replay", str(delivery_run), "--out", str(tmp_path / "page.html")],
             f"has {rows:,} {what} in {table}.parquet; a replay page reads at most {rows - 1:,}")
    assert not (tmp_path / "page.html").exists()


def test_run_replay_of_a_run_too_large_to_play_is_refused_before_the_run(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(delivery_replay, "MAX_FLIGHTS", 100)  # 0.1 weeks at tau 15 min: ~67 orders
    _refused(capsys, ["run", "--set", "horizon_weeks=0.3", "--out", str(tmp_path / "run"), "--replay"],
             "--replay: the run would hold ~2e+02 orders and a replay page draws at most 100 attempts")
    assert not (tmp_path / "run").exists()
    assert cli.main(["run", "--set", "horizon_weeks=0.1", "--set", "n_uavs=5", "--out", str(tmp_path / "run"),
                     "--replay"]) == 0
    assert (tmp_path / "run" / REPLAY_FILE).is_file()


def test_a_page_is_never_written_over_a_table_nor_into_another_runs_folder(tmp_path, capsys, delivery_run,
                                                                              replenishment_run):
    summary = (delivery_run / "summary.parquet").read_bytes()
    page = (replenishment_run / REPLAY_FILE).read_bytes()
    for out in (delivery_run / "summary.parquet", replenishment_run / "page.html", replenishment_run / REPLAY_FILE):
        _refused(capsys, ["replay", str(delivery_run), "--out", str(out)],
                 f"lies in a run folder, where only that run's own page may go: give "
                 f"{str(delivery_run / REPLAY_FILE)!r} or a file outside any run folder")
    assert (delivery_run / "summary.parquet").read_bytes() == summary
    assert (replenishment_run / REPLAY_FILE).read_bytes() == page
    assert run_dir_state(replenishment_run, ("summary", "timeseries")) == "complete"


def test_unwritable_pages_are_refused_in_one_line(tmp_path, capsys, delivery_run, monkeypatch):
    _refused(capsys, ["replay", str(delivery_run), "--out", str(tmp_path)], "is a folder")
    _refused(capsys, ["replay", str(delivery_run), "--out", str(tmp_path / "no" / "page.html")], "does not exist")

    def read_only(path, write):
        raise PermissionError(13, "Permission denied")
    monkeypatch.setattr(replay, "write_atomic", read_only)
    _refused(capsys, ["replay", str(delivery_run), "--out", str(tmp_path / "page.html")], "Permission denied")


def test_replay_writes_where_asked(tmp_path, capsys, replenishment_run):
    out = tmp_path / "page.html"
    assert cli.main(["replay", str(replenishment_run), "--out", str(out)]) == 0
    assert str(out) in capsys.readouterr().out
    assert embedded(out) == embedded(replenishment_run / REPLAY_FILE)


# ------------------------------------------------------------------ in a real browser

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
needs_chromium = pytest.mark.skipif(CHROMIUM is None, reason="Chromium is not installed (Debian: apt-get install "
                                                              "chromium); the replay page is not tested in a browser")


def chromium(page, fragment, output, profile):
    """Load ``page#fragment`` headless, offline; return (stdout, stderr). Every name lookup
    fails, so a page that fetched anything would log an error."""
    done = subprocess.run(
        [CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         f"--user-data-dir={profile}", "--host-resolver-rules=MAP * ~NOTFOUND",
         "--enable-logging=stderr", "--v=0", "--window-size=1200,800", "--virtual-time-budget=3000",
         *output, f"{page.as_uri()}#{fragment}"],
        capture_output=True, text=True, timeout=300)
    # the page logs nothing: any console line is an error or a failed load
    console = [line for line in done.stderr.splitlines() if ":CONSOLE" in line]
    assert not console, console
    return done.stdout


def counters(dom):
    """The counters table of a dumped page: {label: text}."""
    return dict(re.findall(r"<tr><td>([^<]*)</td><td>([^<]*)</td></tr>", dom))


@needs_chromium
@pytest.mark.parametrize("run, times", [("delivery_run", (3000, 60000)), ("replenishment_run", (10, 80))])
def test_the_page_plays_in_chromium_without_errors(run, times, request, tmp_path):
    page = request.getfixturevalue(run) / REPLAY_FILE
    shots = []
    for t in times:
        shot = tmp_path / f"{t}.png"
        chromium(page, f"t={t}", [f"--screenshot={shot}"], tmp_path / "profile")
        shots.append(shot.read_bytes())
        assert shots[-1].startswith(b"\x89PNG")
    assert shots[0] != shots[1]
    dom = chromium(page, f"t={times[1]}", ["--dump-dom"], tmp_path / "profile")
    assert f'data-rendered="{times[1]}"' in dom  # the player ran to the end and drew that time


@needs_chromium
def test_the_page_plays_whatever_text_its_data_holds(delivery_run, tmp_path):
    data = delivery_data(delivery_run)
    data["title"] = HOSTILE_TEXT  # a config string, say, shown in the title
    page = tmp_path / "page.html"
    page.write_text(replay.page(data, replay.scenario_of_run(delivery_run).replay_script))
    dom = chromium(page, "t=3000", ["--dump-dom"], tmp_path / "profile")
    assert 'data-rendered="3000"' in dom  # the player started and drew that time


@needs_chromium
def test_the_counters_at_the_end_are_the_runs_totals(delivery_run, replenishment_run, tmp_path):
    summary = pq.read_table(delivery_run / "summary.parquet").to_pylist()[0]
    shown = counters(chromium(delivery_run / REPLAY_FILE, f"t={summary['horizon_weeks'] * 604800}",
                              ["--dump-dom"], tmp_path / "profile"))
    assert shown["orders arrived"] == f"{summary['orders_arrived']:,}"
    assert shown["delivered"] == f"{summary['delivered']:,}"
    assert shown["pending"] == f"{summary['pending']:,}"
    assert shown["attempts aborted"] == f"{summary['aborted_attempts']:,}"
    trials = pq.read_table(replenishment_run / "summary.parquet").to_pandas().set_index("trial")
    shown = counters(chromium(replenishment_run / REPLAY_FILE, "t=90", ["--dump-dom"], tmp_path / "profile"))
    assert shown["work [points]"] == f"{trials.loc[3, 'work']:,}"


def test_a_special_file_at_out_is_refused_not_replaced(tmp_path, capsys, delivery_run):
    pipe = tmp_path / "page.html"
    os.mkfifo(pipe)
    _refused(capsys, ["replay", str(delivery_run), "--out", str(pipe)],
             f"--out {str(pipe)!r} is a named pipe (FIFO), which writing would replace with a regular file")
    assert pipe.is_fifo() and [p.name for p in tmp_path.iterdir()] == ["page.html"]


def chart_of(dom):
    """The overview chart of a dumped page: {axis: ([tick values], label)} for "x" and "y", and
    the ``d`` of its series path."""
    svg = re.search(r'<svg id="chart".*?</svg>', dom, re.S)[0]
    axes = {}
    for name in ("x", "y"):
        group = re.search(rf'<g class="axis {name}">(.*?)</g>', svg, re.S)[1]
        texts = re.findall(r'<text( class="label")?[^>]*>([^<]*)</text>', group)
        axes[name] = ([float(text.replace(",", "")) for label, text in texts if not label],
                      [text for label, text in texts if label])
    return axes, re.findall(r'<path class="series" d="([^"]*)"', svg)


@needs_chromium
@pytest.mark.parametrize("run, x_label, y_label, x_end", [
    ("delivery_run", "time [h]", "unallocated [orders]", 0.1 * 168),
    ("replenishment_run", "time [s]", "stored [energy units]", 90.0)])
def test_the_chart_has_axes_with_values_and_units_and_one_continuous_line(run, x_label, y_label, x_end, request,
                                                                          tmp_path):
    run_dir = request.getfixturevalue(run)
    axes, paths = chart_of(chromium(run_dir / REPLAY_FILE, "t=10", ["--dump-dom"], tmp_path / "profile"))
    (x_ticks, x_labels), (y_ticks, y_labels) = axes["x"], axes["y"]
    assert x_labels == [x_label] and y_labels == [y_label]
    # round, ascending values from the start of the run to no later than its end
    assert x_ticks[0] == 0 and len(x_ticks) >= 3 and x_ticks == sorted(x_ticks) and x_ticks[-1] <= x_end
    data = embedded(run_dir / REPLAY_FILE)
    values = data["queue"]["orders"] if run == "delivery_run" else data["stored"]
    assert y_ticks[0] <= min(values) and y_ticks[-1] >= max(values) and len(y_ticks) >= 3
    # one path, started once: a line, not dots or bars per pixel column
    assert len(paths) == 1 and paths[0].count("M") == 1 and paths[0].count("L") >= 20


def _vermillion_pixels(shot):
    """How many pixels of the map (left of the side panel) of screenshot ``shot`` are the
    vermillion of the battery-empty mark."""
    from matplotlib.image import imread

    rgb = imread(shot)[:, :880, :3] * 255
    return int((np.abs(rgb - [213, 94, 0]).max(axis=2) < 40).sum())


@needs_chromium
def test_an_empty_battery_is_marked_visibly(replenishment_run, tmp_path):
    data = replenishment_data(replenishment_run)
    n = data["n_workers"] + data["n_chargers"]
    # worker 0 and the last charger empty at every frame: the darkest colour of the scale
    data["energy"] = [0.0 if i % n in (0, n - 1) else e for i, e in enumerate(data["energy"])]
    page = tmp_path / "empty.html"
    page.write_text(replay.page(data, replay.scenario_of_run(replenishment_run).replay_script))
    counts = []
    for source in (page, replenishment_run / REPLAY_FILE):
        chromium(source, "t=40", [f"--screenshot={tmp_path / 'shot.png'}"], tmp_path / "profile")
        counts.append(_vermillion_pixels(tmp_path / "shot.png"))
    assert counts[0] >= 2 * 20 and counts[1] == 0, counts  # a mark of tens of pixels per empty robot, none else


def test_out_replaces_only_a_page_dronefleet_wrote_never_a_users_file_nor_through_a_link(tmp_path, capsys,
                                                                                           delivery_run):
    mine, layout = tmp_path / "mine.html", tmp_path / "_layout.json"
    mine.write_text("<html>my notes</html>")
    layout.write_text('{"keys": ["seed"]}')
    link = tmp_path / "link.html"
    link.symlink_to(mine)
    for out in (mine, layout):
        _refused(capsys, ["replay", str(delivery_run), "--out", str(out)],
                 f"--out {str(out)!r} exists and is not a replay page that dronefleet wrote, so it is not replaced")
    _refused(capsys, ["replay", str(delivery_run), "--out", str(link)], "is a symbolic link")
    assert mine.read_text() == "<html>my notes</html>" and layout.read_text() == '{"keys": ["seed"]}'
    assert link.is_symlink()
    page = tmp_path / "page.html"  # a page dronefleet wrote is replaced
    assert cli.main(["replay", str(delivery_run), "--out", str(page)]) == 0
    assert cli.main(["replay", str(delivery_run), "--out", str(page)]) == 0
    assert replay.is_page(page) and embedded(page) == embedded(delivery_run / REPLAY_FILE)
    capsys.readouterr()
