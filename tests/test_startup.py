"""What a run's process loads: no pandas, no scipy.linalg (their imports are most of a short
run's start-up), and tables built from numpy buffers equal to pyarrow's own conversion."""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pyarrow as pa
import pytest

from dronefleet.records import arrow_array, arrow_table
from dronefleet.supervisor import load_supervisor

CONFIGS = Path(__file__).resolve().parents[1] / "configs"

# Runs `dronefleet run ARGS` in a fresh interpreter and prints which heavy modules it loaded.
_PROBE = """
import json, sys
from dronefleet.cli import main
try:
    main(sys.argv[1:])
except SystemExit as end:
    assert end.code in (0, None), end.code
print(json.dumps(sorted(m for m in ("pandas", "scipy.linalg", "matplotlib", "sklearn") if m in sys.modules)))
"""


@pytest.mark.parametrize("args", [
    ["--set", "horizon_weeks=0.05", "--set", "n_uavs=5"],
    [str(CONFIGS / "replenishment.toml"), "--set", "trials=2", "--set", "ticks=300"],
], ids=["delivery", "replenishment"])
def test_a_run_loads_neither_pandas_nor_scipy_linalg(tmp_path, args):
    proc = subprocess.run([sys.executable, "-c", _PROBE, "run", *args, "--out", str(tmp_path / "run")],
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    assert json.loads(proc.stdout.splitlines()[-1]) == []
    assert (tmp_path / "run" / "summary.parquet").is_file()


def test_the_help_loads_no_numerical_library():
    probe = ("import sys\nfrom dronefleet.cli import main\ntry:\n    main(['--help'])\nexcept SystemExit:\n    pass\n"
             "print(sorted(m for m in ('numpy', 'numba', 'pandas', 'pyarrow') if m in sys.modules))")
    proc = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.splitlines()[-1] == "[]"


@pytest.mark.parametrize("values, null", [
    (np.array([1.5, np.nan, -0.0, np.inf]), None),                   # NaN stays a value
    (np.array([1.5, np.nan, -0.0, np.inf]), np.array([0, 1, 0, 0], bool)),
    (np.arange(5, dtype=np.int16), None),
    (np.arange(5, dtype=np.int32), np.array([1, 0, 0, 0, 1], bool)),
    (np.array([True, False, True] * 5), None),                         # more than one bitmap byte
    (np.array([True, False, True] * 5), np.arange(15) % 4 == 0),
    (np.array(["delivered", "aborted", "", "lost", "ü"]), None),
    (np.array(["a", "bb", "ccc"]), np.array([0, 1, 0], bool)),
    ([3], None), ([2.5], None), (["least_confident"], None), ([True], None),
    (np.arange(12, dtype=np.float64)[::3], None),                       # a strided view
], ids=lambda x: None)
def test_arrow_array_equals_pyarrows_conversion(values, null):
    expected = pa.array(values, mask=null) if null is not None else pa.array(values)
    found = arrow_array(values, null=null)
    assert found.type == expected.type
    assert found.null_count == expected.null_count
    assert found.to_pylist().__repr__() == expected.to_pylist().__repr__()  # repr: NaN and -0.0 exactly


def test_arrow_table_keeps_arrow_columns_and_sets_metadata():
    column = pa.array([[1], [2, 3]])
    table = arrow_table({"x": np.arange(2), "y": column}, {b"k": b"v"})
    assert table.column("y").chunk(0).equals(column)
    assert table.schema.metadata == {b"k": b"v"}
    assert table.column("x").type == pa.int64()


# The `dronefleet` script's end (dronefleet.__main__.script), with an atexit handler, an object that
# the interpreter's teardown would finalise, and optionally a (non-daemon) thread still working.
_SCRIPT_END = """
import atexit, sys, threading, time
from dronefleet.__main__ import script

class Held:
    def __del__(self):
        print("torn down", flush=True)

held = Held()
atexit.register(lambda: print("atexit handler ran", flush=True))
if sys.argv[1] == "thread":
    threading.Thread(target=lambda: (time.sleep(1.0), print("thread done", flush=True))).start()
sys.argv = ["dronefleet", *sys.argv[2:]]
script()
"""


def test_the_script_ends_without_the_teardown_but_after_atexit_and_with_its_output_and_code(tmp_path):
    missing = tmp_path / "absent.toml"
    done = subprocess.run([sys.executable, "-c", _SCRIPT_END, "-", "run", str(missing)],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 2 and done.stderr.count("\n") == 1 and str(missing) in done.stderr, done.stderr
    assert done.stdout == "atexit handler ran\n"  # and not "torn down": no teardown
    done = subprocess.run([sys.executable, "-c", _SCRIPT_END, "-", "configs"], capture_output=True, text=True,
                          timeout=120)
    lines = done.stdout.splitlines()
    assert done.returncode == 0 and lines[0].startswith("configs: ") and "paper" in done.stdout, done.stderr
    assert lines[-1] == "atexit handler ran" and "torn down" not in lines


def test_the_script_waits_for_a_thread_still_working_as_the_usual_exit_does():
    done = subprocess.run([sys.executable, "-c", _SCRIPT_END, "thread", "run", "absent.toml"], capture_output=True,
                          text=True, timeout=120)
    assert done.returncode == 2, done.stderr
    assert done.stdout.splitlines()[:2] == ["thread done", "atexit handler ran"]


def test_the_packaged_controller_is_read_once_per_process_not_once_per_run(monkeypatch):
    from dronefleet.delivery import simulation
    from dronefleet.delivery.config import default_config, replace

    reads = []
    monkeypatch.setattr(simulation, "load_supervisor", lambda path: reads.append(path) or load_supervisor(path))
    simulation._packaged_supervisor.cache_clear()
    config = replace(default_config(), horizon_weeks=0.01, n_uavs=3)
    for seed in (0, 1):
        simulation.initial_state(replace(config, seed=seed))
    assert reads == [simulation.BUILTIN_CONTROLLER]
