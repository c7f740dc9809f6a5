"""What an installed scenario's hooks do at run time is contained: an exit, a kill, an error or a result
the contract does not allow is one line naming the scenario and the hook (exit code 2, or a failed run
of a sweep), never a silent exit 0, a traceback or the death of the command.

Each plugin is the example scenario (random_walk) with one hook overridden, installed as an entry point
in ``tmp_path``. A hook that ends its process runs in a child ``dronefleet`` (or Python), so that the
test's own process survives the old behaviour."""

import itertools
import json
import os
import pickle
import signal
import subprocess
import sys
import time
from pathlib import Path

import pyarrow.parquet as pq
import pytest
from test_scenario_contract import ROOT, WALK, config_file, install, refused

import dronefleet
from dronefleet import cli, scenarios
from dronefleet.scenarios import HookError

NAMES = (f"contained{n}" for n in itertools.count())  # imports and entry points are cached: a name per test


def plugin(tmp_path, monkeypatch, hooks):
    """Install the example scenario, with ``hooks`` (Python source) appended, under a name of its own."""
    name = next(NAMES)
    text = WALK.replace('NAME = "random_walk"', f'NAME = "{name}"') + "\n_simulate = simulate\n" + hooks
    install(tmp_path, name, f"{name}_module", f"{name}_module", text)
    monkeypatch.syspath_prepend(str(tmp_path))
    return name


def dronefleet_process(tmp_path, *argv):
    """``dronefleet ARGV`` in a process of its own, the plugins of ``tmp_path`` installed."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(map(str, (tmp_path, ROOT)))}
    return subprocess.run([sys.executable, "-m", "dronefleet", *map(str, argv)], capture_output=True, text=True,
                          env=env, cwd=tmp_path, timeout=300)


def one_error(done, *fragments):
    lines = done.stderr.splitlines()
    assert len(lines) == 1 and "Traceback" not in done.stderr, done.stderr
    for fragment in fragments:
        assert fragment in lines[0], lines
    return lines[0]


# --------------------------------------------------------------------------- exits and kills


EXITS = "def simulate(config):\n    import os\n    os._exit(0)\n"
KILLED = "def simulate(config):\n    import os, signal\n    os.kill(os.getpid(), signal.SIGKILL)\n"


@pytest.mark.parametrize("hooks, how", [(EXITS, "exit code 0"), (KILLED, "killed by SIGKILL")], ids=["exit", "kill"])
def test_a_simulate_that_ends_its_process_is_one_error_not_a_silent_exit(tmp_path, monkeypatch, hooks, how):
    name = plugin(tmp_path, monkeypatch, hooks)
    done = dronefleet_process(tmp_path, "run", config_file(tmp_path, name), "--out", "out")
    assert done.returncode == 2
    one_error(done, f"scenario '{name}': its simulate ended its process ({how})")
    assert not (tmp_path / "out").exists()
    api = subprocess.run([sys.executable, "-c", f"import dronefleet\ntry:\n    dronefleet.run({name!r})\n"
                          "except dronefleet.scenarios.HookError as error:\n    print(error)\n"],
                         capture_output=True, text=True, cwd=tmp_path, timeout=300,
                         env={**os.environ, "PYTHONPATH": os.pathsep.join(map(str, (tmp_path, ROOT)))})
    assert api.returncode == 0 and f"its simulate ended its process ({how})" in api.stdout, api.stderr


SWEEP = '[sweep]\nname = "walks"\nscenario = "{name}"\nseeds = [1, 2]\n[grid]\nbattery = [30]\n'
#: The first run of the sweep (seed 1) ends its process; the second runs.
FIRST_DIES = ("def simulate(config):\n    import os, signal\n    if config.seed == 1:\n        {}\n"
              "    return _simulate(config)\n")


@pytest.mark.parametrize("death", ["os._exit(0)", "os.kill(os.getpid(), signal.SIGKILL)"], ids=["exit", "kill"])
def test_the_death_of_a_sweeps_first_run_is_one_failed_run(tmp_path, monkeypatch, death):
    name = plugin(tmp_path, monkeypatch, FIRST_DIES.format(death))
    (tmp_path / "walks.toml").write_text(SWEEP.format(name=name))
    done = dronefleet_process(tmp_path, "sweep", "run", "walks.toml", "--results", "results", "--jobs", "2")
    assert done.returncode == 1, done.stderr
    assert "failed  battery=30/seed=1: its worker died" in done.stderr and "Traceback" not in done.stderr, done.stderr
    dataset = tmp_path / "results" / "walks"
    assert (dataset / "summary" / "battery=30" / "seed=2" / "part-0.parquet").is_file()
    assert not (dataset / "summary" / "battery=30" / "seed=1").exists()
    assert (dataset / "_failed" / "battery=30,seed=1.json").is_file()


def test_sys_exit_in_a_hook_is_an_error_naming_it(tmp_path, monkeypatch, capsys):
    name = plugin(tmp_path, monkeypatch, "def simulate(config):\n    raise SystemExit(7)\n")
    refused(capsys, ["run", config_file(tmp_path, name), "--out", tmp_path / "out"],
            f"scenario '{name}': its simulate called sys.exit(7)")
    assert not (tmp_path / "out").exists()
    name = plugin(tmp_path, monkeypatch, "def describe(config):\n    import sys\n    sys.exit('no')\n")
    refused(capsys, ["run", config_file(tmp_path, name), "--out", tmp_path / "out"],
            f"scenario '{name}': its describe called sys.exit('no')")


def test_sys_exit_in_a_sweeps_simulate_is_a_failed_run(tmp_path, monkeypatch, capsys):
    name = plugin(tmp_path, monkeypatch, FIRST_DIES.format("raise SystemExit(7)"))
    (tmp_path / "walks.toml").write_text(SWEEP.format(name=name))
    assert cli.main(["sweep", "run", str(tmp_path / "walks.toml"), "--results", str(tmp_path), "--jobs", "1"]) == 1
    assert "failed  battery=30/seed=1: HookError: scenario" in capsys.readouterr().err
    record = json.loads((tmp_path / "walks" / "_failed" / "battery=30,seed=1.json").read_text())
    assert record["error"] == f"HookError: scenario '{name}': its simulate called sys.exit(7)"
    assert (tmp_path / "walks" / "summary" / "battery=30" / "seed=2" / "part-0.parquet").is_file()


#: A simulate that says where it runs, then never returns (pure Python: Ctrl-C would reach it).
SPINS = ("def simulate(config):\n    import os, pathlib\n"
         "    pathlib.Path(__file__).with_name('simulating').write_text(str(os.getpid()))\n"
         "    while True:\n        pass\n")


def _gone(pid):
    """Whether the process ``pid`` has ended (a zombie waiting for init to reap it has)."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] in "ZX"
    except FileNotFoundError:
        return True


@pytest.mark.skipif(not Path("/proc/self/stat").is_file(), reason="reads process states in /proc")
@pytest.mark.parametrize("signum, code, said", [(signal.SIGINT, 130, "interrupted"),
                                                (signal.SIGTERM, 143, "interrupted by SIGTERM")], ids=["ctrl-c", "sigterm"])
def test_ctrl_c_or_sigterm_of_a_contained_simulate_ends_it_and_its_process(tmp_path, monkeypatch, signum, code, said):
    name = plugin(tmp_path, monkeypatch, SPINS)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(map(str, (tmp_path, ROOT)))}
    process = subprocess.Popen([sys.executable, "-m", "dronefleet", "run", str(config_file(tmp_path, name)),
                                "--out", "out"], cwd=tmp_path, env=env, text=True, stderr=subprocess.PIPE,
                               preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    marker, deadline = tmp_path / "simulating", time.monotonic() + 300  # a hang, not a measure
    while not marker.exists():
        assert process.poll() is None and time.monotonic() < deadline, process.communicate()[1]
        time.sleep(0.05)
    process.send_signal(signum)  # to the command alone: a plugin that ignored it must not keep it running
    _, err = process.communicate(timeout=60)
    assert (process.returncode, err) == (code, f"dronefleet: {said}\n")
    worker = int(marker.read_text())
    while not _gone(worker):
        assert time.monotonic() < deadline, "the worker of the simulate lives on"
        time.sleep(0.05)
    assert not (tmp_path / "out").exists()


# --------------------------------------------------------------------------- what hooks return


def test_a_built_in_stays_trusted_in_a_worker_process_and_an_installed_one_is_checked(tmp_path, monkeypatch):
    # a sweep's worker gets a copy of the scenario: a built-in's own errors (RunTooLargeError) must stay theirs
    assert pickle.loads(pickle.dumps(scenarios.SCENARIOS["delivery"])).builtin
    assert not pickle.loads(pickle.dumps(scenarios.get(plugin(tmp_path, monkeypatch, "")))).builtin


@pytest.mark.parametrize("hooks, fragment", [
    ("def simulate(config):\n    raise RuntimeError('no licence')\n", "simulate raised RuntimeError: no licence"),
    ("def simulate(config):\n    return list(_simulate(config).values())\n",
     "simulate returned list, not a dict of its tables (robots, summary)"),
    ("def simulate(config):\n    return {'robots': _simulate(config)['robots']}\n",
     "simulate returned the tables 'robots'; its TABLES are robots, summary"),
    ("def simulate(config):\n    return {k: v.to_pydict() for k, v in _simulate(config).items()}\n",
     "simulate returned its table 'robots' as dict, not a pyarrow Table"),
    ("def load(path=None, overrides=(), seed=None):\n    return None\n",
     "load returned NoneType, not a config"),
    ("def describe(config):\n    raise KeyError('steps')\n", "describe raised KeyError: 'steps'"),
    ("def format_summary(tables):\n    raise ValueError('no rows')\n", "format_summary raised ValueError: no rows"),
    ("class Boom(BaseException):\n    pass\ndef simulate(config):\n    raise Boom('boom')\n",
     "simulate raised Boom: boom"),
    ("def simulate(config):\n    t = _simulate(config)\n    return {**t, 'robots': t['robots'].append_column("
     "'extra', t['robots'].column('x'))}\n", "simulate returned its table 'robots' with the columns"),
    ("import pyarrow as pa\ndef simulate(config):\n    t = _simulate(config)\n"
     "    return {**t, 'summary': pa.concat_tables([t['summary'], t['summary']])}\n",
     "simulate returned a summary of 2 rows, not one per replicate (1)"),
    ("def describe(config):\n    return 'walk\\n\\x1b[2Jcleared'\n", "describe returned 'walk\\n\\x1b[2Jcleared', not one line"),
    ("def replicates(config):\n    return [1, 2, 3]\n", "replicates returned list, not a range"),
], ids=["simulate-raises", "simulate-list", "simulate-no-summary", "simulate-dicts", "load-none",
        "describe-raises", "format-summary-raises", "simulate-base-exception", "simulate-other-columns",
        "simulate-two-summary-rows", "describe-not-one-line", "replicates-a-list"])
def test_a_hook_that_breaks_the_contract_is_one_line_naming_it(tmp_path, monkeypatch, capsys, hooks, fragment):
    name = plugin(tmp_path, monkeypatch, hooks)
    refused(capsys, ["run", config_file(tmp_path, name), "--out", tmp_path / "out"], f"scenario '{name}': its {fragment}")
    assert not (tmp_path / "out").exists()


def test_the_api_raises_the_hooks_error_in_one_line(tmp_path, monkeypatch):
    name = plugin(tmp_path, monkeypatch, "def simulate(config):\n    return [1, 2]\n")
    with pytest.raises(HookError, match=f"^scenario '{name}': its simulate returned list, not a dict") as raised:
        dronefleet.run(name)
    assert isinstance(raised.value, RuntimeError) and "\n" not in str(raised.value)


REPLAY = ("def replay_data(run_dir):\n    return {}\n"
          "def check_replayable(config):\n    pass\n")


@pytest.mark.parametrize("data, fragment", [
    ("[1, 2]", "replay_data returned list, not a dict with a title (str) and duration_s"),
    ("{'title': 'walk', 'robots': [1]}", "replay_data returned dict, not a dict with a title (str) and duration_s"),
    ("{'title': 'walk', 'duration_s': 1.0, 'robots': {1, 2}}", "replay_data returned data that is not JSON-ready"),
], ids=["list", "no-duration", "set"])
def test_replay_data_that_is_no_page_is_refused_in_one_line(tmp_path, monkeypatch, capsys, data, fragment):
    name = plugin(tmp_path, monkeypatch, REPLAY.replace("return {}", f"return {data}"))
    run = tmp_path / "run"
    assert cli.main(["run", str(config_file(tmp_path, name)), "--out", str(run)]) == 0
    capsys.readouterr()
    refused(capsys, ["replay", run, "--out", tmp_path / "page.html"], f"scenario '{name}': its {fragment}")
    assert not (tmp_path / "page.html").exists()
    assert pq.read_table(run / "summary.parquet").num_rows == 1  # the run itself is kept


def test_a_base_exception_of_a_sweeps_simulate_is_one_failed_run(tmp_path, monkeypatch):
    name = plugin(tmp_path, monkeypatch, "class Boom(BaseException):\n    pass\n" + FIRST_DIES.format("raise Boom('boom')"))
    (tmp_path / "walks.toml").write_text(SWEEP.format(name=name))
    for jobs in ("1", "2"):
        done = dronefleet_process(tmp_path, "sweep", "run", "walks.toml", "--jobs", jobs, "--results", f"res{jobs}")
        assert done.returncode == 1 and "Traceback" not in done.stderr, done.stderr
        assert "its simulate raised Boom: boom" in done.stderr and "1 failed" in done.stdout + done.stderr, done.stderr


THREAD = "import threading, time\nthreading.Thread(target=lambda: time.sleep(3600)).start()\n"


def test_a_plugin_whose_import_starts_a_thread_that_never_ends_does_not_hold_the_command(tmp_path, monkeypatch):
    # its contained simulate's worker cannot end by itself: the command kills it once it has the tables
    name = plugin(tmp_path, monkeypatch, THREAD)
    done = dronefleet_process(tmp_path, "run", config_file(tmp_path, name), "--out", "out")
    assert done.returncode == 0, done.stderr
    assert (tmp_path / "out" / "summary.parquet").is_file()
    (tmp_path / "walks.toml").write_text(SWEEP.format(name=name))
    done = dronefleet_process(tmp_path, "sweep", "run", "walks.toml", "--jobs", "2", "--results", "res")
    assert done.returncode == 0, done.stderr


def test_an_import_that_changes_the_working_directory_has_it_changed_back(tmp_path, monkeypatch):
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    name = plugin(tmp_path, monkeypatch, f"import os\nos.chdir({str(elsewhere)!r})\n")
    done = dronefleet_process(tmp_path, "run", config_file(tmp_path, name), "--out", "out")
    assert done.returncode == 0, done.stderr
    assert (tmp_path / "out" / "summary.parquet").is_file() and not (elsewhere / "out").exists()
    assert "changed the working directory on import" in done.stderr


@pytest.mark.parametrize("label", ["../../escaped", "sub/dir", "", "a\\nb"])
def test_a_label_that_is_no_folder_name_never_places_the_default_run_folder(tmp_path, monkeypatch, capsys, label):
    name = plugin(tmp_path, monkeypatch, f"def label(config):\n    return {label!r}\n")
    monkeypatch.chdir(tmp_path)
    refused(capsys, ["run", config_file(tmp_path, name)], f"scenario '{name}': its label returned")
    assert not (tmp_path / "results").exists() and not (tmp_path.parent / "escaped").exists()
