"""Hostile input to `dronefleet sweep run` and what a sweep must survive.

Every hostile job-array variable, flag and sweep file ends with exit code 2 and a one-line
message naming the value and what is allowed, before any run: nothing is written. A
failure record that cannot be written does not stop the sweep; grid keys in another order
give the same sweep and one partition layout; workers and the resource trackers end when
the sweep's process is killed.
"""

import json
import os
import shlex
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from conftest import Counted

from dronefleet import cli, executors, sweeps as sw
from dronefleet.delivery import simulation
from dronefleet.outputs import PROBE_PREFIX

ROOT = Path(__file__).resolve().parents[1]
SMOKE = ROOT / "configs" / "sweeps" / "smoke.toml"   # 8 runs, 3 tasks of up to 3 runs


def run_cli(args):
    """cli.main's exit code, argparse's included (it exits with 2 on a bad flag)."""
    try:
        return cli.main(args)
    except SystemExit as stop:
        return stop.code


@pytest.fixture
def no_array(monkeypatch):
    """No scheduler variable from the environment the tests run in (a SLURM job, say)."""
    for name, _ in sw.TASK_VARIABLES:
        monkeypatch.delenv(name, raising=False)


def refused(capsys, args, fragment, results):
    """Exit 2, the message on one line (argparse's usage lines aside) with ``fragment``, nothing written."""
    assert run_cli(args) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err
    message = [line for line in err.splitlines() if "error:" in line]
    assert len(message) == 1 and fragment in message[0], err
    assert not any(results.iterdir()), list(results.iterdir())


@pytest.mark.parametrize("variable, value, fragment", [
    ("SLURM_ARRAY_TASK_ID", "abc", "SLURM_ARRAY_TASK_ID='abc' is not a job-array task of this sweep: "
                                   "expected an integer 0-2 (3 tasks)"),
    ("SLURM_ARRAY_TASK_ID", "-1", "SLURM_ARRAY_TASK_ID='-1'"),
    ("SLURM_ARRAY_TASK_ID", "²", "SLURM_ARRAY_TASK_ID='²'"),          # str.isdigit() takes it, int() does not
    ("SLURM_ARRAY_TASK_ID", "١", "expected an integer 0-2"),          # an Arabic-Indic one: int() takes it
    ("SLURM_ARRAY_TASK_ID", "3", "SLURM_ARRAY_TASK_ID='3'"),           # one beyond the array
    ("SLURM_ARRAY_TASK_ID", " 1", "SLURM_ARRAY_TASK_ID=' 1'"),
    ("SLURM_ARRAY_TASK_ID", "1.0", "expected an integer 0-2"),
    ("SLURM_ARRAY_TASK_ID", "9" * 5000, "(5000 characters)"),          # never printed whole
    ("PBS_ARRAY_INDEX", "x", "PBS_ARRAY_INDEX='x'"),
    ("PBS_ARRAY_INDEX", "3", "expected an integer 0-2"),
    ("SGE_TASK_ID", "0", "SGE_TASK_ID='0' is not a job-array task of this sweep: expected an integer 1-3"),
    ("SGE_TASK_ID", "4", "expected an integer 1-3"),
    ("SGE_TASK_ID", "Undefined", "SGE_TASK_ID='Undefined'"),
    ("LSB_JOBINDEX", "-2", "LSB_JOBINDEX='-2'"),
    ("LSB_JOBINDEX", "4", "expected an integer 1-3"),
    ("SLURM_ARRAY_TASK_ID", "", "SLURM_ARRAY_TASK_ID is set but empty: expected an integer 0-2 (3 tasks)"),
    ("PBS_ARRAY_INDEX", "", "PBS_ARRAY_INDEX is set but empty"),   # not the whole sweep in every task
    ("SGE_TASK_ID", "", "SGE_TASK_ID is set but empty: expected an integer 1-3"),
])
def test_hostile_job_array_variables_are_refused_before_any_run(tmp_path, monkeypatch, capsys, no_array,
                                                                variable, value, fragment):
    monkeypatch.setenv(variable, value)
    refused(capsys, ["sweep", "run", str(SMOKE), "--results", str(tmp_path)], fragment, tmp_path)


@pytest.mark.parametrize("variable, value", [("SGE_TASK_ID", "undefined"), ("LSB_JOBINDEX", "0")])
def test_outside_arrays_the_schedulers_values_give_no_task(variable, value):
    # SGE sets SGE_TASK_ID=undefined and LSF LSB_JOBINDEX=0 in a job that is not an array
    assert sw.task_from_environment({variable: value}, n_tasks=3) is None


def test_every_set_variable_is_checked_not_only_the_first():
    with pytest.raises(sw.SweepError, match="LSB_JOBINDEX='x'"):
        sw.task_from_environment({"SLURM_ARRAY_TASK_ID": "1", "LSB_JOBINDEX": "x"}, n_tasks=3)


@pytest.mark.parametrize("environ, fragment", [
    ({"SLURM_ARRAY_TASK_ID": "1", "SGE_TASK_ID": "1"},
     "SLURM_ARRAY_TASK_ID='1' (task 1) and SGE_TASK_ID='1' (task 0) give different job-array tasks"),
    ({"PBS_ARRAY_INDEX": "0", "LSB_JOBINDEX": "3"}, "PBS_ARRAY_INDEX='0' (task 0) and LSB_JOBINDEX='3' (task 2)"),
])
def test_variables_that_give_different_tasks_are_refused(tmp_path, monkeypatch, capsys, no_array, environ, fragment):
    for variable, value in environ.items():
        monkeypatch.setenv(variable, value)
    refused(capsys, ["sweep", "run", str(SMOKE), "--results", str(tmp_path)], fragment, tmp_path)


def test_variables_that_give_the_same_task_agree():
    # SGE numbers from 1: its 2 is SLURM's 1; "not an array" values give no task to compare
    assert sw.task_from_environment({"SLURM_ARRAY_TASK_ID": "1", "SGE_TASK_ID": "2", "LSB_JOBINDEX": "0"},
                                    n_tasks=3) == 1


@pytest.mark.parametrize("flags, fragment", [
    (["--task-id", "²"], "argument --task-id: expected an integer >= 0 (at most 18 digits), got '²'"),
    (["--task-id", "-1"], "got '-1'"),
    (["--task-id", "abc"], "got 'abc'"),
    (["--task-id", "1" * 40], "expected an integer >= 0 (at most 18 digits)"),
    (["--task-id", "3"], "task 3 does not exist: sweep smoke has 3 tasks, 0-2"),
    (["--jobs", "²"], "argument --jobs: expected an integer >= 1"),
    (["--jobs", "0"], "argument --jobs: expected an integer >= 1 (at most 18 digits), got '0'"),
    (["--executor", "dask", "--scheduler", "tcp://"], "--scheduler 'tcp://' is not a Dask scheduler address: "
                                                      "expected [protocol://]host:port"),
    (["--executor", "dask", "--scheduler", "tcp://10.0.0.1"], "'tcp://10.0.0.1' is not a Dask scheduler"),
    (["--executor", "dask", "--scheduler", "tcp://10.0.0.1:99999"], "port 1-65535"),
    (["--executor", "dask", "--scheduler", "tcp://host:port"], "'tcp://host:port' is not"),
    (["--executor", "dask", "--scheduler", "http://10.0.0.1:8786"], "'http://10.0.0.1:8786' is not"),
    (["--executor", "dask", "--scheduler", "tcp://a b:8786"], "'tcp://a b:8786' is not"),
    (["--executor", "dask", "--scheduler", "tcp://x:1\nrm"], "'tcp://x:1\\nrm' is not"),
    (["--executor", "dask", "--scheduler", "tcp://" + "a" * 5000 + ":1"], "characters) is not a Dask"),
    (["--scheduler", "tcp://10.0.0.1:8786"], "use it with --executor dask"),
])
def test_hostile_flags_are_refused_before_any_run(tmp_path, capsys, no_array, flags, fragment):
    refused(capsys, ["sweep", "run", str(SMOKE), "--results", str(tmp_path), *flags], fragment, tmp_path)


def test_a_scheduler_that_does_not_answer_is_refused_within_the_timeout(tmp_path, capsys, monkeypatch, no_array):
    monkeypatch.setattr(executors, "SCHEDULER_TIMEOUT_S", 2.0)
    # "within 2 s": the connection waited for the configured timeout, not Dask's default.
    refused(capsys, ["sweep", "run", str(SMOKE), "--results", str(tmp_path), "--executor", "dask",
                     "--scheduler", "tcp://127.0.0.1:1"], "cannot reach the Dask scheduler at tcp://127.0.0.1:1 "
                                                          "within 2 s", tmp_path)


@pytest.mark.parametrize("text, fragment", [
    ("[sweep]\nseeds = [0]\n[grid]\nrule = []\n", "rule is an empty list"),
    ("[sweep]\nseeds = [0]\n[grid]\ntau_minutes = [15.0, 15]\n", "tau_minutes lists 15 more than once"),
    ("[sweep]\nseeds = [0]\nruns_per_task = 0\n[grid]\nrule = ['random']\n", "runs_per_task must be an integer >= 1"),
    ("[sweep]\nseeds = [-1]\n[grid]\nrule = ['random']\n", "[sweep] seeds"),
    ("[sweep]\nseeds = [0]\n[grid]\nrule = ['nope']\n", "[grid] at rule = 'nope'"),
    ("[sweep]\nseeds = [0]\n[grid]\nnope = [1]\n", "nope"),
    ("[grid]\nrule = ['random']\n", "[sweep] seeds: give a non-empty list"),
    # refused at once from the count, before a tuple of 10**12 seeds exhausts memory
    ("[sweep]\nseeds = { start = 0, count = 1000000000000 }\n[grid]\nrule = ['random']\n",
     "[sweep] seeds: count = 1000000000000 seeds is more than a sweep may run: at most 100,000 runs per sweep"),
    ("[sweep]\nseeds = { start = 0, count = 100000 }\n[grid]\nrule = ['random', 'most_confident', "
     "'least_confident']\ntau_minutes = [15, 20, 25, 30, 35, 40, 45, 50, 55, 60]\n",
     "3 rule x 10 tau_minutes x 100000 seeds = 3,000,000 runs; a sweep may hold at most 100,000 runs"),
])
def test_hostile_sweep_files_are_refused_before_any_run(tmp_path, capsys, no_array, text, fragment):
    path = tmp_path / "hostile.toml"
    path.write_text(text)
    results = tmp_path / "results"
    results.mkdir()
    refused(capsys, ["sweep", "run", str(path), "--results", str(results)], fragment, results)


REPLENISHMENT = """[sweep]
scenario = "replenishment"
[set]
trials = 2
ticks = 200
[[grid]]
strategy = ["mobile"]
n_chargers = [1, 2]
"""


@pytest.mark.parametrize("text, fragment", [
    (REPLENISHMENT + "transfer_loss = [0.0, -0.1]\n",
     "[[grid]] 1 at strategy = 'mobile', n_chargers = 1, transfer_loss = -0.1: transfer_loss = -0.1 is not "
     "allowed: must be in [0, 1)"),
    (REPLENISHMENT + "transfer_loss = [1.0]\n", "transfer_loss = 1.0 is not allowed: must be in [0, 1)"),
    (REPLENISHMENT + "work_rate = [1.0]\n", "[[grid]] 1: unknown key 'work_rate' (did you mean 'work_ratio'?). "
                                            "Allowed keys: run.trials"),
    (REPLENISHMENT + "robots.work_ratio = [1.0]\n", "unknown key 'robots.work_ratio'"),
    (REPLENISHMENT + "[[grid]]\nstrategy = ['fixed']\n",
     "[[grid]] 2 at strategy = 'fixed': n_chargers = 6 is not allowed: must be 0 with strategy \"fixed\""),
    (REPLENISHMENT + "[[grid]]\nstrategy = ['mobile']\nn_chargers = [2]\n",
     "[[grid]] 2 at strategy = 'mobile', n_chargers = 2 is the configuration of [[grid]] 1 at strategy = 'mobile', "
     "n_chargers = 2"),
    (REPLENISHMENT.replace("ticks = 200", "ticks = 2.5"), "[set]: run.ticks must be an integer, got float 2.5"),
    (REPLENISHMENT.replace("trials = 2", "trials = 0"), "[set]: trials = 0 is not allowed: must be >= 1"),
    (REPLENISHMENT.replace("[set]", "seeds = [0]\n[set]"),
     "[sweep] seeds does not apply to a replenishment run, which has no root seed"),
    (REPLENISHMENT.replace("trials = 2", "first_trial = 0"), "[set]: run.first_trial = 0 is out of range"),
    (REPLENISHMENT.replace('"replenishment"', '"replenish"'),
     "[sweep] unknown scenario 'replenish' (did you mean 'replenishment'?); registered scenarios: delivery, "
     "replenishment"),
    (REPLENISHMENT.replace("[sweep]\n", "[sweep]\nbase = '../../configs/paper.toml'\n"),
     "[sweep] scenario = 'replenishment', but the base"),
])
def test_hostile_replenishment_sweep_files_are_refused_before_any_run(tmp_path, capsys, monkeypatch, no_array,
                                                                     text, fragment):
    from dronefleet.replenishment import scenario

    monkeypatch.setattr(scenario, "simulate", lambda config: pytest.fail("a run was simulated"))
    path = tmp_path / "hostile.toml"
    path.write_text(text.replace("../../configs/paper.toml", str(ROOT / "configs" / "paper.toml")))
    results = tmp_path / "results"
    results.mkdir()
    for command in ("run", "plan", "status"):
        refused(capsys, ["sweep", command, str(path), "--results", str(results)], fragment, results)


def test_the_runs_cap_is_a_bound_on_the_runs_of_the_product(monkeypatch):
    monkeypatch.setattr(sw, "MAX_RUNS", 8)       # smoke.toml: 2 rule x 2 tau_minutes x 2 seeds
    assert len(sw.load_sweep(SMOKE).runs) == 8
    monkeypatch.setattr(sw, "MAX_RUNS", 7)
    with pytest.raises(sw.SweepError, match="= 8 runs; a sweep may hold at most 7 runs"):
        sw.load_sweep(SMOKE)


def test_repeated_grid_values_are_found_without_comparing_every_pair():
    # 100,000 values (the cap) compared pairwise took minutes before the cap was even checked
    values = [Counted(n) for n in range(2000)]
    assert sw._repeated(values) is None
    assert Counted.comparisons < len(values)
    assert sw._repeated([15, "a", [1], 15.0]) == 15.0 and sw._repeated([[1], [1]]) == [1]


def snapshot(root):
    """Every path under ``root``, with the size and modification time of each file."""
    return {path: (path.stat().st_size, path.stat().st_mtime_ns) if path.is_file() else "folder"
            for path in root.rglob("*")}


@pytest.mark.parametrize("args, fragment", [
    (["run", "--results", "{tmp}/file"], "cannot write '{tmp}/file/smoke': Not a directory: "
                                         "--results must be a folder where files can be written"),
    (["run", "--results", "{tmp}/readonly"], "cannot write '{tmp}/readonly/smoke'"),
    (["plan", "--results", "{tmp}/file"], "cannot write '{tmp}/file/smoke'"),
    (["plan", "--results", "{tmp}/new", "--out", "{tmp}/folder"], "--out '{tmp}/folder' is a folder"),
    (["plan", "--results", "{tmp}/new", "--out", "/dev/null/x"], "cannot write '/dev/null': Not a directory: "
                                                                 "--out must be a file in a writable folder"),
    (["plan", "--results", "{tmp}/new", "--out", "{tmp}/file/x.sbatch"], "cannot write '{tmp}/file'"),
])
def test_output_paths_that_cannot_be_written_are_refused_before_anything_is_made(tmp_path, capsys, no_array,
                                                                                 monkeypatch, args, fragment):
    if "readonly" in args[2]:
        # Root writes into a mode-555 folder, so the file system's refusal is made here (CI runs as root).
        import errno
        import tempfile
        real = tempfile.mkdtemp

        def mkdtemp(*a, dir=None, **k):
            if "readonly" in str(dir):
                raise OSError(errno.EROFS, "Read-only file system")
            return real(*a, dir=dir, **k)
        monkeypatch.setattr(tempfile, "mkdtemp", mkdtemp)
    (tmp_path / "file").write_text("a file where a folder belongs")
    (tmp_path / "folder").mkdir()
    (tmp_path / "readonly").mkdir(mode=0o555)
    before = snapshot(tmp_path)
    args = [arg.format(tmp=tmp_path) for arg in args]
    assert run_cli(["sweep", args[0], str(SMOKE), *args[1:]]) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err and len(err.splitlines()) == 1 and fragment.format(tmp=tmp_path) in err, err
    assert snapshot(tmp_path) == before  # no _logs, no dataset folder


MOVED = 'rule = ["least_confident", "random"]\n'   # smoke.toml's rule, moved from [grid] to [set] below


@pytest.mark.parametrize("dataset, fragment", [
    ({"_layout.json": '{"keys": ["rule", "tau_minutes", "seed"]}\n'},
     "smoke holds a dataset partitioned by rule/tau_minutes/seed; this sweep partitions by tau_minutes/seed: "
     "use another [sweep] name or --results"),
    # a dataset written before _layout.json: its layout comes from its partition directories
    ({"summary/rule=random/tau_minutes=15.0/seed=0/part-0.parquet": "x"}, "partitioned by rule/tau_minutes/seed"),
    ({"orders/rule=random/tau_minutes=15.0/seed=0/part-0.parquet": "x"}, "partitioned by rule/tau_minutes/seed"),
    ({"_layout.json": "{not json"}, "cannot read the partition layout of the dataset"),
    ({"_layout.json": '{"keys": "rule"}'}, "cannot read the partition layout of the dataset"),
])
@pytest.mark.parametrize("command", ["run", "plan", "status", "collect"])
def test_a_sweep_of_another_partition_layout_is_refused_in_the_same_dataset(tmp_path, capsys, no_array,
                                                                            dataset, fragment, command):
    moved = tmp_path / "moved.toml"
    text = SMOKE.read_text()
    assert MOVED in text
    moved.write_text(text.replace(MOVED, "").replace("[set]\n", '[set]\nrule = "random"\n'))
    results = tmp_path / "results"
    for name, content in dataset.items():
        (results / "smoke" / name).parent.mkdir(parents=True, exist_ok=True)
        (results / "smoke" / name).write_text(content)
    before = snapshot(tmp_path)
    assert run_cli(["sweep", command, str(moved), "--results", str(results)]) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err and len(err.splitlines()) == 1 and fragment in err, err
    assert snapshot(tmp_path) == before


# ---------------------------------------------------------------------------- what a sweep survives


def test_a_failure_record_that_cannot_be_written_is_reported_and_the_sweep_goes_on(tmp_path, monkeypatch, capsys,
                                                                                   no_array):
    real = simulation.simulate

    def simulate(config, **kwargs):
        if config.rule == "random" and config.tau_minutes == 15.0 and config.seed == 1:
            raise ValueError("injected failure")
        return real(config, **kwargs)

    monkeypatch.setattr(simulation, "simulate", simulate)
    out = tmp_path / "smoke"
    out.mkdir()
    (out / "_failed").write_text("a file where the failure records' directory belongs")
    assert cli.main(["sweep", "run", str(SMOKE), "--results", str(tmp_path), "--jobs", "1"]) == 1
    captured = capsys.readouterr()
    warning = [line for line in captured.err.splitlines() if "cannot write the failure record" in line]
    assert len(warning) == 1 and "rule=random/tau_minutes=15.0/seed=1" in warning[0], captured.err
    assert "its error: ValueError: injected failure" in warning[0]
    assert "ran 8, skipped 0 done before, 1 failed" in captured.out
    s = sw.load_sweep(SMOKE)
    assert [sw.state(run, out) for run in s.runs].count("done") == 7
    # the run is not done, so the next sweep run redoes it
    monkeypatch.setattr(simulation, "simulate", real)
    assert cli.main(["sweep", "run", str(SMOKE), "--results", str(tmp_path), "--jobs", "1"]) == 0
    assert "ran 1, skipped 7 done before, 0 failed" in capsys.readouterr().out


def test_grid_keys_in_another_order_are_the_same_sweep_with_one_layout(tmp_path, capsys, no_array):
    text = SMOKE.read_text()
    rule_first = 'rule = ["least_confident", "random"]\ntau_minutes = [15.0, 30.0]\n'
    assert rule_first in text
    swapped = tmp_path / "swapped.toml"
    swapped.write_text(text.replace(rule_first, 'tau_minutes = [15.0, 30.0]\nrule = ["least_confident", "random"]\n'))
    a, b = sw.load_sweep(SMOKE), sw.load_sweep(swapped)
    assert list(a.grid) == list(b.grid) == ["rule", "tau_minutes"]     # sorted by name
    assert [r.partition for r in a.runs] == [r.partition for r in b.runs]  # same runs, same tasks
    assert [r.config for r in a.runs] == [r.config for r in b.runs]
    results = tmp_path / "results"
    assert cli.main(["sweep", "run", str(SMOKE), "--results", str(results), "--jobs", "1"]) == 0
    assert cli.main(["sweep", "run", str(swapped), "--results", str(results), "--jobs", "1"]) == 0
    assert "ran 0, skipped 8 done before" in capsys.readouterr().out
    layouts = {tuple(part.split("=")[0] for part in path.relative_to(results / "smoke" / "summary").parts[:-1])
               for path in (results / "smoke" / "summary").rglob("*.parquet")}
    assert layouts == {("rule", "tau_minutes", "seed")}
    layout = results / "smoke" / "_layout.json"
    assert json.loads(layout.read_text()) == {"keys": ["rule", "tau_minutes", "seed"], "scenario": "delivery"}  # written by the first run
    # the same name with rule moved to [set]: refused, not a second layout beside the first
    moved = tmp_path / "moved.toml"
    moved.write_text(text.replace(rule_first, 'tau_minutes = [15.0, 30.0]\n').replace("[set]\n", '[set]\nrule = "random"\n'))
    assert run_cli(["sweep", "run", str(moved), "--results", str(results), "--jobs", "1"]) == 2
    assert "partitioned by rule/tau_minutes/seed; this sweep partitions by tau_minutes/seed" in capsys.readouterr().err
    assert not (results / "smoke" / "summary" / "tau_minutes=15.0").exists()
    # a dataset of before _layout.json: the layout is read from its folders, and recorded by the next run
    layout.unlink()
    assert run_cli(["sweep", "run", str(moved), "--results", str(results), "--jobs", "1"]) == 2
    assert cli.main(["sweep", "run", str(SMOKE), "--results", str(results), "--jobs", "1"]) == 0
    assert "ran 0, skipped 8 done before" in capsys.readouterr().out
    assert json.loads(layout.read_text()) == {"keys": ["rule", "tau_minutes", "seed"], "scenario": "delivery"}


# ---------------------------------------------------------------------------- a killed sweep leaves no process


def _children(pid):
    """Pids whose parent is ``pid``, from /proc."""
    found = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                stat = (entry / "stat").read_text()
            except OSError:  # ended meanwhile
                continue
            if int(stat.rsplit(")", 1)[1].split()[1]) == pid:
                found.append(int(entry.name))
    return found


def _descendants(pid):
    found, todo = [], [pid]
    while todo:
        children = _children(todo.pop())
        found += children
        todo += children
    return found


def _alive(pid):
    """Running, not a zombie waiting for its new parent to reap it."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return False
    return stat.rsplit(")", 1)[1].split()[0] != "Z"


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="reads processes from /proc (Linux)")
def test_a_killed_sweep_leaves_no_worker_and_no_resource_tracker(tmp_path):
    path = tmp_path / "long.toml"
    path.write_text('[sweep]\nname = "long"\nseeds = { start = 0, count = 5 }\n[set]\nhorizon_weeks = 0.1\n'
                    '[grid]\nrule = ["least_confident"]\n')
    # The workers' runs never end (the first run, in the sweep's own process, is real): the sweep
    # is still running when killed, whatever the machine's speed. Workers import it by name.
    (tmp_path / "endless.py").write_text(
        "import multiprocessing, time\nfrom dronefleet import sweeps\nreal = sweeps.execute\n"
        "def execute(run, out):\n    if multiprocessing.parent_process() is not None:\n"
        "        time.sleep(3600)\n    return real(run, out)\n")
    code = ("import sys, endless\nfrom dronefleet import cli, sweeps\nsweeps.execute = endless.execute\n"
            f"sys.exit(cli.main(['sweep', 'run', {str(path)!r}, '--results', {str(tmp_path)!r}, '--jobs', '2']))\n")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(tmp_path), str(ROOT), os.environ.get("PYTHONPATH", "")])}
    for name, _ in sw.TASK_VARIABLES:
        env.pop(name, None)
    sweep = subprocess.Popen([sys.executable, "-c", code], env=env, stdout=subprocess.DEVNULL,
                             stderr=subprocess.DEVNULL)
    started = []
    try:
        deadline = time.monotonic() + 300  # the first run compiles the engine if no cache has it
        # two workers and the resource trackers (multiprocessing's, loky's), started with the first worker
        while len(started := _descendants(sweep.pid)) < 3 and time.monotonic() < deadline:
            assert sweep.poll() is None, "the sweep ended before it was killed"
            time.sleep(0.1)
        assert len(started) >= 3, started
        assert any(b"resource_tracker" in Path(f"/proc/{pid}/cmdline").read_bytes() for pid in started)
        time.sleep(1.0)  # workers running their first runs
        started = _descendants(sweep.pid)
        sweep.send_signal(signal.SIGKILL)
        sweep.wait()
        deadline = time.monotonic() + 10
        while any(map(_alive, started)) and time.monotonic() < deadline:
            time.sleep(0.1)
        assert not [pid for pid in started if _alive(pid)]
    finally:
        sweep.kill()
        for pid in started:  # if the test failed: end what it started
            if _alive(pid):
                os.kill(pid, signal.SIGKILL)


def test_without_prctl_a_worker_ends_when_its_parent_is_gone():
    # The portable fallback: a parent pid that is not this process's parent means "gone".
    code = "import os; from dronefleet.executors import _watch_parent; _watch_parent(os.getppid() + 1)"
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    assert subprocess.run([sys.executable, "-c", code], env=env, timeout=60).returncode == 1


def test_status_reports_an_unreadable_failure_record_instead_of_failing(tmp_path, capsys, no_array):
    s = sw.load_sweep(SMOKE)
    out = tmp_path / "smoke"
    record = s.runs[0].failure_path(out)
    record.parent.mkdir(parents=True)
    record.write_bytes(b"\xff{not json")
    assert cli.main(["sweep", "status", str(SMOKE), "--results", str(tmp_path)]) == 1
    captured = capsys.readouterr()
    assert "Traceback" not in captured.err
    assert f"failed   {s.runs[0].partition}: (the record {record.name} cannot be read" in captured.out


# ---------------------------------------------------------------------------- the job-array script of `sweep plan`


@pytest.mark.parametrize("flags, fragment", [
    (["--time", "1:00\ntouch x"], "--time '1:00\\ntouch x' is not a SLURM time limit"),  # a command line of its own
    (["--time", "1:00\rtouch x"], "--time '1:00\\rtouch x' is not a SLURM time limit"),
    (["--time", "30m"], "--time '30m' is not a SLURM time limit: minutes, MM:SS, HH:MM:SS, D-HH"),
    (["--time", "1:00 --wrap=x"], "--time '1:00 --wrap=x' is not"),
    (["--time", "1:2:3:4"], "--time '1:2:3:4' is not"),
    (["--partition", "a b"], "--partition 'a b' is not partition names"),
    (["--partition", "short,"], "--partition 'short,' is not"),
    (["--partition", "x\x00y"], "--partition 'x\\x00y' is not"),
    (["--account", "$(id)"], "--account '$(id)' is not an account name"),
    (["--account", "lab,other"], "--account 'lab,other' is not"),
    (["--results", "{tmp}/new\nline"], "--results '{tmp}/new\\nline' holds the control character '\\n', which a "
                                       "job script cannot carry safely"),
    (["--results", "{tmp}/esc\x1b[2J"], "holds the control character '\\x1b'"),
    (["--results", "{tmp}/not-utf8-\udcff"], "holds a byte that is not UTF-8"),
    (["--results", "{tmp}/back\\slash"], "holds a backslash (an escape to sbatch)"),
    (["--out", "{tmp}/x\n.sbatch"], "--out '{tmp}/x\\n.sbatch' holds the control character '\\n'"),
])
def test_hostile_plan_values_are_refused_before_anything_is_made(tmp_path, capsys, no_array, flags, fragment):
    flags = [flag.format(tmp=tmp_path) for flag in flags]
    if "--results" not in flags:
        flags += ["--results", str(tmp_path / "results")]
    refused(capsys, ["sweep", "plan", str(SMOKE), *flags], fragment.format(tmp=tmp_path), tmp_path)


@pytest.mark.parametrize("time_limit", ["30", "30:00", "12:30:00", "2-12", "2-12:30", "2-12:30:00", "UNLIMITED"])
def test_every_slurm_time_format_is_taken(tmp_path, capsys, time_limit):
    assert cli.main(["sweep", "plan", str(SMOKE), "--results", str(tmp_path), "--time", time_limit]) == 0
    assert f"\n#SBATCH --time={time_limit}\n" in (tmp_path / "smoke" / "smoke.sbatch").read_text()


def test_the_job_script_keeps_hostile_paths_literal(tmp_path, monkeypatch, capsys):
    """Paths that hold spaces, quotes, % and ``$(...)`` reach the task's command as they are:
    bash (and sbatch, whose #SBATCH parser takes the same quotes) expands nothing."""
    hostile = "a $(touch {}) it's `touch {}` %x"
    here = tmp_path / hostile.format("here-ran", "here-ran")
    (here / "sweeps").mkdir(parents=True)
    sweep = here / "sweeps" / hostile.format("sweep-ran", "sweep-ran").replace("%x", "x.toml")
    sweep.write_text(SMOKE.read_text())
    results = here / hostile.format("results-ran", "results-ran")
    monkeypatch.chdir(here)
    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    assert cli.main(["sweep", "plan", str(sweep), "--results", str(results)]) == 0
    script = results / "smoke" / "smoke.sbatch"
    assert f"sbatch {shlex.quote(str(script))}" in capsys.readouterr().out  # a command that can be pasted
    text = script.read_text()
    assert subprocess.run(["bash", "-n", str(script)]).returncode == 0
    output = [line for line in text.splitlines() if line.startswith("#SBATCH --output=")]
    assert shlex.split(output[0].removeprefix("#SBATCH ")) == [
        f"--output={str(results).replace('%', '%%')}/smoke/_logs/%A_%a.out"]  # %% is SLURM's literal %
    # Run the script with its last line printing the words it would exec, instead of exec'ing them.
    assert text.count("\nexec ") == 1
    shown = script.with_name("shown.sh")
    shown.write_text(text.replace("\nexec ", "\nprintf '%s\\n' \"$PWD\" \"$NUMBA_CACHE_DIR\" "))
    done = subprocess.run(["bash", str(shown)], cwd=tmp_path, capture_output=True, text=True,
                          env={**os.environ, "SLURM_ARRAY_TASK_ID": "1"})
    assert done.returncode == 0, done.stderr
    assert done.stdout.splitlines() == [str(here), str(results / "_numba_cache"), sys.executable, "-m",
                                        "dronefleet.cli", "sweep", "run", str(sweep), "--results", str(results),
                                        "--task-id", "1"]
    assert not list(tmp_path.rglob("*-ran")), "a command in a path was run"


def _dataset_with_layout(root):
    out = root / "smoke"
    out.mkdir(parents=True)
    (out / "_layout.json").write_text('{"keys": ["rule", "tau_minutes", "seed"]}\n')
    return out


def test_plan_never_replaces_a_dataset_file_a_special_file_or_a_file_it_did_not_write(tmp_path, capsys):
    results = tmp_path / "results"
    out = _dataset_with_layout(results)
    (tmp_path / "notes.txt").write_text("mine")
    os.mkfifo(tmp_path / "pipe")
    before = snapshot(tmp_path)
    for target, fragment in [
        (out / "_layout.json", f"--out {str(out / '_layout.json')!r} lies inside the dataset {str(out)!r}, "
                               f"whose files it would replace: give {str(out / 'smoke.sbatch')!r}"),
        (out / "_logs" / "x.sbatch", "lies inside the dataset"),
        (tmp_path / "notes.txt", f"--out {str(tmp_path / 'notes.txt')!r} exists and is not a job-array script "
                                 "that dronefleet sweep plan wrote, so it is not replaced"),
        (tmp_path / "pipe", f"--out {str(tmp_path / 'pipe')!r} is a named pipe (FIFO), which writing would "
                            "replace with a regular file"),
        (SMOKE, "exists and is not a job-array script"),
    ]:
        assert run_cli(["sweep", "plan", str(SMOKE), "--results", str(results), "--out", str(target)]) == 2
        err = capsys.readouterr().err
        assert "Traceback" not in err and len(err.splitlines()) == 1 and fragment in err, err
        assert snapshot(tmp_path) == before
    assert (tmp_path / "pipe").is_fifo()
    # its own scripts are written again: in the dataset, and anywhere else it wrote one
    for target in (out / "smoke.sbatch", tmp_path / "smoke.sh"):
        for _ in range(2):
            assert run_cli(["sweep", "plan", str(SMOKE), "--results", str(results), "--out", str(target)]) == 0
        assert target.read_text().startswith(sw.SCRIPT_HEAD)


def _disk_full_after(monkeypatch, module, name, keep=100):
    """``module.name`` (a writer whose second argument, or self, is the path) writes ``keep`` bytes
    of its output, then fails as a full disk does."""
    import errno

    def full(*args, **kwargs):
        path = args[1] if not isinstance(args[0], Path) else args[0]
        Path(path).write_bytes(b"x" * keep)
        raise OSError(errno.ENOSPC, "No space left on device")
    monkeypatch.setattr(module, name, full)


def test_a_script_write_that_fails_is_one_line_and_leaves_nothing(tmp_path, capsys, monkeypatch):
    out = _dataset_with_layout(tmp_path)
    (out / "_logs").mkdir()
    script = out / "smoke.sbatch"
    before = snapshot(tmp_path)
    _disk_full_after(monkeypatch, Path, "write_text")
    assert run_cli(["sweep", "plan", str(SMOKE), "--results", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err and len(err.splitlines()) == 1, err
    assert f"cannot write {str(script)!r}: No space left on device" in err
    assert snapshot(tmp_path) == before  # no script, whole or partial, and no hidden temporary


@pytest.fixture(scope="module")
def tiny_done(tmp_path_factory):
    """The results root of the tiny delivery sweep, run (4 runs)."""
    from conftest import TINY_SWEEPS

    root = tmp_path_factory.mktemp("tiny")
    (root / "tiny.toml").write_text(TINY_SWEEPS["delivery"])
    assert cli.main(["sweep", "run", str(root / "tiny.toml"), "--results", str(root / "results"), "--jobs", "1"]) == 0
    return root


def test_a_collect_write_that_fails_is_one_line_and_leaves_nothing(tiny_done, capsys, monkeypatch):
    import pyarrow.parquet as pq

    out = tiny_done / "results" / "tiny"
    before = snapshot(tiny_done)
    _disk_full_after(monkeypatch, pq, "write_table")
    assert run_cli(["sweep", "collect", str(tiny_done / "tiny.toml"), "--results", str(tiny_done / "results")]) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err and len(err.splitlines()) == 1, err
    assert f"cannot write {str(out / 'collected.parquet')!r}: No space left on device" in err
    assert snapshot(tiny_done) == before


def test_collect_never_replaces_a_special_file(tiny_done, capsys):
    collected = tiny_done / "results" / "tiny" / "collected.parquet"
    os.mkfifo(collected)
    try:
        assert run_cli(["sweep", "collect", str(tiny_done / "tiny.toml"), "--results",
                        str(tiny_done / "results")]) == 2
        err = capsys.readouterr().err
        assert len(err.splitlines()) == 1 and f"{str(collected)!r} is a named pipe (FIFO)" in err, err
        assert collected.is_fifo()
    finally:
        collected.unlink()


def test_a_layout_write_that_fails_is_one_line(tmp_path, capsys, monkeypatch, no_array):
    import errno

    def full(sweep, out):
        raise OSError(errno.ENOSPC, "No space left on device")
    monkeypatch.setattr(sw, "_record_layout", full)
    monkeypatch.setattr(sw, "execute", lambda run, out: pytest.fail("a run ran"))
    assert run_cli(["sweep", "run", str(SMOKE), "--results", str(tmp_path), "--jobs", "1"]) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err and len(err.splitlines()) == 1, err
    assert f"cannot write {str(tmp_path / 'smoke' / '_layout.json')!r}: No space left on device" in err


# ---------------------------------------------------------------------------- files a sweep does not own


def test_a_folder_of_the_users_files_is_never_a_sweeps_dataset(tmp_path, capsys, no_array):
    import pyarrow as pa
    import pyarrow.parquet as pq

    results = tmp_path / "results"
    mine = results / "smoke"   # the folder the sweep's dataset would be
    mine.mkdir(parents=True)
    pq.write_table(pa.table({"x": [1]}), mine / "collected.parquet")
    (mine / "notes.txt").write_text("mine")
    before = snapshot(tmp_path)
    for command in ("run", "status", "collect"):
        assert run_cli(["sweep", command, str(SMOKE), "--results", str(results)]) == 2
        err = capsys.readouterr().err
        assert "Traceback" not in err and len(err.splitlines()) == 1, err
        assert f"{mine} is not a sweep dataset and holds files dronefleet did not write ('notes.txt')" in err, err
        assert snapshot(tmp_path) == before


def test_another_tasks_write_probe_in_the_folder_is_not_a_users_file(tmp_path, capsys, no_array):
    # a task of the same job array checks that it can write there at the moment this one looks
    empty, probed = tmp_path / "empty", tmp_path / "probed"
    (empty / "smoke").mkdir(parents=True)
    (probed / "smoke" / f"{PROBE_PREFIX}x1y2").mkdir(parents=True)
    assert run_cli(["sweep", "status", str(SMOKE), "--results", str(empty)]) == 1   # nothing run yet
    capsys.readouterr()
    assert run_cli(["sweep", "status", str(SMOKE), "--results", str(probed)]) == 1, capsys.readouterr().err


@pytest.mark.parametrize("stray", ["summary/notes.txt", "orders/rule=random/notes.txt", "summary/rule=random/mine",
                                   "summary/part-0.parquet"])
def test_a_users_folder_named_as_a_table_is_never_a_sweeps_dataset(tmp_path, capsys, no_array, stray):
    mine = tmp_path / "results" / "smoke"
    # beside the user's file, the partitions of an older dataset (no _layout.json) do not make it one
    (mine / "summary" / "rule=random" / "tau_minutes=15.0" / "seed=1").mkdir(parents=True)
    (mine / "summary" / "rule=random" / "tau_minutes=15.0" / "seed=1" / "part-0.parquet").write_bytes(b"PAR1")
    (mine / stray).parent.mkdir(parents=True, exist_ok=True)
    (mine / stray).write_text("mine")
    before = snapshot(tmp_path)
    for command in ("run", "status", "collect"):
        assert run_cli(["sweep", command, str(SMOKE), "--results", str(tmp_path / "results")]) == 2
        err = capsys.readouterr().err
        assert "Traceback" not in err and len(err.splitlines()) == 1, err
        assert f"{mine} is not a sweep dataset: its {stray!r} is not a run's part" in err, err
        assert snapshot(tmp_path) == before


def test_collect_never_replaces_a_summary_table_it_did_not_write(tiny_done, capsys):
    import pyarrow as pa
    import pyarrow.parquet as pq

    collected = tiny_done / "results" / "tiny" / "collected.parquet"
    args = ["sweep", "collect", str(tiny_done / "tiny.toml"), "--results", str(tiny_done / "results")]
    assert run_cli(args) == 0   # its own is written again
    assert run_cli(args) == 0
    pq.write_table(pa.table({"mine": [1.5]}), collected)
    before = collected.read_bytes()
    capsys.readouterr()
    assert run_cli(args) == 2
    err = capsys.readouterr().err
    assert len(err.splitlines()) == 1 and f"{str(collected)!r} exists and is not a summary table that dronefleet " \
        "sweep collect wrote, so it is not replaced" in err, err
    assert collected.read_bytes() == before
    collected.unlink()


# ---------------------------------------------------------------------------- one scenario per dataset

#: Items and lunar sweeps over n_robots have one layout: n_robots/root_seed.
ROBOTS = """[sweep]
name = "shared"
scenario = "{scenario}"
[set]
{fixed}
[grid]
n_robots = [5]
"""


@pytest.fixture(scope="module")
def items_dataset(tmp_path_factory):
    """A results root holding the items dataset "shared", partitioned by n_robots/root_seed."""
    root = tmp_path_factory.mktemp("shared")
    (root / "items.toml").write_text(ROBOTS.format(scenario="items", fixed="trials = 1\nsteps = 50"))
    (root / "lunar.toml").write_text(ROBOTS.format(scenario="lunar", fixed="runs = 1\nduration_s = 20.0"))
    assert cli.main(["-q", "sweep", "run", str(root / "items.toml"), "--results", str(root / "results"),
                     "--jobs", "1"]) == 0
    return root


@pytest.mark.parametrize("record", ["with its scenario", "without (an older dataset)", "none (an older dataset)"])
def test_a_sweep_of_another_scenario_never_enters_a_dataset_of_the_same_layout(items_dataset, tmp_path,
                                                                                capsys, no_array, record):
    import shutil

    results = shutil.copytree(items_dataset / "results", tmp_path / "results")
    layout = results / "shared" / "_layout.json"
    assert json.loads(layout.read_text()) == {"keys": ["n_robots", "root_seed"], "scenario": "items"}
    if record == "without (an older dataset)":
        layout.write_text('{"keys": ["n_robots", "root_seed"]}\n')
    elif record == "none (an older dataset)":
        layout.unlink()
    before = snapshot(tmp_path)
    for command in ("run", "status", "collect"):
        assert run_cli(["sweep", command, str(items_dataset / "lunar.toml"), "--results", str(results)]) == 2
        err = capsys.readouterr().err
        assert "Traceback" not in err and len(err.splitlines()) == 1, err
        assert f"{results / 'shared'} holds a dataset of the 'items' scenario; this sweep is of lunar" in err
        assert snapshot(tmp_path) == before
    # its own scenario's sweep goes on, and records the scenario in an older dataset's layout
    assert run_cli(["sweep", "run", str(items_dataset / "items.toml"), "--results", str(results)]) == 0
    assert json.loads(layout.read_text())["scenario"] == "items"


def test_an_older_dataset_whose_scenario_cannot_be_told_is_refused_not_replaced(items_dataset, tmp_path,
                                                                               capsys, no_array):
    import shutil

    results = shutil.copytree(items_dataset / "results", tmp_path / "results")
    (results / "shared" / "_layout.json").unlink()
    part = next((results / "shared" / "summary").rglob("part-0.parquet"))
    part.write_bytes(part.read_bytes()[:100])
    before = snapshot(tmp_path)
    assert run_cli(["sweep", "run", str(items_dataset / "lunar.toml"), "--results", str(results)]) == 2
    err = capsys.readouterr().err
    assert len(err.splitlines()) == 1 and f"cannot tell the scenario of the dataset {results / 'shared'}" in err, err
    assert snapshot(tmp_path) == before
