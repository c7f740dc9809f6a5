"""Ctrl-C at any moment of a command: "interrupted", exit code 130, nothing half-written, no traceback.

Real processes are sent SIGINT at chosen moments: while a compiled kernel runs (each scenario's,
a plugin rule's that never returns), while a plugin module is imported, in a sweep and in
``reproduce`` (whose workers get the terminal's Ctrl-C too). The moment is not a guess of the
clock: a kernel runs in a thread of its own (dronefleet.interrupt), so the tests wait until
threads other than the main one have used CPU time, in a run made far too long to end first.
"""

import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

import dronefleet

REPO = Path(dronefleet.__file__).resolve().parent.parent
CONFIGS = REPO / "configs"

pytestmark = pytest.mark.skipif(not Path("/proc/self/task").is_dir(), reason="reads threads' CPU time in /proc")

#: CPU time the kernel threads must have used before Ctrl-C [clock ticks, 1/100 s on Linux]: they run.
KERNEL_TICKS = 30

NEVER_RETURNS = '''
from numba import njit


@njit
def spin(f, w_norm, soc, theta, rng):
    x = 0.0
    while x >= 0.0:  # never ends
        x += 1.0
    return True, x


spin.bids_on = "any"
'''

HANGS_ON_IMPORT = '''
from pathlib import Path

Path(__file__).with_name("importing").write_text("")
while True:
    pass
'''


def _cpu(stat):
    """User + system CPU time [clock ticks] of a /proc stat file."""
    fields = Path(stat).read_text().rsplit(")", 1)[1].split()
    return int(fields[11]) + int(fields[12])


def _kernel_ticks(pid):
    """CPU time of the process ``pid``'s threads other than its main one, ended ones included [ticks]."""
    try:
        return _cpu(f"/proc/{pid}/stat") - _cpu(f"/proc/{pid}/task/{pid}/stat")
    except (FileNotFoundError, ProcessLookupError):
        return 0


def _children(pid):
    try:
        return [int(c) for c in Path(f"/proc/{pid}/task/{pid}/children").read_text().split()]
    except FileNotFoundError:
        return []


def _ended(pid):
    """Whether the process ``pid`` has ended (a zombie that init has yet to reap has)."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] in "ZX"
    except FileNotFoundError:
        return True


def _start(args, cwd, path=None, group=False, script=None):
    """``python -m dronefleet ARGS`` (or ``python -c SCRIPT ARGS``; ``path`` first on its module path)
    with Ctrl-C handled as in a terminal (a process started in the background of a non-interactive
    shell would ignore it)."""
    env = dict(os.environ)
    if path is not None:
        env["PYTHONPATH"] = os.pathsep.join(filter(None, (str(path), env.get("PYTHONPATH"))))
    return subprocess.Popen(
        [sys.executable, *(["-m", "dronefleet"] if script is None else ["-c", script]), *args], cwd=cwd, text=True,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE, env=env, start_new_session=group,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))


def _wait_until(process, ready, limit_s=600):
    """Poll ``ready()`` until true; fail if the process ends first (limit: a hang, not a measure)."""
    deadline = time.monotonic() + limit_s
    while not ready():
        if process.poll() is not None:
            pytest.fail(f"ended before the moment to interrupt it: rc {process.returncode}\n"
                        f"{process.communicate()[1]}")
        assert time.monotonic() < deadline, "the moment to interrupt never came"
        time.sleep(0.05)


#: The exit code each stopping signal ends a command with: as a shell reports a process it killed.
EXIT_CODES = {signal.SIGINT: 130, signal.SIGTERM: 143}


def _interrupted(process, group=False, signum=signal.SIGINT):
    """Send Ctrl-C, or ``signum`` (to the process group: as the terminal does, and SLURM at a job's
    time limit); its stderr lines once it ended."""
    if group:
        os.killpg(process.pid, signum)
    else:
        process.send_signal(signum)
    _, err = process.communicate(timeout=60)  # a hang, not a measure
    assert process.returncode == EXIT_CODES[signum], err
    assert "Traceback" not in err and "Error" not in err, err
    return err.splitlines()


def _leftovers(folder):
    """Hidden temporary files and folders under ``folder`` (an interrupted write's)."""
    return [p for p in Path(folder).rglob(".*") if p.name.endswith((".tmp", ".old"))]


RUN_ARGS = ["run", str(CONFIGS / "replenishment.toml"), "--set", "trials=2000"]


@pytest.mark.parametrize("args", [
    pytest.param(RUN_ARGS, id="replenishment"),
    pytest.param(["run", "--set", "horizon_weeks=90", "--set", "n_uavs=100"], id="delivery"),
    pytest.param(["run", str(CONFIGS / "items.toml"), "--set", "trials=70000"], id="items"),
    pytest.param(["run", str(CONFIGS / "lunar.toml"), "--set", "runs=140"], id="lunar"),  # minutes of work
])
def test_ctrl_c_in_a_compiled_kernel_is_a_clean_interruption(args, tmp_path):
    process = _start([*args, "--out", str(tmp_path / "out")], tmp_path)
    _wait_until(process, lambda: _kernel_ticks(process.pid) >= KERNEL_TICKS)
    assert _interrupted(process) == ["dronefleet: interrupted"]
    assert sorted(os.listdir(tmp_path)) == []


def test_sigterm_in_a_compiled_kernel_stops_the_run_as_ctrl_c_does(tmp_path):
    process = _start([*RUN_ARGS, "--out", str(tmp_path / "out")], tmp_path)
    _wait_until(process, lambda: _kernel_ticks(process.pid) >= KERNEL_TICKS)
    assert _interrupted(process, signum=signal.SIGTERM) == ["dronefleet: interrupted by SIGTERM"]
    assert sorted(os.listdir(tmp_path)) == []


def test_a_plugin_rule_that_never_returns_is_named_and_left_behind(tmp_path):
    (tmp_path / "spinning.py").write_text(NEVER_RETURNS)
    process = _start(["run", "--set", "rule=spinning:spin", "--set", "horizon_weeks=1", "--out",
                      str(tmp_path / "out")], tmp_path, path=tmp_path)
    _wait_until(process, lambda: _kernel_ticks(process.pid) >= KERNEL_TICKS)
    lines = _interrupted(process)
    assert len(lines) == 1 and lines[0].startswith("dronefleet: interrupted but the winner rule 'spinning:spin' "
                                                   "did not stop within"), lines
    assert not (tmp_path / "out").exists()


SPINNING_SWEEP = """
[sweep]
name = "spinning"
seeds = [0, 1]
[set]
horizon_weeks = 1
[grid]
rule = ["spinning:spin"]
"""


def test_sigterm_ends_a_sweep_whose_winner_rule_never_returns(tmp_path):
    # as `timeout` ends a command: SIGTERM to it alone, its worker (the rule's run) is stopped by it
    (tmp_path / "spinning.py").write_text(NEVER_RETURNS)
    (tmp_path / "spinning.toml").write_text(SPINNING_SWEEP)
    results = tmp_path / "results"
    process = _start(["sweep", "run", "spinning.toml", "--results", str(results), "--jobs", "2"], tmp_path,
                     path=tmp_path, group=True)
    _wait_until(process, lambda: any(_kernel_ticks(child) >= KERNEL_TICKS for child in _children(process.pid)))
    workers = _children(process.pid)
    assert any("interrupted" in line for line in _interrupted(process, signum=signal.SIGTERM))
    deadline = time.monotonic() + 60  # a hang, not a measure
    while not all(map(_ended, workers)):
        assert time.monotonic() < deadline, "a worker outlives the sweep"
        time.sleep(0.05)
    assert not list(results.rglob("part-0.parquet")) and _leftovers(results) == []


def test_ctrl_c_while_a_plugin_module_hangs_on_import_names_it(tmp_path):
    (tmp_path / "hanging.py").write_text(HANGS_ON_IMPORT)
    process = _start(["run", "--set", "rule=hanging:rule", "--out", str(tmp_path / "out")], tmp_path,
                     path=tmp_path)
    _wait_until(process, (tmp_path / "importing").exists)
    assert _interrupted(process) == [
        "dronefleet: interrupted while importing module 'hanging' of winner rule 'hanging:rule'"]
    assert not (tmp_path / "out").exists()


SWEEP = """
[sweep]
name = "long"
scenario = "replenishment"
[set]
trials = 1
sample_every = 1000
[grid]
ticks = [60, 50000000]
"""


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM], ids=["ctrl-c", "sigterm"])
@pytest.mark.parametrize("group", [True, False], ids=["every-process", "parent-only"])
def test_ctrl_c_of_a_sweep_keeps_the_runs_done_and_stops_its_workers(group, signum, tmp_path):
    # The first run (60 ticks) runs in a worker alone, the second (years of ticks) in a worker
    # after it, which the terminal's Ctrl-C reaches too, but a `kill -INT` of the command does not.
    (tmp_path / "long.toml").write_text(SWEEP)
    results = tmp_path / "results"
    process = _start(["sweep", "run", "long.toml", "--results", str(results), "--jobs", "2"], tmp_path, group=True)
    _wait_until(process, lambda: any(_kernel_ticks(child) >= KERNEL_TICKS for child in _children(process.pid)))
    lines = _interrupted(process, group=group, signum=signum)
    assert any("interrupted" in line for line in lines), lines
    summaries = sorted(p.relative_to(results / "long") for p in results.rglob("summary/**/*.parquet"))
    assert [p.parts[1] for p in summaries] == ["ticks=60"], summaries
    assert not (results / "long" / "_failed").exists()
    assert _leftovers(results) == []


#: ``dronefleet`` whose replenishment --quick figures run far too long to end before the Ctrl-C.
LONG_QUICK = '''
import sys
from dronefleet.replenishment import study
study.QUICK_TICKS = 10**7
from dronefleet.__main__ import main
sys.exit(main())
'''


def test_ctrl_c_of_reproduce_in_a_kernel_is_a_clean_interruption(tmp_path):
    process = _start(["reproduce", "fig09", "--quick", "--jobs", "1", "--out", str(tmp_path / "results")], tmp_path,
                     script=LONG_QUICK)
    _wait_until(process, lambda: _kernel_ticks(process.pid) >= KERNEL_TICKS)
    assert _interrupted(process) == ["dronefleet: interrupted"]
    assert _leftovers(tmp_path) == []
    assert not (tmp_path / "results" / "quick" / "fig09").exists()  # the figure comes after its runs


LOADING = '''
import builtins, os, signal, sys
real_import = builtins.__import__

def import_then_ctrl_c(name, *args, **kwargs):
    if name == "cli":  # dronefleet.__main__ loads the command's modules
        os.kill(os.getpid(), signal.SIGINT)
    return real_import(name, *args, **kwargs)

builtins.__import__ = import_then_ctrl_c
from dronefleet.__main__ import main
sys.exit(main())
'''


def test_ctrl_c_while_the_command_loads_its_modules_is_interrupted(tmp_path):
    # the console script and python -m both enter through dronefleet.__main__.main
    done = subprocess.run([sys.executable, "-c", LOADING, "run", "--out", str(tmp_path / "out")],
                          capture_output=True, text=True, cwd=tmp_path, timeout=120)
    assert (done.returncode, done.stderr) == (130, "dronefleet: interrupted\n")
    assert not (tmp_path / "out").exists()


ENDED = '''
import os, signal, sys
import dronefleet.__main__
sys.argv = ["dronefleet", "run", "absent.toml"]  # refused: returns 2 at once
code = dronefleet.__main__.main()
os.kill(os.getpid(), signal.SIGINT)  # a Ctrl-C as the interpreter exits, its work done
print("exiting", flush=True)
sys.exit(code)
'''


def test_ctrl_c_once_the_command_has_ended_does_not_undo_its_exit_code(tmp_path):
    done = subprocess.run([sys.executable, "-c", ENDED], capture_output=True, text=True, cwd=tmp_path, timeout=120)
    assert done.returncode == 2 and done.stderr.count("\n") == 1 and "absent.toml" in done.stderr, done.stderr
    assert done.stdout == "exiting\n"


WORKER_STARTING = '''
import os, signal, sys
import loky.backend.fork_exec as spawning
spawn = spawning.fork_exec

def ctrl_c_as_the_worker_starts(*args, **kwargs):
    spawning.fork_exec = spawn  # the first worker only
    pid = spawn(*args, **kwargs)
    # once the worker's interpreter handles SIGINT (it does before it imports its site and modules)
    while not int(next(line for line in open(f"/proc/{pid}/status") if line.startswith("SigCgt:")).split()[1],
                  16) & 1 << (signal.SIGINT - 1):
        pass
    os.killpg(0, signal.SIGINT)  # the terminal's Ctrl-C: to every process of the group
    return pid

spawning.fork_exec = ctrl_c_as_the_worker_starts
from dronefleet.__main__ import main
sys.exit(main())
'''


def test_ctrl_c_while_a_worker_of_reproduce_starts_is_no_message_of_the_worker(tmp_path):
    # A worker starts with Ctrl-C blocked until its initializer ignores it; the worker's start
    # also starts multiprocessing's resource tracker, which unblocked it again (the worker then
    # died in its start-up, printing "Fatal Python error: init_import_site" or a traceback).
    for figure in ("items-fig01", "items-fig02"):  # the first drawn here, the second in a worker
        shutil.copytree(REPO / "results" / figure, tmp_path / "tables" / figure)
    process = _start(["reproduce", "items-fig01", "items-fig02", "--redraw", "--jobs", "2", "--out",
                      str(tmp_path / "tables")], tmp_path, group=True, script=WORKER_STARTING)
    _, err = process.communicate(timeout=300)  # a hang, not a measure
    assert process.returncode == 130, err
    assert err.splitlines() == ["dronefleet: interrupted"], err
