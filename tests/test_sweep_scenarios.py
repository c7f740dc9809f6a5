"""Sweeps on the scenario contract: every registered scenario through plan, a job-array task,
status, the other runs, collect and the typed dataset; ``[[grid]]`` unions and refused
duplicates; replenishment sweeps interrupted and resumed, refused when their config changed;
replenishment and items sweeps run as job-array tasks and on Dask into the dataset of a local run."""

import json

import distributed
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from conftest import TINY_SWEEPS as TINY
from dronefleet import cli, scenarios, sweeps as sw

ARROW_TYPES = {float: pa.float64(), int: pa.int64(), str: pa.string(), bool: pa.bool_()}


def write(tmp_path, text, name="tiny.toml"):
    path = tmp_path / name
    path.write_text(text)
    return path


def table_files(out, tables):
    """Every table file of a sweep's dataset, by relative path."""
    return {p.relative_to(out): p.read_bytes() for table in tables for p in sorted((out / table).rglob("*.parquet"))}


@pytest.fixture
def no_array(monkeypatch):
    """No scheduler variable from the environment the tests run in (a SLURM job, say)."""
    for name, _ in sw.TASK_VARIABLES:
        monkeypatch.delenv(name, raising=False)


def test_every_registered_scenario_has_a_tiny_sweep_here():
    assert set(TINY) == set(scenarios.SCENARIOS)


@pytest.mark.parametrize("name", sorted(scenarios.SCENARIOS))
def test_a_sweep_of_every_scenario_plans_runs_resumes_and_collects(name, tmp_path, monkeypatch, capsys, no_array):
    scenario = scenarios.SCENARIOS[name]
    path = write(tmp_path, TINY[name])
    s = sw.load_sweep(path)
    assert s.scenario is scenario and len(s.runs) == 4 and s.n_tasks == 2
    keys = s.runs[0].keys
    # the grid's keys, sorted, then the root seed's partition (none for replenishment, which has no seed)
    seed = () if scenario.seed_key is None else (sw.partition_name(scenario, scenario.seed_key),)
    assert keys == (*sorted(s.grid), *seed) and list(s.grid) == sorted(s.grid)
    assert seed != ("seed",) or not any("seed" in schema.names for schema in scenario.table_schemas().values()
                                        if hasattr(scenario.module, "replicates"))
    assert len({run.partition for run in s.runs}) == 4
    for run in s.runs:  # the contract: key resolution, values, validated replacement
        config_keys = [sw.config_key(scenario, k) for k in keys]
        assert all(scenario.resolve_key(f"{scenario.schema[k].section}.{k}") == k for k in config_keys)
        assert scenario.replace(run.config, {}) == run.config
        assert type(run.value(keys[-1])) is type(scenario.defaults[config_keys[-1]])
    results = tmp_path / "results"
    out = results / "tiny"

    assert cli.main(["sweep", "plan", str(path), "--results", str(results)]) == 0
    assert "#SBATCH --array=0-1\n" in (out / "tiny.sbatch").read_text()
    monkeypatch.setenv("SLURM_ARRAY_TASK_ID", "1")          # a job-array task: the last two runs
    assert cli.main(["sweep", "run", str(path), "--results", str(results)]) == 0
    assert "task 1: 2 runs on 1 process" in capsys.readouterr().out
    assert [sw.state(run, out) for run in s.runs] == ["missing"] * 2 + ["done"] * 2
    for run in s.task(1):
        for table in scenario.tables:
            file = run.path(out, table)
            assert scenario.read_config(file) == run.config
            assert not set(keys) & set(pq.read_schema(file).names)  # values come back from the path
    assert cli.main(["sweep", "status", str(path), "--results", str(results)]) == 1
    assert "2 done, 2 missing, 0 failed" in capsys.readouterr().out

    monkeypatch.delenv("SLURM_ARRAY_TASK_ID")
    assert cli.main(["sweep", "run", str(path), "--results", str(results), "--jobs", "2"]) == 0
    assert "ran 2, skipped 2 done before, 0 failed" in capsys.readouterr().out
    assert cli.main(["sweep", "status", str(path), "--results", str(results)]) == 0
    assert json.loads((out / "_layout.json").read_text()) == {"keys": list(keys), "scenario": name}

    assert cli.main(["sweep", "collect", str(path), "--results", str(results)]) == 0
    assert "4 of 4 runs" in capsys.readouterr().out
    collected = pq.read_table(out / "collected.parquet")
    summaries = [pq.read_table(run.path(out, "summary")) for run in s.runs]
    assert collected.column_names == [*keys, *summaries[0].column_names]
    assert collected.num_rows == sum(t.num_rows for t in summaries)
    for key in keys:
        assert collected.schema.field(key).type == ARROW_TYPES[type(scenario.defaults[sw.config_key(scenario, key)])]
    assert collected.column(keys[-1]).to_pylist() == [run.value(keys[-1]) for run, t in zip(s.runs, summaries)
                                                      for _ in range(t.num_rows)]
    for table in scenario.tables:
        data = sw.dataset(s, out, table).to_table()
        assert data.num_rows == sum(pq.read_metadata(run.path(out, table)).num_rows for run in s.runs)
        for key in keys:
            assert data.schema.field(key).type == ARROW_TYPES[type(scenario.defaults[sw.config_key(scenario, key)])]


# ---------------------------------------------------------------------------- [[grid]] unions


UNION = """
[sweep]
seeds = [0]
[set]
horizon_weeks = 0.02
[[grid]]
tau_minutes = [30.0, 15.0]
rule = ["random", "least_confident"]
[[grid]]
rule = ["most_confident"]
"""


def test_grid_tables_give_the_union_of_their_products_in_file_order(tmp_path):
    s = sw.load_sweep(write(tmp_path, UNION))
    # each table's product in its own key order (the first varies slowest), tables in file order
    assert [(r.config.tau_minutes, r.config.rule) for r in s.runs] == [
        (30.0, "random"), (30.0, "least_confident"), (15.0, "random"), (15.0, "least_confident"),
        (15.0, "most_confident")]  # a key the table does not name keeps the base's value
    assert s.runs[0].keys == ("rule", "tau_minutes", "seed")  # the sorted union, then the seed key
    assert s.grid == {"rule": ("random", "least_confident", "most_confident"), "tau_minutes": (30.0, 15.0)}
    assert s.describe() == "(2 tau_minutes x 2 rule + 1 point) x 1 seed = 5 runs"
    # [grid] stays one product with its keys sorted (rule varies slowest): the same runs in another order
    one = sw.load_sweep(write(tmp_path, UNION.replace("[[grid]]", "[grid]", 1).split("[[grid]]")[0], "one.toml"))
    assert [(r.config.rule, r.config.tau_minutes) for r in one.runs] == [
        ("random", 30.0), ("random", 15.0), ("least_confident", 30.0), ("least_confident", 15.0)]
    assert {r.partition for r in one.runs} == {r.partition for r in s.runs[:4]}


def test_replenishment_figures_are_unions_with_the_fixed_strategy_beside_a_mobile_product():
    s = sw.load_sweep(sw.Path(__file__).resolve().parents[1] / "configs" / "sweeps" / "replenishment-fig09.toml")
    assert s.describe() == "(1 point + 7 n_chargers x 5 charger_capacity_factor) = 36 runs"  # no seed to count
    assert s.runs[0].partition == "charger_capacity_factor=2.0/n_chargers=0/strategy=fixed"
    assert [(r.config.params.n_chargers, r.config.params.charger_capacity_factor) for r in s.runs[1:3]] == \
        [(1, 1.0), (1, 1.5)]


@pytest.mark.parametrize("text, fragment", [
    (UNION + "[[grid]]\nrule = ['random']\ntau_minutes = [15.0]\n",
     "[[grid]] 3 at rule = 'random', tau_minutes = 15.0 is the configuration of [[grid]] 1 at tau_minutes = 15.0, "
     "rule = 'random': a sweep runs each configuration once"),
    # the base value, named or not, is the same configuration
    (UNION + "[[grid]]\nrule = ['most_confident']\ntau_minutes = [15]\n", "is the configuration of [[grid]] 2 at"),
    (UNION + "[[grid]]\n", "[[grid]] 3 is empty"),
    (UNION + "[[grid]]\nrule = 'random'\n", "[[grid]] 3: rule must be a list of values"),
    (UNION + "[[grid]]\nrule = ['nope']\n", "[[grid]] 3 at rule = 'nope': auction.rule = 'nope' is not"),
    (UNION.replace("[set]\n", "[set]\nrule = 'random'\n"), "rule is both fixed ([set] or changes) and in [[grid]] 1"),
    (UNION + "[grid]\nrule = ['random']\n", "cannot parse sweep file"),
    ("grid = []\n[sweep]\nseeds = [0]\n", "[[grid]] is empty"),
])
def test_duplicated_or_bad_grid_tables_are_refused(tmp_path, text, fragment):
    with pytest.raises(sw.SweepError) as error:
        sw.load_sweep(write(tmp_path, text))
    assert fragment in str(error.value)


# ---------------------------------------------------------------------------- replenishment seeds


REPLENISHMENT = TINY["replenishment"]


def test_replenishment_has_no_seeds_and_runs_blocks_of_trials_from_a_grid_over_first_trial(tmp_path):
    runs = sw.load_sweep(write(tmp_path, REPLENISHMENT)).runs
    assert {(r.config.first_trial, r.config.last_trial) for r in runs} == {(1, 2)}  # the base's trials
    blocks = sw.load_sweep(write(tmp_path, REPLENISHMENT.replace("n_chargers = [0]", "n_chargers = [0]\n"
                                                                 "first_trial = [1, 3]"))).runs
    assert [(r.config.first_trial, r.partition) for r in blocks[:2]] == \
        [(1, "first_trial=1/n_chargers=0/strategy=fixed"), (3, "first_trial=3/n_chargers=0/strategy=fixed")]
    for seeds in ("[1, 3]", "{ start = 1, count = 2 }"):  # "seed" means the root seed, which it has not
        with pytest.raises(sw.SweepError, match=r"tiny.toml: \[sweep\] seeds does not apply to a replenishment run, "
                                                "which has no root seed: .*choose them with first_trial"):
            sw.load_sweep(write(tmp_path, REPLENISHMENT.replace("runs_per_task", f"seeds = {seeds}\nruns_per_task")))


def test_the_scenario_comes_from_the_base_or_the_sweep_and_they_must_agree(tmp_path):
    (tmp_path / "base.toml").write_text('scenario = "replenishment"\n[run]\nfirst_trial = 5\n')
    text = REPLENISHMENT.replace('scenario = "replenishment"', 'base = "base.toml"')
    s = sw.load_sweep(write(tmp_path, text))
    assert s.scenario.name == "replenishment" and {r.config.first_trial for r in s.runs} == {5}
    (tmp_path / "delivery.toml").write_text("[fleet]\nn_uavs = 3\n")
    with pytest.raises(sw.SweepError, match="scenario = 'replenishment', but the base .* is a delivery config"):
        sw.load_sweep(write(tmp_path, REPLENISHMENT.replace("[sweep]\n", '[sweep]\nbase = "delivery.toml"\n')))


# ---------------------------------------------------------------------------- resuming, refusing, Dask


def test_an_interrupted_replenishment_sweep_resumes_without_redoing_done_runs(tmp_path, monkeypatch, capsys,
                                                                              no_array):
    path = write(tmp_path, REPLENISHMENT)
    s = sw.load_sweep(path)
    tables = s.scenario.tables
    real, started = sw.execute, []

    def interrupted(run, out):  # Ctrl-C while the third run is running
        started.append(run)
        if len(started) == 3:
            raise KeyboardInterrupt
        return real(run, out)

    monkeypatch.setattr(sw, "execute", interrupted)
    killed, clean = tmp_path / "killed", tmp_path / "clean"
    assert cli.main(["sweep", "run", str(path), "--results", str(killed), "--jobs", "1"]) == 130
    assert "interrupted; the runs done are kept" in capsys.readouterr().err
    out = killed / "tiny"
    assert [sw.state(run, out) for run in s.runs] == ["done", "done", "missing", "missing"]
    before = {p: (p.stat().st_ino, p.stat().st_mtime_ns) for run in s.runs[:2] for p in
              (run.path(out, t) for t in tables)}
    # what a kill in the middle of the third run can leave: a time series without its summary, a temporary file
    partial = s.runs[2].path(out, "timeseries")
    partial.parent.mkdir(parents=True)
    partial.write_bytes(b"not parquet")
    (partial.parent / ".part-0.parquet.999.tmp").write_bytes(b"half")

    monkeypatch.setattr(sw, "execute", real)
    assert cli.main(["sweep", "run", str(path), "--results", str(killed), "--jobs", "1"]) == 0
    assert "ran 2, skipped 2 done before, 0 failed" in capsys.readouterr().out
    assert {p: (p.stat().st_ino, p.stat().st_mtime_ns) for p in before} == before
    assert cli.main(["sweep", "run", str(path), "--results", str(clean), "--jobs", "1"]) == 0
    assert table_files(out, tables) == table_files(clean / "tiny", tables)
    assert len(pd.read_parquet(out / "timeseries")) == len(pd.read_parquet(clean / "tiny" / "timeseries"))


def test_a_replenishment_run_made_with_another_config_is_refused_not_mixed(tmp_path, capsys, no_array):
    path = write(tmp_path, REPLENISHMENT)
    assert cli.main(["sweep", "run", str(path), "--results", str(tmp_path), "--task-id", "0"]) == 0
    changed = write(tmp_path, REPLENISHMENT.replace("ticks = 200", "ticks = 300"))
    for command in ("run", "status", "collect"):
        assert cli.main(["sweep", command, str(changed), "--results", str(tmp_path)]) == 2
        err = capsys.readouterr().err
        assert len(err.splitlines()) == 1 and "was made with another config (ticks 200 vs 300)" in err


@pytest.mark.parametrize("name", ["replenishment", "items", "lunar"])  # delivery's: test_sweep.py (smoke.toml)
def test_job_array_tasks_and_dask_write_the_dataset_of_a_local_run(name, tmp_path, monkeypatch, capsys, no_array):
    path = write(tmp_path, TINY[name])
    tables = scenarios.SCENARIOS[name].tables
    assert cli.main(["sweep", "run", str(path), "--results", str(tmp_path / "local"), "--jobs", "1"]) == 0
    for task in ("0", "1"):  # what the job array's script runs, task by task
        monkeypatch.setenv("SLURM_ARRAY_TASK_ID", task)
        assert cli.main(["sweep", "run", str(path), "--results", str(tmp_path / "array")]) == 0
    monkeypatch.delenv("SLURM_ARRAY_TASK_ID")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                                  dashboard_address=None) as cluster:
        assert cli.main(["sweep", "run", str(path), "--results", str(tmp_path / "dask"), "--executor", "dask",
                         "--scheduler", cluster.scheduler_address]) == 0
    local = tmp_path / "local" / "tiny"
    files = table_files(local, tables)
    assert len(files) == len(tables) * 4
    for results in ("local", "array", "dask"):
        assert cli.main(["sweep", "collect", str(path), "--results", str(tmp_path / results)]) == 0
        out = tmp_path / results / "tiny"
        assert table_files(out, tables) == files
        assert (out / "collected.parquet").read_bytes() == (local / "collected.parquet").read_bytes()
    assert len(pd.read_parquet(local / "collected.parquet")) == 4 * 2  # a row per trial
