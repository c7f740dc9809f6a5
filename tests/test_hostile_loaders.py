"""Hostile inputs to the loaders, through the real command line: each is refused in one line.

One row per hostile input (issue 10: config files, parameters that drive memory or time,
fleet files, supervisor files). Every row runs ``dronefleet run`` in-process with the
input prepared in ``tmp_path`` and requires: exit code 2, ONE stderr line
``dronefleet: error: ...`` holding the expected fragment (the value and what is allowed),
no traceback, the ``--out`` folder absent, and an end within a generous time guard (a
hang or a long run would exceed it; this is not a speed test). A few rows also run in a
subprocess, to see the real exit code and stderr.
"""

import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

import dronefleet
from dronefleet import cli, scenarios
from dronefleet.delivery import simulation
from dronefleet.delivery.config import RUN_LIMITS, default_config, load_config, replace, run_size
from dronefleet.delivery.fleet import COLUMNS, load_fleet
from dronefleet.records import write_table
from dronefleet.supervisor import (BUILTIN_CONTROLLER, MAX_DEPTH, MAX_FILE_BYTES, SupervisorFileError,
                                   load_supervisor)

N_UAVS = 3
REPO = Path(dronefleet.__file__).resolve().parent.parent


# --------------------------------------------------------------------------- inputs


def fleet_columns(n=N_UAVS):
    """The columns of a valid saved fleet of ``n`` UAVs at t = 1 week, as Python lists."""
    return {
        "t_s": [604800.0] * n, "uav": list(range(n)), "soh": [0.9] * n,
        "w_distance": [-1.0] * n, "w_mass": [-0.5] * n, "w_soc": [2.0] * n, "intercept": [0.1] * n,
        "steps": [15.0] * n, "soc": [80.0] * n, "lost": [False] * n, "period": [1] * n,
    }


def write_fleet(path, columns=None, config=None, types=None):
    """A fleet file of ``columns`` (default: valid) with ``config`` (default: N_UAVS UAVs) in its metadata."""
    columns = fleet_columns() if columns is None else columns
    types = {"uav": pa.int16(), "period": pa.int16(), **(types or {})}
    table = pa.table({name: pa.array(values, type=types.get(name)) for name, values in columns.items()})
    write_table(table, path, config or replace(default_config(), n_uavs=N_UAVS))
    return path


def fleet_with(column, value, uav=1):
    """A fleet file whose ``column`` holds ``value`` for UAV ``uav``."""
    def make(tmp_path):
        columns = fleet_columns()
        columns[column][uav] = value
        return write_fleet(tmp_path / "fleet.parquet", columns)
    return make


def fleet_file(make):
    """argv of a run from the fleet file that ``make(tmp_path)`` writes."""
    return lambda tmp_path: ["--set", f"n_uavs={N_UAVS}", "--fleet", str(make(tmp_path))]


def config_file(data):
    """argv of a run of a config file holding the bytes ``data``."""
    def argv(tmp_path):
        path = tmp_path / "run.toml"
        path.write_bytes(data)
        return [str(path)]
    return argv


def unreadable_config(tmp_path):
    path = tmp_path / "secret.toml"
    path.write_text("[orders]\ntau_minutes = 20.0\n")
    path.chmod(0)
    return [str(path)]


def fleet_parquet_without_metadata(tmp_path):
    path = tmp_path / "plain.parquet"
    pq.write_table(pa.table(fleet_columns()), path)
    return path


def fleet_with_metadata(config_text):
    def make(tmp_path):
        path = tmp_path / "fleet.parquet"
        pq.write_table(pa.table(fleet_columns()).replace_schema_metadata({"dronefleet.config": config_text}), path)
        return path
    return make


def truncated_fleet(tmp_path):
    whole = write_fleet(tmp_path / "whole.parquet").read_bytes()
    path = tmp_path / "truncated.parquet"
    path.write_bytes(whole[: len(whole) // 2])
    return path


def fleet_columns_without(name):
    def make(tmp_path):
        columns = fleet_columns()
        del columns[name]
        return write_fleet(tmp_path / "fleet.parquet", columns)
    return make


def fleet_of_other_size(tmp_path):
    return write_fleet(tmp_path / "fleet.parquet", fleet_columns(5), replace(default_config(), n_uavs=5))


def fleet_missing_a_uav(tmp_path):
    columns = {name: values[:2] for name, values in fleet_columns().items()}
    return write_fleet(tmp_path / "fleet.parquet", columns)


def fleet_with_text_soh(tmp_path):
    columns = fleet_columns()
    columns["soh"] = [str(v) for v in columns["soh"]]
    return write_fleet(tmp_path / "fleet.parquet", columns)


def fleet_with_float_uav(tmp_path):
    return write_fleet(tmp_path / "fleet.parquet", types={"uav": pa.float64()})


def empty_fleet(tmp_path):
    return write_fleet(tmp_path / "fleet.parquet", {name: [] for name in COLUMNS},
                       types={name: pa.float64() for name in ("t_s", "soh", "w_distance", "w_mass", "w_soc",
                                                              "intercept", "steps", "soc")} | {"lost": pa.bool_()})


def fleet_with_period(period):
    def make(tmp_path):
        columns = fleet_columns()
        columns["period"] = [period] * N_UAVS
        return write_fleet(tmp_path / "fleet.parquet", columns)
    return make


def text_file(name, text):
    def make(tmp_path):
        path = tmp_path / name
        path.write_text(text)
        return path
    return make


def a_directory(tmp_path):
    (tmp_path / "folder.parquet").mkdir()
    return tmp_path / "folder.parquet"


def run_set(*overrides):
    return lambda tmp_path: [arg for o in overrides for arg in ("--set", o)]


NAN, INF = math.nan, math.inf
HOSTILE = [
    # ---- parameters that drive memory or time
    ("tau 1e-9 min", run_set("tau_minutes=1e-9"),
     "the run would hold ~8.06e+13 orders (horizon 8 weeks / tau 1e-09 min); at most 1e+07 allowed"),
    ("record interval 1e-6 s", run_set("record_interval_s=1e-6"),
     "~4.84e+12 time-series samples (horizon 8 weeks / record_interval_s 1e-06 s); at most 1e+07 allowed"),
    ("horizon 1e6 weeks", run_set("horizon_weeks=1e6"),
     "run.horizon_weeks = 1000000.0 is out of range: allowed (0, 1000]"),
    ("initial epochs 1e6 (integer)", run_set("initial_epochs=1000000"),
     "~2.5e+07 initial-fit draws (n_uavs 25 x initial_epochs 1000000); at most 1e+07 allowed"),
    ("initial epochs 1e8 (integer)", run_set("initial_epochs=100000000"),
     "policy.initial_epochs = 100000000 is out of range: allowed [1, 10000000]"),
    ("initial epochs 1e8 (float)", run_set("initial_epochs=1e8"),
     "policy.initial_epochs must be an integer, got float 100000000.0 (write 100000000)"),
    ("1e9 UAVs", run_set("n_uavs=1000000000"), "fleet.n_uavs = 1000000000 is out of range: allowed [1, 32767]"),
    ("charger 1e-300 W", run_set("charger_power_w=1e-300"),
     "energy.charger_power_w = 1e-300 is out of range: allowed [1, 1e+06]"),
    ("vanishing rotors (an infinite flight power)", run_set("rotor_area_m2=1e-300", "air_density_kg_m3=1e-300"),
     "energy.rotor_area_m2 = 1e-300 is out of range: allowed [0.0001, 10000]"),
    ("charger efficiency 1e-300 (a hang)", run_set("charger_efficiency=1e-300"),
     "energy.charger_efficiency = 1e-300 is out of range: allowed [0.01, 1]"),
    ("threshold 0, advert 1e-6 s", run_set("rule=threshold", "theta=0", "advert_interval_s=1e-6"),
     "auction.advert_interval_s = 1e-06 is out of range: allowed [0.001, 6.048e+08]"),
    ("threshold 0, advert 1 ms", run_set("rule=threshold", "theta=0", "advert_interval_s=0.001"),
     "~4.84e+09 advertisement ticks (horizon 8 weeks / advert_interval_s 0.001 s); at most 3e+07 allowed"),
    ("alpha 1e300 (a ZeroDivisionError)", run_set("alpha=1e300"), "policy.alpha = 1e+300 is out of range: allowed (0, 100]"),
    ("scaler std 1e-300 (an engine stop)", run_set("scaler_std=[1e-300, 1, 1]"),
     "policy.scaler_std[0] = 1e-300 is out of range: allowed [1e-06, 1e+09]"),
    ("frame mass 1e300 (power overflows)", run_set("frame_mass_kg=1e300"),
     "energy.frame_mass_kg = 1e+300 is out of range: allowed [0, 10000]"),
    ("seed 2**63", lambda tmp_path: ["--seed", str(2**63)],
     "run.seed = 9223372036854775808 is out of range: allowed [0, 9223372036854775807]"),
    ("seed 2**63 by --set", run_set(f"seed={2**63}"), "run.seed = 9223372036854775808 is out of range"),
    ("float beyond any double", run_set("tau_minutes=" + "9" * 400), "orders.tau_minutes = 99999"),
    # ---- config files
    ("config in Latin-1", config_file("[orders]\n# café\ntau_minutes = 20.0\n".encode("latin-1")),
     "is not UTF-8 text (byte 0xe9 at offset 14); save it as UTF-8"),
    ("config is binary garbage", config_file(bytes(range(256)) * 4), "is not UTF-8 text (byte 0x80"),
    ("config is UTF-8 garbage", config_file(b"\x00\x01\x02\x03 = = ]]"), "cannot parse config file"),
    ("config larger than 1 MB", config_file(b"# padding\n" * 100_001), "is larger than 1000000 bytes"),
    ("config nested too deeply", config_file(b"[run]\nx = " + b"[" * 100_000), "cannot parse config file"),
    ("config integer of 5000 digits", config_file(b"[fleet]\nn_uavs = " + b"9" * 5000), "cannot parse config file"),
    ("config is a directory", lambda tmp_path: [str(tmp_path)], "is not a regular file (a folder, pipe or device)"),
    ("config missing", lambda tmp_path: [str(tmp_path / "missing.toml")],
     "cannot read config file", ),
    ("config huge list", config_file(b"[policy]\nscaler_mean = [" + b"1.0, " * 100_000 + b"]"),
     "policy.scaler_mean must be a list of 3 numbers, got a list of length 100000"),
    # ---- fleet files
    ("fleet SoH nan", fleet_file(fleet_with("soh", NAN)), "column soh of UAV 1 is nan; allowed: (0, 1]"),
    ("fleet SoH 0", fleet_file(fleet_with("soh", 0.0)), "column soh of UAV 1 is 0; allowed: (0, 1]"),
    ("fleet SoH 1.5", fleet_file(fleet_with("soh", 1.5)), "column soh of UAV 1 is 1.5; allowed: (0, 1]"),
    ("fleet SoC 200", fleet_file(fleet_with("soc", 200.0)), "column soc of UAV 1 is 200; allowed: [0, 100]"),
    ("fleet SoC null, not lost", fleet_file(fleet_with("soc", None)),
     "column soc of UAV 1 is null; allowed: [0, 100] (null only for a lost UAV)"),
    ("fleet steps nan", fleet_file(fleet_with("steps", NAN)), "column steps of UAV 1 is nan; allowed: an integral"),
    ("fleet steps -1", fleet_file(fleet_with("steps", -1.0)), "column steps of UAV 1 is -1; allowed: an integral"),
    ("fleet steps 2.5", fleet_file(fleet_with("steps", 2.5)), "column steps of UAV 1 is 2.5"),
    ("fleet weight inf", fleet_file(fleet_with("w_mass", INF)), "column w_mass of UAV 1 is inf; allowed: finite"),
    ("fleet weight 1e300", fleet_file(fleet_with("w_soc", 1e300)), "column w_soc of UAV 1 is 1e+300"),
    ("fleet intercept -inf", fleet_file(fleet_with("intercept", -INF)), "column intercept of UAV 1 is -inf"),
    ("fleet lost null", fleet_file(fleet_with("lost", None)), "column lost is null for UAV 1"),
    ("fleet t_s nan", fleet_file(fleet_with("t_s", NAN)), "column t_s must hold finite times >= 0"),
    ("fleet period 0", fleet_file(fleet_with_period(0)), "column period at the last instant is [0]"),
    ("fleet period 32767", fleet_file(fleet_with_period(32767)), "allowed: one integer in [1, 32766]"),
    ("fleet SoH as text", fleet_file(fleet_with_text_soh), "column soh has type string; allowed: numbers"),
    ("fleet uav as float", fleet_file(fleet_with_float_uav), "column uav has type double; allowed: integers"),
    ("fleet without soc", fleet_file(fleet_columns_without("soc")), "lacks the fleet column(s) soc"),
    ("fleet empty", fleet_file(empty_fleet), "column t_s must hold finite times >= 0"),
    ("fleet of 2 UAVs for 3", fleet_file(fleet_missing_a_uav),
     "does not hold UAVs 0..2 once each at its last instant"),
    ("fleet of another fleet size", fleet_file(fleet_of_other_size), "was saved with n_uavs = 5, but this run has"),
    ("fleet without metadata", fleet_file(fleet_parquet_without_metadata),
     "is not a dronefleet fleet file: its metadata holds no dronefleet config"),
    ("fleet metadata not JSON", fleet_file(fleet_with_metadata("{not json")), "its metadata holds no dronefleet"),
    ("fleet metadata nested deeply", fleet_file(fleet_with_metadata("[" * 100_000)), "its metadata holds no"),
    ("fleet metadata config invalid", fleet_file(fleet_with_metadata('{"fleet": {"n_uavs": 0}}')),
     "holds a config that is not valid now (fleet.n_uavs = 0 is out of range: allowed [1, 32767])"),
    ("fleet truncated", fleet_file(truncated_fleet), "is not a readable parquet file"),
    ("fleet is text", fleet_file(text_file("fleet.parquet", "soh,soc\n1,2\n")), "is not a readable parquet file"),
    ("fleet is a directory", fleet_file(a_directory), "is not a file"),
    ("fleet missing", lambda tmp_path: ["--fleet", str(tmp_path / "none-{seed}.parquet")],
     "no such file"),
]
if hasattr(os, "geteuid") and os.geteuid() != 0:  # root reads any file
    HOSTILE.append(("config unreadable", unreadable_config, "Permission denied"))


def run_cli(argv, capsys):
    code = cli.main(["run", *argv])
    return code, capsys.readouterr()


@pytest.mark.parametrize("name, argv, fragment", HOSTILE, ids=[row[0] for row in HOSTILE])
def test_hostile_input_is_refused_in_one_line(name, argv, fragment, tmp_path, capsys, monkeypatch):
    # Refused before any work: the simulation is never started.
    monkeypatch.setattr(simulation, "simulate", lambda *a, **k: pytest.fail("the run was simulated"))
    out = tmp_path / "out"
    code, captured = run_cli([*argv(tmp_path), "--out", str(out)], capsys)
    assert code == 2
    lines = captured.err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("dronefleet: error: "), captured.err
    assert fragment in lines[0]
    assert len(lines[0]) < 600  # no value printed whole
    assert not out.exists()


SUBPROCESS_ROWS = ["tau 1e-9 min", "seed 2**63", "config in Latin-1", "fleet SoH nan", "threshold 0, advert 1 ms"]


@pytest.mark.parametrize("name", SUBPROCESS_ROWS)
def test_hostile_input_in_a_process_exits_2_with_one_line(name, tmp_path):
    _, argv, fragment = next(row for row in HOSTILE if row[0] == name)
    out = tmp_path / "out"
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    done = subprocess.run([sys.executable, "-m", "dronefleet.cli", "run", *argv(tmp_path), "--out", str(out)],
                          capture_output=True, text=True, env=env, cwd=tmp_path, timeout=120)
    assert done.returncode == 2
    assert done.stderr.count("\n") == 1 and done.stderr.startswith("dronefleet: error: "), done.stderr
    assert fragment in done.stderr and "Traceback" not in done.stderr
    assert done.stdout == ""
    assert not out.exists()


# --------------------------------------------------------------------------- what stays allowed


def test_the_refusals_leave_the_paper_and_a_10000_uav_fleet_allowed():
    for path in sorted((REPO / "configs").glob("*.toml")):
        scenarios.load(path)  # each through its scenario's loader
    big = load_config(overrides=["n_uavs=10000", f"tau_minutes={15 * 25 / 10000}"])
    assert all(size <= RUN_LIMITS[name] for name, size in run_size(big).items())
    load_config(seed=2**63 - 1)


def test_a_valid_fleet_file_loads_as_written(tmp_path):
    columns = fleet_columns()
    columns["lost"][2], columns["soc"][2] = True, None  # a lost UAV has no SoC
    fleet = load_fleet(write_fleet(tmp_path / "fleet.parquet", columns), replace(default_config(), n_uavs=N_UAVS))
    np.testing.assert_array_equal(fleet.soh, [0.9] * 3)
    np.testing.assert_array_equal(fleet.coef, [[-1.0, -0.5, 2.0]] * 3)
    np.testing.assert_array_equal(fleet.steps, [15.0] * 3)
    np.testing.assert_array_equal(fleet.lost, [False, False, True])
    assert fleet.soc[:2].tolist() == [80.0, 80.0] and math.isnan(fleet.soc[2]) and fleet.period == 1


# --------------------------------------------------------------------------- supervisor files


BOMB = "\n".join(["a: &a [x, x, x, x, x, x, x, x, x]"]
                 + [f"{c}: &{c} [{', '.join([f'*{p}'] * 9)}]" for p, c in zip("abcdefgh", "bcdefghi")]
                 + ["num_events: *i", ""])

HOSTILE_SUPERVISORS = [
    ("alias bomb", BOMB.encode(), "uses a YAML alias at line 2"),
    ("latin-1", "num_events: 1 # café\n".encode("latin-1"), "is not UTF-8 text (byte 0xe9 at offset 19)"),
    ("empty", b"", "is empty"),
    ("blank", b"  \n\n", "is empty"),
    ("larger than the cap", b"# x\n" * (MAX_FILE_BYTES // 4 + 1), f"is larger than {MAX_FILE_BYTES} bytes"),
    # Nesting past our cap but within libyaml's own (1,000 flow levels in PyYAML >= 6.0.4): our words.
    ("deep nesting", b"[" * (MAX_DEPTH + 1) + b"]" * (MAX_DEPTH + 1), f"nests lists or mappings more than {MAX_DEPTH}"),
    # Nesting that libyaml itself may refuse first: refused in one line, in whoever's words.
    ("very deep nesting", b"[" * 100_000 + b"]" * 100_000, ""),
    ("integer of 5000 digits", b"num_events: " + b"9" * 5000, "not valid YAML"),
    ("not YAML", b"a: [1, 2\nb: }", "not valid YAML"),
    ("a list", b"[1, 2, 3]", "should be a mapping"),
    ("huge value in a message", b"num_events: 1\nnum_supervisors: 1\nevents: [" + b"EV_a, " * 30_000 + b"]\n"
     + b"ev_controllable: [1]\nsup_events: [[1]]\nsup_init_state: [0]\nsup_current_state: [0]\n"
     + b"sup_data_pos: [0]\nsup_data: [0]\n", "events has 30000 entries but num_events is 1"),
    ("huge list shown cut", b"num_events: [" + b"1, " * 50_000 + b"]\nnum_supervisors: 1\nevents: []\n"
     + b"ev_controllable: []\nsup_events: []\nsup_init_state: []\nsup_current_state: []\n"
     + b"sup_data_pos: []\nsup_data: []\n", "num_events should be a positive integer, found [1, 1,"),
]


@pytest.mark.parametrize("name, data, fragment", HOSTILE_SUPERVISORS, ids=[r[0] for r in HOSTILE_SUPERVISORS])
def test_hostile_supervisor_file_is_refused_in_one_line(name, data, fragment, tmp_path):
    path = tmp_path / "controller.yaml"
    path.write_bytes(data)
    with pytest.raises(SupervisorFileError) as error:
        load_supervisor(path)
    message = str(error.value)
    assert fragment in message and "\n" not in message and len(message) < 600, message
    assert message.startswith(str(path))


def _fifo(folder):
    os.mkfifo(folder / "pipe.yaml")
    return folder / "pipe.yaml"


@pytest.mark.parametrize("make", [lambda p: p, lambda p: p / "missing.yaml", _fifo], ids=["directory", "missing", "fifo"])
def test_supervisor_path_that_is_no_file_is_refused(make, tmp_path):
    with pytest.raises(SupervisorFileError, match="cannot read the supervisor file"):
        load_supervisor(make(tmp_path))


def test_the_packaged_controller_still_loads():
    automaton = load_supervisor(BUILTIN_CONTROLLER)
    assert automaton.n_events == 9 and automaton.n_supervisors >= 1


def test_a_bad_supervisor_file_reaches_the_command_line_as_one_line(tmp_path, capsys, monkeypatch):
    # No command-line option names a supervisor file yet; the run's loader is pointed at a bomb.
    bomb = tmp_path / "bomb.yaml"
    bomb.write_text(BOMB)
    monkeypatch.setattr(simulation, "BUILTIN_CONTROLLER", bomb)
    out = tmp_path / "out"
    code, captured = run_cli(["--set", "horizon_weeks=0.01", "--out", str(out)], capsys)
    assert code == 2 and not out.exists()
    assert captured.err.splitlines() == [f"dronefleet: error: {bomb}: uses a YAML alias at line 2, column 8; "
                                         "aliases are not allowed (Nadzoru 2 writes none)"]
