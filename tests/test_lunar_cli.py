"""``dronefleet run lunar``: the tables with the contract's columns (LUNAR-CONTRACT.md, spec
sections 12 and 19), the printed summary, run folders complete or absent, and a run that is
refused before any work. Tiny runs (6 robots, 60 s, 2 runs) take seconds once the kernel is
compiled. (Ctrl-C in a lunar run: tests/test_interrupt.py, with the other scenarios.)"""

import errno
import math

import pyarrow.parquet as pq
import pytest

from dronefleet import cli, records, scenarios
from dronefleet.lunar import scenario as lunar

TINY = ["--set", "runs=2", "--set", "n_robots=50", "--set", "duration_s=60"]  # fewer robots make no trips in 60 s
SCENARIO = scenarios.SCENARIOS["lunar"]
ROWS = [f"row{r}" for r in range(1, 12)] + ["rowD"]
#: The columns of each table as the contract lists them, in order, with their arrow types.
COLUMNS = {
    "summary": [("run", "int64"), ("seed", "int64"), ("layout", "string"), ("battery_wh", "double"),
                *((name, "int64") for name in ("resources", "trips", "interruptions", "nest_recharges", "sessions",
                                               "deaths", "depletions", "beacons", "mobile", "units_beacons")),
                *((f"{kind}_{key}", "double") for kind in ("alignment", "alignment_w", "heading_alignment")
                  for key in "TNR"),
                *((name, "double") for name in ("deaths_per_session", "t_first_T", "t_first_R", "t_first_row5",
                                                "t_beacons_90")),
                *((row, "int64") for row in ROWS)],
    "timeseries": [("run", "int64"), ("t", "double"),
                   *((name, "int64") for name in ("resources", "trips", "interruptions", "nest_recharges",
                                                  "sessions")),
                   ("rate", "double"),
                   *((name, "int64") for name in ("n_mobile", "n_beacons", "n_dead", "n_unspawned", "n_f_out",
                                                  "n_f_in", "n_r")),
                   *((name, "double") for name in ("soc_sum", "soc_beacons", "soc_mobile", "soc_min_beacon")),
                   ("units_beacons", "int64"), *((f"alignment_{key}", "double") for key in "TNR")],
    "trips": [("run", "int64"), ("origin", "string"), ("dest", "string"), ("tick_left", "int64"),
              ("tick_entered", "int64"),
              *((name, "double") for name in ("length_m", "energy_j", "energy_wh", "soc_cost", "duration_s",
                                              "soft_length_m")),
              ("role_left", "string"), ("role_entered", "string"), ("robot", "int64")],
    "snapshots": [("run", "int64"), ("label", "string"), ("t", "double"), ("robot", "int64"), ("status", "string"),
                  ("role", "string"), ("mode", "string"), ("x", "double"), ("y", "double"), ("heading", "double"),
                  ("soc", "double"), ("load", "int64"),
                  *((f"{name}_{key}", "double") for name in ("omega", "vx", "vy", "S") for key in "TNR")],
    "robots": [("run", "int64"), ("robot", "int64"), ("trips", "int64"),
               *((name, "double") for name in ("distance_m", "energy_j", "energy_wh")),
               *((name, "int64") for name in ("recharges", "loads", "unloads")),
               *((f"time_{role}_s", "double") for role in ("f_out", "f_in", "r", "b")), ("died", "bool")],
    "deaths": [("run", "int64"), ("robot", "int64"), ("t", "double"), ("x", "double"), ("y", "double"),
               ("role", "string"), ("mode", "string"), ("region", "string")],
    "recharge_triggers": [("run", "int64"), ("robot", "int64"), ("t", "double"), ("role", "string"),
                          *((name, "double") for name in ("soc", "s_hat_dest", "s_hat_R", "x", "y", "dist_R_m"))],
    "beacon_costs": [("run", "int64"), ("label", "string"), ("t", "double"), ("near", "string"), ("beacons", "int64"),
                     ("S_R_mean", "double"), ("S_T_mean", "double")],
}


def run(capsys, *args):
    """``cli.main(["run", "lunar", *args])``: (exit code, stdout, stderr)."""
    code = cli.main(["run", "lunar", *map(str, args)])
    printed = capsys.readouterr()
    return code, printed.out, printed.err


@pytest.fixture(scope="module")
def tiny_run(tmp_path_factory):
    """A tiny run's folder and what it printed."""
    out = tmp_path_factory.mktemp("lunar") / "run"
    code = cli.main(["run", "lunar", *TINY, "--out", str(out)])
    assert code == 0
    return out


def test_the_table_schemas_are_the_contracts():
    schemas = SCENARIO.table_schemas()
    assert tuple(schemas) == SCENARIO.tables == tuple(COLUMNS)
    for table, columns in COLUMNS.items():
        assert [(f.name, str(f.type)) for f in schemas[table]] == columns, table


def test_a_run_writes_the_tables_with_the_contracts_columns(tiny_run):
    assert sorted(p.name for p in tiny_run.iterdir()) == sorted(f"{t}.parquet" for t in COLUMNS)
    config = SCENARIO.load(None, [s for s in TINY if s != "--set"])
    for table, columns in COLUMNS.items():
        written = pq.read_table(tiny_run / f"{table}.parquet")
        assert [(f.name, str(f.type)) for f in written.schema] == columns, table
        assert SCENARIO.read_config(tiny_run / f"{table}.parquet") == config
    summary = pq.read_table(tiny_run / "summary.parquet").to_pydict()
    assert summary["run"] == [0, 1] and set(summary["layout"]) == {"SOFT-RT"} and set(summary["battery_wh"]) == {10.0}
    assert all(count >= 0 for name in ("resources", "trips", "sessions", "deaths", "beacons") for count in summary[name])
    assert all(math.isnan(a) or -1.0 <= a <= 1.0 for key in "TNR" for a in summary[f"alignment_{key}"])
    timeseries = pq.read_table(tiny_run / "timeseries.parquet").to_pydict()
    assert set(timeseries["run"]) == {0, 1}
    per_run = [t for r, t in zip(timeseries["run"], timeseries["t"]) if r == 0]
    assert per_run == sorted(per_run) and max(per_run) <= 60.0
    snapshots = pq.read_table(tiny_run / "snapshots.parquet").to_pydict()
    assert "end" in snapshots["label"] and set(snapshots["run"]) == {0, 1}
    assert set(snapshots["status"]) <= {"unspawned", "alive", "dead"}
    assert set(snapshots["role"]) <= {"F_OUT", "F_IN", "R", "B"}
    trips = pq.read_table(tiny_run / "trips.parquet").to_pydict()
    assert set(trips["origin"]) | set(trips["dest"]) <= {"N", "T", "R"}


def test_a_run_prints_its_description_and_summary(tmp_path, capsys):
    code, out, err = run(capsys, *TINY, "--set", "layout=OPEN", "--out", tmp_path / "run")
    assert code == 0, err
    tables = {t: pq.read_table(tmp_path / "run" / f"{t}.parquet") for t in COLUMNS}
    config = SCENARIO.read_config(tmp_path / "run" / "summary.parquet")
    assert SCENARIO.describe(config) in out and SCENARIO.format_summary(tables) in out
    summary = SCENARIO.format_summary(tables)
    for line in ("over 2 runs", "resources returned", "trips", "recharging interruptions", "charging sessions",
                 "deaths", "beacons at the end", "alignment T", "alignment N", "alignment R"):
        assert line in summary, line
    assert "OPEN" in out and "nan" not in summary


def test_the_summary_counts_runs_without_an_alignment_rather_than_printing_nan(tiny_run):
    import pyarrow as pa

    tables = {t: pq.read_table(tiny_run / f"{t}.parquet") for t in COLUMNS}
    summary = tables["summary"]
    column = summary.schema.get_field_index("alignment_R")
    tables["summary"] = summary.set_column(column, "alignment_R", pa.array([math.nan, 0.5]))
    line = next(line for line in SCENARIO.format_summary(tables).splitlines() if "alignment R" in line)
    assert "0.500" in line and "(1 run without a value)" in line and "nan" not in line
    tables["summary"] = summary.set_column(column, "alignment_R", pa.array([math.nan, math.nan]))
    line = next(line for line in SCENARIO.format_summary(tables).splitlines() if "alignment R" in line)
    assert line.split()[3] == "-" and "(2 runs without a value)" in line  # "alignment R [cosine]  -"


def test_the_same_config_gives_the_same_tables(tiny_run, tmp_path):
    again = SCENARIO.simulate(SCENARIO.read_config(tiny_run / "summary.parquet"))
    for table in COLUMNS:
        assert pq.read_table(tiny_run / f"{table}.parquet").to_pandas().equals(again[table].to_pandas()), table


def test_the_default_folder_is_complete_and_a_second_run_is_refused(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    code, _, err = run(capsys, *TINY)
    assert code == 0, err
    (folder,) = (tmp_path / "results" / "runs").iterdir()
    assert folder.name.startswith("lunar-") and records.run_dir_state(folder, SCENARIO.tables) == "complete"
    before = {p.name: p.stat().st_mtime_ns for p in folder.iterdir()}
    monkeypatch.setattr(lunar, "simulate", _never)
    code, _, err = run(capsys, *TINY)
    assert code == 2 and "holds a complete run" in err and len(err.splitlines()) == 1, err
    assert {p.name: p.stat().st_mtime_ns for p in folder.iterdir()} == before


def _never(config):
    raise AssertionError("simulated although the run is refused")


def test_refusals_come_before_any_work(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(lunar, "simulate", _never)
    for setting in ("n_robots=0", "layout=MARS", "los_bodies=yes", "runs=700"):
        args = [*TINY, "--set", setting] if setting != "runs=700" else ["--set", "duration_s=86400", "--set", setting]
        code, out, err = run(capsys, *args, "--out", tmp_path / "out")
        assert code == 2 and len(err.splitlines()) == 1 and "Traceback" not in err, err
        assert err.startswith("dronefleet: error: ") and out == ""
    assert list(tmp_path.iterdir()) == []


def test_a_failed_write_leaves_no_run_folder(tmp_path, capsys, monkeypatch):
    real, done = pq.write_table, []

    def write(*args, **kwargs):  # the disk fills up at the third table
        if len(done) == 2:
            raise OSError(errno.ENOSPC, "No space left on device")
        done.append(args[1])
        return real(*args, **kwargs)

    monkeypatch.setattr(pq, "write_table", write)
    out = tmp_path / "run"
    code, _, err = run(capsys, *TINY, "--out", out)
    assert code == 2 and f"cannot write {str(out)!r}" in err and len(err.splitlines()) == 1, err
    assert list(tmp_path.iterdir()) == []


def test_the_python_api_runs_lunar_and_returns_its_tables(tmp_path):
    import dronefleet

    result = dronefleet.run("lunar", runs=2, n_robots=10, duration_s=60.0)
    assert result.config == SCENARIO.load(None, ["runs=2", "n_robots=10", "duration_s=60"])
    assert set(result.tables) == set(COLUMNS) and len(result.summary) == 2
    result.save(tmp_path / "api")
    assert SCENARIO.read_config(tmp_path / "api" / "summary.parquet") == result.config
