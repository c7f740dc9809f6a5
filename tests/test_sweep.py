"""Parameter sweeps (dronefleet.sweeps): sweep files, tasks, the dataset, resumption, failures, Dask."""

import io
import json
import logging
import multiprocessing
import os
import shutil
import signal
import subprocess
import sys
import time
from functools import partial
from pathlib import Path
from urllib.parse import unquote

import dask
import distributed
import duckdb
import pandas as pd
import pyarrow.dataset as ds
import pyarrow.parquet as pq
import pytest

from dronefleet import cli, console, scenarios, sweeps as sw
from dronefleet.delivery import simulation
from dronefleet.delivery.config import default_config, replace
from dronefleet.delivery.records import TABLES

CONFIGS = Path(__file__).resolve().parents[1] / "configs"
SMOKE = CONFIGS / "sweeps" / "smoke.toml"
GRID = ("rule", "tau_minutes", "seed")


def write(tmp_path, text, name="s.toml"):
    path = tmp_path / name
    path.write_text(text)
    return path


def parquet_bytes(out):
    """Every table file of a sweep's dataset, by relative path."""
    return {p.relative_to(out): p.read_bytes() for table in TABLES for p in sorted((out / table).rglob("*.parquet"))}


@pytest.fixture(scope="module")
def smoke(tmp_path_factory):
    """The smoke sweep run once on two local processes: (sweep, dataset directory)."""
    results = tmp_path_factory.mktemp("results")
    assert cli.main(["sweep", "run", str(SMOKE), "--results", str(results), "--jobs", "2"]) == 0
    return sw.load_sweep(SMOKE), results / "smoke"


# ---------------------------------------------------------------------------- sweep files


def test_the_rules_sweep_is_figure_16s_grid_in_a_fixed_order():
    s = sw.load_sweep(CONFIGS / "sweeps" / "rules.toml")
    assert (s.name, len(s.runs), s.runs_per_task, s.n_tasks) == ("rules", 360, 10, 36)
    assert s.describe() == "3 rule x 6 tau_minutes x 20 seeds = 360 runs"
    assert s.grid == {"rule": ("least_confident", "most_confident", "random"),
                      "tau_minutes": (15.0, 20.0, 25.0, 30.0, 35.0, 40.0)}
    # grid product in key order, seeds innermost
    assert [r.partition for r in s.runs[:2]] == ["rule=least_confident/tau_minutes=15.0/seed=0",
                                                 "rule=least_confident/tau_minutes=15.0/seed=1"]
    assert s.runs[20].partition == "rule=least_confident/tau_minutes=20.0/seed=0"
    assert s.runs[-1].partition == "rule=random/tau_minutes=40.0/seed=19"
    paper = default_config()
    assert s.runs[-1].config == replace(paper, rule="random", tau_minutes=40.0, seed=19)
    assert s.task(35) == s.runs[350:]


def test_keys_as_section_key_dotted_or_bare_and_base_relative_to_the_file(tmp_path):
    (tmp_path / "configs").mkdir()
    (tmp_path / "configs" / "base.toml").write_text("[fleet]\nn_uavs = 7\n")
    path = write(tmp_path / "configs", '[sweep]\nbase = "base.toml"\nseeds = [4]\n[set]\n"energy.xi" = 0.25\n'
                 '[grid]\nauction.rule = ["random"]\ntau_minutes = [20]\n', name="mine.toml")
    s = sw.load_sweep(path)
    assert s.name == "mine" and s.runs_per_task == 10
    (run,) = s.runs
    assert (run.config.n_uavs, run.config.xi, run.config.rule, run.config.tau_minutes, run.config.seed) == \
        (7, 0.25, "random", 20.0, 4)
    assert run.partition == "rule=random/tau_minutes=20.0/seed=4"


GOOD = '[sweep]\nseeds = [0, 1]\n[grid]\nrule = ["least_confident", "random"]\n'


def test_changes_and_seeds_make_a_variant_of_a_sweep_file():
    s = sw.load_sweep(SMOKE, changes={"horizon_weeks": 2.0, "fleet.n_uavs": 5}, seeds=[7])
    assert s.seeds == (7,) and len(s.runs) == 4
    assert {(r.config.horizon_weeks, r.config.n_uavs, r.config.seed) for r in s.runs} == {(2.0, 5, 7)}
    with pytest.raises(sw.SweepError, match="tau_minutes is both fixed"):
        sw.load_sweep(SMOKE, changes={"tau_minutes": 20.0})
    with pytest.raises(sw.SweepError, match="changes: unknown key 'horizon'"):
        sw.load_sweep(SMOKE, changes={"horizon": 2.0})


@pytest.mark.parametrize("text, message", [
    (GOOD + "[extra]\nx = 1\n", "unknown key 'extra'. Allowed: sweep, set, grid"),
    (GOOD.replace("[sweep]\n", "[sweep]\nrepeats = 3\n"), "unknown key 'repeats'. Allowed: name, base, seeds"),
    (GOOD + "tau_minute = [15]\n", "unknown key 'tau_minute' (did you mean 'tau_minutes'?)"),
    (GOOD + "[set]\nfleet.speed_m_s = 3\n", "fleet.speed_m_s is not a key of [fleet]; speed_m_s belongs in [energy]"),
    (GOOD + "tau_minutes = []\n", "[grid]: tau_minutes is an empty list"),
    ('[sweep]\nseeds = [0]\n[grid]\n', "[grid] is empty"),
    ('[sweep]\nseeds = [0]\n', "[grid] is empty"),
    (GOOD + "tau_minutes = [15, 15.0]\n", "tau_minutes lists 15.0 more than once"),
    (GOOD + "tau_minutes = 15\n", "tau_minutes must be a list of values, got 15"),
    (GOOD + "seed = [1, 2]\n", "seed cannot be set here"),
    (GOOD + "scaler_mean = [[1, 2, 3]]\n", "scaler_mean holds a list of numbers and cannot be a grid key"),
    (GOOD + "[set]\nrule = 'random'\n", "rule is both fixed ([set] or changes) and in [grid]"),
    (GOOD.replace('"random"]', '"nope"]'),
     "[grid] at rule = 'nope': auction.rule = 'nope' is not a registered winner rule"),
    (GOOD + "tau_minutes = [15, -5]\n", "orders.tau_minutes = -5 is out of range: allowed (0, 1.008e+07]"),
    (GOOD + "soh_min = [0.9]\n[set]\nsoh_max = 0.8\n", "fleet.soh_min = 0.9 must be <= fleet.soh_max = 0.8"),
    (GOOD + "[set]\nn_uavs = 2.5\n", "[set]: fleet.n_uavs must be an integer"),
    (GOOD.replace("seeds = [0, 1]", "seeds = []"), "give a non-empty list"),
    (GOOD.replace("seeds = [0, 1]", "seeds = [0, 0]"), "seed 0 is listed more than once"),
    (GOOD.replace("seeds = [0, 1]", "seeds = [-1]"),
     "[sweep] seeds: run.seed = -1 is out of range: allowed [0, 9223372036854775807]"),
    (GOOD.replace("seeds = [0, 1]", "seeds = [0.5]"), "[sweep] seeds: run.seed must be an integer, got float"),
    (GOOD.replace("seeds = [0, 1]", "seeds = { start = 3 }"), "a range is { start = <integer>, count = <integer >= 1> }"),
    (GOOD.replace("seeds = [0, 1]", "seeds = { start = -2, count = 3 }"), "run.seed = -2 is out of range"),
    (GOOD.replace("seeds = [0, 1]", "seeds = { count = 2, step = 2 }"), "unknown key 'step'"),
    (GOOD.replace("seeds = [0, 1]\n", ""), "give a non-empty list"),
    (GOOD.replace("[sweep]\n", "[sweep]\nname = '../up'\n"), "name = '../up'"),
    (GOOD.replace("[sweep]\n", "[sweep]\nruns_per_task = 0\n"), "runs_per_task must be an integer >= 1"),
    (GOOD.replace("[sweep]\n", "[sweep]\nbase = 'missing.toml'\n"), "cannot read config file"),
    ("[sweep\n", "cannot parse sweep file"),
])
def test_bad_sweep_files_are_refused_before_any_run(tmp_path, capsys, text, message):
    path = write(tmp_path, text)
    with pytest.raises(sw.SweepError) as error:
        sw.load_sweep(path)
    assert message in str(error.value)
    results = tmp_path / "results"
    assert cli.main(["sweep", "run", str(path), "--results", str(results)]) == 2
    assert message in capsys.readouterr().err
    assert not results.exists()


def test_partition_values_round_trip_through_their_text():
    config = replace(default_config(), fleet_file="fleets/a b,{seed}=1%.parquet", tau_minutes=1e-5, horizon_weeks=0.001,
                     seed=12)
    run = sw.Run(config, ("fleet_file", "tau_minutes", "n_uavs", "seed"), scenarios.get("delivery"))
    assert run.partition == "fleet_file=fleets%2Fa%20b%2C%7Bseed%7D%3D1%25.parquet/tau_minutes=1e-05/n_uavs=25/seed=12"
    assert "/" not in run.id and run.id.count(",") == 3
    for segment, key in zip(run.partition.split("/"), run.keys):
        name, _, text = segment.partition("=")
        value = getattr(config, key)
        assert name == key and type(value)(unquote(text)) == value


# ---------------------------------------------------------------------------- tasks and the job script


@pytest.mark.parametrize("variable, index, task", [
    ("SLURM_ARRAY_TASK_ID", "2", 2), ("PBS_ARRAY_INDEX", "0", 0),
    ("SGE_TASK_ID", "3", 2), ("LSB_JOBINDEX", "1", 0),       # SGE and LSF arrays start at 1
    ("SGE_TASK_ID", "undefined", None), ("LSB_JOBINDEX", "0", None),  # set outside array jobs
])
def test_the_task_comes_from_the_schedulers_variable(variable, index, task):
    assert sw.task_from_environment({variable: index}) == task


@pytest.mark.parametrize("variable, index", [("SLURM_ARRAY_TASK_ID", "1"), ("PBS_ARRAY_INDEX", "1"),
                                             ("SGE_TASK_ID", "2"), ("LSB_JOBINDEX", "2")])
def test_sweep_run_in_an_array_job_runs_only_its_task(tmp_path, monkeypatch, capsys, variable, index):
    for name, _ in sw.TASK_VARIABLES:
        monkeypatch.delenv(name, raising=False)
    monkeypatch.setenv(variable, index)
    assert cli.main(["sweep", "run", str(SMOKE), "--results", str(tmp_path)]) == 0
    assert "task 1: 3 runs on 1 process" in capsys.readouterr().out
    s = sw.load_sweep(SMOKE)
    assert [sw.state(run, tmp_path / "smoke") for run in s.runs] == ["missing"] * 3 + ["done"] * 3 + ["missing"] * 2


def test_task_ids_beyond_the_array_are_refused(tmp_path, capsys):
    assert cli.main(["sweep", "run", str(SMOKE), "--results", str(tmp_path), "--task-id", "3"]) == 2
    assert "task 3 does not exist: sweep smoke has 3 tasks, 0-2 (3 runs each)" in capsys.readouterr().err


@pytest.mark.parametrize("option, value", [("--jobs", "0"), ("--task-id", "-1"), ("--jobs", "two")])
def test_counts_on_the_command_line_are_checked(capsys, option, value):
    with pytest.raises(SystemExit) as exit:
        cli.main(["sweep", "run", str(SMOKE), option, value])
    assert exit.value.code == 2 and f"{option}: expected an integer" in capsys.readouterr().err


def test_plan_writes_a_job_array_script(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert cli.main(["sweep", "plan", str(SMOKE), "--time", "00:10:00", "--partition", "short",
                     "--account", "lab"]) == 0
    printed = capsys.readouterr().out
    assert "8 runs, 3 tasks of up to 3 runs" in printed
    script = tmp_path / "results" / "smoke" / "smoke.sbatch"
    assert f"sbatch {script.relative_to(tmp_path)}" in printed
    text = script.read_text()
    results = tmp_path / "results"
    sbatch = [line for line in text.splitlines() if line.startswith("#SBATCH")]
    assert sbatch == ["#SBATCH --job-name=dronefleet-smoke", "#SBATCH --array=0-2", "#SBATCH --cpus-per-task=1",
                      "#SBATCH --mem=2G", f"#SBATCH --output={results}/smoke/_logs/%A_%a.out",
                      "#SBATCH --time=00:10:00",
                      "#SBATCH --partition=short", "#SBATCH --account=lab"]
    assert (results / "smoke" / "_logs").is_dir()  # SLURM does not create it
    assert f"\ncd {tmp_path}\n" in text
    assert f'NUMBA_CACHE_DIR={results}/_numba_cache; fi\nexport NUMBA_CACHE_DIR\n' in text
    assert text.rstrip().endswith(f"exec {sys.executable} -m dronefleet.cli sweep run {SMOKE} "
                                  f"--results {results} --task-id \"$SLURM_ARRAY_TASK_ID\"")
    out = tmp_path / "elsewhere.sh"
    assert cli.main(["sweep", "plan", str(write(tmp_path, GOOD.replace("[sweep]\n", "[sweep]\nruns_per_task = 1\n"))),
                     "--out", str(out)]) == 0
    assert "#SBATCH --array=0-3\n" in out.read_text()


def test_progress_is_a_bar_of_runs_on_a_terminal_only(monkeypatch):
    class Terminal(io.StringIO):
        def isatty(self):
            return True

    drawn, logger = {}, logging.getLogger(console.LOGGER)
    previous = logger.level
    try:
        for name, stream, level in (("terminal", Terminal(), logging.INFO), ("pipe", io.StringIO(), logging.INFO),
                                    ("quiet", Terminal(), logging.WARNING)):
            monkeypatch.setattr(sys, "stderr", stream)
            console.configure(level)
            progress = sw.Progress()
            for finished in range(1, 9):
                progress(finished, 8, finished // 3)
            drawn[name] = stream.getvalue()
    finally:
        logger.setLevel(previous)
    assert "  runs:" in drawn["terminal"] and "/8 " in drawn["terminal"]
    assert drawn["pipe"] == drawn["quiet"] == ""


# ---------------------------------------------------------------------------- the dataset


def test_each_table_reads_as_one_table_with_pandas_pyarrow_and_duckdb(smoke):
    s, out = smoke
    rows = {table: sum(pq.read_metadata(r.path(out, table)).num_rows for r in s.runs) for table in TABLES}
    assert rows["summary"] == len(s.runs) == 8
    for table in TABLES:
        frames = {
            "pandas": pd.read_parquet(out / table),
            "pyarrow": ds.dataset(out / table, partitioning="hive").to_table().to_pandas(),
            "duckdb": duckdb.sql(f"SELECT * FROM read_parquet('{out / table}/**/*.parquet', "
                                 "hive_partitioning = true)").df(),
        }
        for reader, frame in frames.items():
            assert len(frame) == rows[table], (table, reader)
            assert list(frame.columns).count("seed") == 1
            assert set(GRID) <= set(frame.columns), (table, reader)
            assert set(frame.rule.astype(str)) == {"least_confident", "random"}
            assert set(frame.tau_minutes.astype(float)) == {15.0, 30.0}
    typed = sw.dataset(s, out, "summary").to_table().to_pandas()
    assert typed.tau_minutes.dtype == "float64" and typed.seed.dtype == "int64"
    assert sorted(zip(typed.rule, typed.tau_minutes, typed.seed)) == \
        sorted((r.config.rule, r.config.tau_minutes, r.config.seed) for r in s.runs)


def test_the_typed_dataset_holds_only_the_sweeps_done_runs(smoke, tmp_path):
    s, smoke_out = smoke
    out = tmp_path / "smoke"
    shutil.copytree(smoke_out, out)
    cut = sw.load_sweep(SMOKE, seeds=[0])  # the file cut to fewer seeds: seed=1 partitions are not its runs
    killed = cut.runs[1]                    # killed before its summary: its other tables are there
    killed.path(out, "summary").unlink()
    done = [run for run in cut.runs if run != killed]
    for table in ("orders", "summary"):
        frame = sw.dataset(cut, out, table).to_table().to_pandas()
        assert len(frame) == sum(pq.read_metadata(run.path(out, table)).num_rows for run in done)
        assert len(pd.read_parquet(out / table)) > len(frame)  # what a glob of the directory reads
        assert (frame.tau_minutes.dtype, frame.seed.dtype) == ("float64", "int64")
        # the runs' rows, in run order
        keys = list(zip(frame.rule, frame.tau_minutes, frame.seed))
        assert list(dict.fromkeys(keys)) == [(r.config.rule, r.config.tau_minutes, r.config.seed) for r in done]
    for run in cut.runs:
        run.path(out, "summary").unlink(missing_ok=True)
    with pytest.raises(sw.SweepError, match="no run of sweep smoke is done"):
        sw.dataset(cut, out, "orders")


def test_files_are_the_runs_tables_without_the_partition_columns(smoke):
    s, out = smoke
    run = s.runs[5]
    expected = simulation.simulate(run.config)
    from dronefleet.delivery.records import read_config, tables

    for table, data in tables(expected).items():
        path = run.path(out, table)
        assert read_config(path) == run.config
        written = pq.read_table(path)
        kept = [c for c in data.column_names if c not in GRID]
        assert written.column_names == kept
        pd.testing.assert_frame_equal(written.to_pandas(), data.select(kept).to_pandas())


def test_one_process_and_two_write_the_same_bytes(smoke, tmp_path):
    s, out = smoke
    assert cli.main(["sweep", "run", str(SMOKE), "--results", str(tmp_path), "--jobs", "1"]) == 0
    assert parquet_bytes(tmp_path / "smoke") == parquet_bytes(out)
    assert len(parquet_bytes(out)) == len(TABLES) * len(s.runs)


def test_collect_gives_one_row_per_run_with_its_parameters_and_metrics(smoke, capsys):
    s, out = smoke
    assert cli.main(["sweep", "collect", str(SMOKE), "--results", str(out.parent)]) == 0
    assert "8 of 8 runs" in capsys.readouterr().out
    table = pq.read_table(out / "collected.parquet")
    assert table.schema.metadata[b"dronefleet.sweep"] == SMOKE.read_bytes()
    frame = table.to_pandas()
    summary = pq.read_table(s.runs[0].path(out, "summary")).column_names
    assert list(frame.columns) == [*GRID, *summary]
    assert (frame.tau_minutes.dtype, frame.seed.dtype) == ("float64", "int64")
    assert list(zip(frame.rule, frame.tau_minutes, frame.seed)) == \
        [(r.config.rule, r.config.tau_minutes, r.config.seed) for r in s.runs]
    assert (frame.n_uavs == 10).all() and (frame.horizon_weeks == 1.0).all()
    one = pq.read_table(s.runs[3].path(out, "summary")).to_pandas()
    pd.testing.assert_frame_equal(frame.loc[[3], summary].reset_index(drop=True), one)


def test_a_changed_sweep_file_is_refused_not_mixed(smoke, tmp_path, capsys):
    _, out = smoke
    changed = write(tmp_path, SMOKE.read_text().replace("n_uavs = 10", "n_uavs = 11"), name="smoke.toml")
    assert cli.main(["sweep", "run", str(changed), "--results", str(out.parent)]) == 2
    assert "was made with another config (n_uavs 10 vs 11)" in capsys.readouterr().err


# ---------------------------------------------------------------------------- failures, status, resumption


def test_a_run_that_raises_is_recorded_and_the_others_complete(tmp_path, monkeypatch, capsys):
    real = simulation.simulate

    def simulate(config):
        if (config.rule, config.tau_minutes, config.seed) == ("random", 15.0, 1):
            raise ValueError("injected failure")
        return real(config)

    monkeypatch.setattr(simulation, "simulate", simulate)
    args = ["--results", str(tmp_path), "--jobs", "1"]
    assert cli.main(["sweep", "run", str(SMOKE), *args]) == 1
    assert "failed  rule=random/tau_minutes=15.0/seed=1: ValueError: injected failure" in capsys.readouterr().err
    out = tmp_path / "smoke"
    record = json.loads((out / "_failed" / "rule=random,tau_minutes=15.0,seed=1.json").read_text())
    assert record["error"] == "ValueError: injected failure"
    assert 'raise ValueError("injected failure")' in record["traceback"]
    assert record["config"]["auction"]["rule"] == "random"

    assert cli.main(["sweep", "status", str(SMOKE), "--results", str(tmp_path)]) == 1
    printed = capsys.readouterr().out
    assert "8 runs in" in printed and "7 done, 0 missing, 1 failed" in printed
    assert "failed   rule=random/tau_minutes=15.0/seed=1: ValueError: injected failure" in printed
    assert "tasks with runs not done: 1 " in printed  # run 5 of 8, 3 runs per task

    monkeypatch.setattr(simulation, "simulate", real)
    assert cli.main(["sweep", "run", str(SMOKE), *args]) == 0
    assert "ran 1, skipped 7 done before, 0 failed" in capsys.readouterr().out
    assert not (out / "_failed" / "rule=random,tau_minutes=15.0,seed=1.json").exists()
    assert cli.main(["sweep", "status", str(SMOKE), "--results", str(tmp_path)]) == 0
    assert "8 done, 0 missing, 0 failed" in capsys.readouterr().out


CRASH = """
[sweep]
name = "crash"
seeds = [0, 1, 2]
[set]
horizon_weeks = 0.5
[grid]
rule = ["least_confident", "random"]
"""
REAL_EXECUTE = sw.execute


def execute_or_die(crash, delay, run, out):
    """``sweep.execute``, except that the run whose id is ``crash`` kills the worker process
    running it after ``delay`` seconds (as the kernel's OOM killer would). Module-level:
    workers import it by name. Only in a worker: in the sweep's own process, it would kill
    pytest."""
    if run.id == crash and multiprocessing.parent_process() is not None:
        time.sleep(delay)
        os._exit(1)
    return REAL_EXECUTE(run, out)


def test_a_run_that_kills_its_worker_is_recorded_and_the_others_complete(tmp_path, monkeypatch, capsys):
    path = write(tmp_path, CRASH, name="crash.toml")
    args = ["--results", str(tmp_path)]
    # The first run given to a worker: the runs after it go on, on the other worker and on the
    # one that replaces the dead one.
    monkeypatch.setattr(sw, "execute", partial(execute_or_die, "rule=least_confident,seed=1", 0.0))
    assert cli.main(["sweep", "run", str(path), *args, "--jobs", "2"]) == 1
    died = "its worker died (killed, out of memory or crashed) while running it: "  # then the executor's words
    assert "ran 6, skipped 0 done before, 1 failed" in capsys.readouterr().out
    record = json.loads((tmp_path / "crash" / "_failed" / "rule=least_confident,seed=1.json").read_text())
    assert record["error"].startswith(died) and record["config"]["auction"]["rule"] == "least_confident"

    assert cli.main(["sweep", "status", str(path), *args]) == 1
    printed = capsys.readouterr().out
    assert "5 done, 0 missing, 1 failed" in printed and f"failed   rule=least_confident/seed=1: {died}" in printed

    monkeypatch.setattr(sw, "execute", REAL_EXECUTE)
    assert cli.main(["sweep", "run", str(path), *args, "--jobs", "1"]) == 0
    assert "ran 1, skipped 5 done before, 0 failed" in capsys.readouterr().out
    assert not list((tmp_path / "crash" / "_failed").glob("*.json"))


def test_status_of_a_sweep_not_started(tmp_path, capsys):
    assert cli.main(["sweep", "status", str(SMOKE), "--results", str(tmp_path)]) == 1
    printed = capsys.readouterr().out
    assert "0 done, 8 missing, 0 failed" in printed and "tasks with runs not done: 0-2" in printed
    assert cli.main(["sweep", "collect", str(SMOKE), "--results", str(tmp_path)]) == 2
    assert "no run of sweep smoke is done" in capsys.readouterr().err


RESUME = """
[sweep]
name = "resume"
seeds = [0, 1, 2, 3]
[set]
horizon_weeks = 2.0
[grid]
rule = ["least_confident", "random"]
"""


def test_a_killed_sweep_started_again_redoes_only_unfinished_runs(tmp_path, capsys):
    path = write(tmp_path, RESUME, name="resume.toml")
    s = sw.load_sweep(path)
    killed, clean = tmp_path / "killed", tmp_path / "clean"
    # The sweep process SIGKILLs itself as it starts its fourth run (one process, runs in order):
    # a kill half-way, whatever the machine's speed.
    kill_at = s.runs[3].id
    code = ("import os, signal, sys\n"
            "from dronefleet import cli, sweeps\n"
            "real = sweeps.execute\n"
            "def execute(run, out):\n"
            f"    if run.id == {kill_at!r}:\n"
            "        os.kill(os.getpid(), signal.SIGKILL)\n"
            "    return real(run, out)\n"
            "sweeps.execute = execute\n"
            f"sys.exit(cli.main(['sweep', 'run', {str(path)!r}, '--results', {str(killed)!r}, '--jobs', '1']))\n")
    process = subprocess.run([sys.executable, "-c", code], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                             timeout=600)
    assert process.returncode == -signal.SIGKILL
    done = [run for run in s.runs if sw.state(run, killed / "resume") == "done"]
    assert 1 <= len(done) < len(s.runs), "the sweep was not stopped half-way"
    before = {p: (p.stat().st_ino, p.stat().st_mtime_ns)
              for run in done for p in (run.path(killed / "resume", t) for t in TABLES)}
    # What a kill in the middle of the next run can leave: a partial table, a temporary file.
    unfinished = s.runs[len(done)]
    partial = unfinished.path(killed / "resume", "orders")
    partial.parent.mkdir(parents=True, exist_ok=True)
    partial.write_bytes(b"not parquet")
    (partial.parent / ".part-0.parquet.999.tmp").write_bytes(b"half")

    assert cli.main(["sweep", "run", str(path), "--results", str(killed), "--jobs", "1"]) == 0
    assert f"ran {len(s.runs) - len(done)}, skipped {len(done)} done before" in capsys.readouterr().out
    assert {p: (p.stat().st_ino, p.stat().st_mtime_ns) for p in before} == before
    assert cli.main(["sweep", "run", str(path), "--results", str(clean), "--jobs", "1"]) == 0
    assert parquet_bytes(killed / "resume") == parquet_bytes(clean / "resume")
    assert len(parquet_bytes(clean / "resume")) == len(TABLES) * len(s.runs)
    # The leftover temporary file is hidden from readers.
    assert len(pd.read_parquet(killed / "resume" / "orders")) == len(pd.read_parquet(clean / "resume" / "orders"))
    assert len(duckdb.sql(f"SELECT * FROM read_parquet('{killed / 'resume' / 'orders'}/**/*.parquet', "
                          "hive_partitioning = true)").df()) == len(pd.read_parquet(clean / "resume" / "orders"))


def test_a_warm_started_run_is_redone_when_its_fleet_file_is_written_again(smoke, tmp_path, capsys):
    s, smoke_out = smoke
    (tmp_path / "fleets").mkdir()
    for run in s.runs[-2:]:  # the fleets of the smoke runs at rule=random, tau 30, seeds 0 and 1: 10 UAVs
        shutil.copyfile(run.path(smoke_out, "fleet"), tmp_path / "fleets" / f"{run.config.seed}.parquet")
    path = write(tmp_path, f"[sweep]\nname = 'warm'\nseeds = [0, 1]\n[set]\nhorizon_weeks = 0.5\nn_uavs = 10\n"
                           f"fleet_file = '{tmp_path}/fleets/{{seed}}.parquet'\n[grid]\nrule = ['random']\n")
    args = ["--results", str(tmp_path), "--jobs", "1"]
    assert cli.main(["sweep", "run", str(path), *args]) == 0
    warm, out = sw.load_sweep(path), tmp_path / "warm"
    # The fleet of seed 1 written again an hour after its run used it (its sweep was rerun).
    now = time.time()
    os.utime(warm.runs[1].path(out, "summary"), (now - 7200, now - 7200))
    os.utime(tmp_path / "fleets" / "1.parquet", (now - 3600, now - 3600))
    assert [sw.state(run, out) for run in warm.runs] == ["done", "missing"]
    assert sw.dataset(warm, out, "summary").count_rows() == 1
    capsys.readouterr()
    assert cli.main(["sweep", "run", str(path), *args]) == 0
    assert "ran 1, skipped 1 done before, 0 failed" in capsys.readouterr().out
    assert [sw.state(run, out) for run in warm.runs] == ["done", "done"]


# ---------------------------------------------------------------------------- Dask


def test_dask_executor_writes_the_same_dataset(smoke, tmp_path, capsys):
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                                  dashboard_address=None) as cluster:
        assert cli.main(["sweep", "run", str(SMOKE), "--results", str(tmp_path), "--executor", "dask",
                         "--scheduler", cluster.scheduler_address]) == 0
    assert f"on the Dask cluster at {cluster.scheduler_address}" in capsys.readouterr().out
    assert parquet_bytes(tmp_path / "smoke") == parquet_bytes(smoke[1])


def test_a_run_that_kills_its_dask_workers_is_recorded_and_the_others_complete(tmp_path, monkeypatch, capsys):
    path = write(tmp_path, CRASH, name="crash.toml")
    # A moment in: a worker dying at once can take the result of its previous run with it while
    # the client fetches it, which stalls Dask for 30 s.
    monkeypatch.setattr(sw, "execute", partial(execute_or_die, "rule=random,seed=1", 0.5))
    # The scheduler gives a task up at its first worker death (KilledWorker; by default at the
    # fourth): the killer's, and those waiting on the same worker, which fail alike.
    with dask.config.set({"distributed.scheduler.allowed-failures": 0}), \
            distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                                     dashboard_address=None) as cluster:
        assert cli.main(["sweep", "run", str(path), "--results", str(tmp_path), "--executor", "dask",
                         "--scheduler", cluster.scheduler_address]) == 1
    assert cli.main(["sweep", "status", str(path), "--results", str(tmp_path)]) == 1
    printed = capsys.readouterr().out
    died = "its worker died (killed, out of memory or crashed) while running it: KilledWorker: "
    assert f"failed   rule=random/seed=1: {died}" in printed and "0 missing" in printed
    assert all(died in line for line in printed.splitlines() if line.startswith("  failed"))


@pytest.mark.parametrize("args, message", [
    (["--executor", "dask"], "--executor dask runs every run of the sweep on the cluster at --scheduler"),
    (["--executor", "dask", "--scheduler", "tcp://127.0.0.1:1", "--task-id", "0"], "without a task id"),
    (["--scheduler", "tcp://127.0.0.1:1"], "use it with --executor dask"),
])
def test_dask_options_are_checked(tmp_path, capsys, args, message):
    assert cli.main(["sweep", "run", str(SMOKE), "--results", str(tmp_path), *args]) == 2
    assert message in capsys.readouterr().err


def test_without_dask_the_executor_says_what_to_install(tmp_path, monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "distributed", None)  # import distributed -> ImportError
    assert cli.main(["sweep", "run", str(SMOKE), "--results", str(tmp_path), "--executor", "dask",
                     "--scheduler", "tcp://127.0.0.1:1"]) == 2
    assert "pip install 'dronefleet[dask]'" in capsys.readouterr().err


def _worker_pid(item):
    return os.getpid()


def test_local_workers_serve_the_next_call_within_reused_workers_and_end_with_the_block():
    from dronefleet import executors

    def worker_pids():
        return {pid for _, pid, _ in executors.local(_worker_pid, range(6), 2)} - {os.getpid()}

    with executors.reused_workers():
        first, second = worker_pids(), worker_pids()
    assert len(first) == 2 and second == first  # the second call's items went to the same processes
    for pid in first:
        with pytest.raises(ProcessLookupError):  # ended (and reaped) with the block
            os.kill(pid, 0)
    assert not worker_pids() & worker_pids()  # outside the block, each call has workers of its own
