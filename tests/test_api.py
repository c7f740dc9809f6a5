"""The Python API (``dronefleet.run``, ``dronefleet.sweep``): the README's examples run, a saved
run is the CLI's run folder byte for byte, overrides reach the config, a sweep's rows are the
single runs' summaries, and bad arguments are one-line ValueErrors before any work."""

import doctest
import itertools
import json
import re
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest

import dronefleet
from dronefleet import api, cli, scenarios
from dronefleet.config import ConfigError
from dronefleet.outputs import OutputError

ROOT = Path(__file__).resolve().parents[1]
REPLENISHMENT = ROOT / "configs" / "replenishment.toml"
#: A delivery run of a few seconds of work, and a replenishment one.
TINY = {"delivery": {"horizon_weeks": 0.05, "n_uavs": 5}, "replenishment": {"trials": 2, "ticks": 300}}


def api_examples():
    """``{"file, example N": code}``: the ```python blocks of the README and the docs that call the
    API (``dronefleet.run(`` or ``dronefleet.sweep(``; other blocks hold fragments)."""
    found = {}
    for path in [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]:
        blocks = re.findall(r"^```python\n(.*?)^```", path.read_text(encoding="utf-8"), re.MULTILINE | re.DOTALL)
        calling = [code for code in blocks if "dronefleet.run(" in code or "dronefleet.sweep(" in code]
        found.update({f"{path.relative_to(ROOT)}, example {n}": code for n, code in enumerate(calling, start=1)})
    return found


def test_the_readme_has_python_examples_of_run_and_sweep():
    code = "\n".join(api_examples().values())
    assert "dronefleet.run(" in code and "dronefleet.sweep(" in code and '"replenishment"' in code


def run_python(how, code, folder):
    """Python on ``code`` as a user runs it, from ``folder``: ``how`` is "script" (``python
    script.py``), "stdin" (``python - < script.py``) or "-c" (``python -c CODE``)."""
    script = folder / "script.py"
    script.write_text(code, encoding="utf-8")
    command = {"script": [sys.executable, script.name], "stdin": [sys.executable, "-"],
               "-c": [sys.executable, "-c", code]}[how]
    with script.open("rb") as stdin:
        return subprocess.run(command, cwd=folder, stdin=stdin if how == "stdin" else subprocess.DEVNULL,
                              capture_output=True, text=True, timeout=900, check=False)


def sweeping(examples):
    """The examples that run a sweep, which starts worker processes."""
    return [name for name, code in examples.items() if "dronefleet.sweep(" in code]


# Real interpreters, unguarded scripts (no `if __name__ == "__main__":`), as the README shows
# them: a sweep's workers are other processes, which an exec in this one does not show.
@pytest.mark.parametrize("how, name", [*(("script", name) for name in api_examples()),
                                       ("stdin", sweeping(api_examples())[0]), ("-c", sweeping(api_examples())[0])])
def test_the_python_examples_of_the_readme_and_docs_run_as_scripts(how, name, tmp_path):
    done = run_python(how, api_examples()[name], tmp_path)  # what an example saves lands in tmp_path
    assert done.returncode == 0, done.stderr
    assert done.stdout  # each example prints what it shows


#: A sweep on worker processes, from a script whose lines outside any guard say when they run.
SCRIPT = """
print("the script's top level runs")
import dronefleet

def main():
    table = dronefleet.sweep({"rule": ["least_confident", "random"]}, seeds=[0, 1], jobs=2,
                             set={"horizon_weeks": 0.05, "n_uavs": 5})
    print(len(table), "rows")
"""


@pytest.mark.parametrize("guard", ["", 'if __name__ == "__main__":\n    '], ids=["unguarded", "guarded"])
def test_sweep_workers_never_run_the_callers_script(guard, tmp_path):
    done = run_python("script", f"{SCRIPT}\n{guard}main()\n", tmp_path)
    assert done.returncode == 0, done.stderr
    assert done.stdout.splitlines() == ["the script's top level runs", "4 rows"]  # once: in no worker


def test_the_docstring_examples_run():
    assert doctest.testmod(api).failed == 0


def files(folder):
    return {path.name: path.read_bytes() for path in sorted(Path(folder).iterdir())}


@pytest.mark.parametrize("cli_args, config, changes", [
    (["--seed", "4", "--set", "horizon_weeks=0.05", "--set", "n_uavs=5", "--set", "auction.rule=random"],
     None, {"seed": 4, "set": {"auction.rule": "random"}, **TINY["delivery"]}),
    ([str(REPLENISHMENT), "--set", "trials=2", "--set", "ticks=300", "--set", "first_trial=3"],
     REPLENISHMENT, {"first_trial": 3, **TINY["replenishment"]}),
], ids=["delivery", "replenishment"])
def test_a_saved_run_is_the_clis_run_folder_byte_for_byte(tmp_path, capsys, cli_args, config, changes):
    assert cli.main(["run", *cli_args, "--out", str(tmp_path / "cli")]) == 0
    saved = dronefleet.run(config, **changes).save(tmp_path / "api")
    assert saved == tmp_path / "api"
    assert files(tmp_path / "api") == files(tmp_path / "cli")
    assert len(files(tmp_path / "cli")) == len(scenarios.scenario_of(config).tables)


def test_save_refuses_a_run_folder_unless_overwrite(tmp_path):
    r = dronefleet.run(**TINY["delivery"])
    r.save(tmp_path / "run")
    with pytest.raises(OutputError, match="holds a complete run"):
        r.save(tmp_path / "run")
    r.save(tmp_path / "run", overwrite=True)
    assert set(files(tmp_path / "run")) == {f"{name}.parquet" for name in r.arrow}
    # in a sweep's dataset the run would be read as rows of the sweep
    (tmp_path / "d" / "summary").mkdir(parents=True)
    (tmp_path / "d" / "_layout.json").write_text('{"keys": ["seed"], "scenario": "delivery"}')
    with pytest.raises(OutputError, match="lies in the sweep dataset"):
        r.save(tmp_path / "d" / "summary" / "seed=7")
    assert list((tmp_path / "d" / "summary").iterdir()) == []


def test_overrides_the_seed_and_set_reach_the_config():
    r = dronefleet.run(seed=3, tau_minutes=20, set={"auction.rule": "random", "fleet.n_uavs": 5}, horizon_weeks=0.05)
    delivery = scenarios.SCENARIOS["delivery"]
    assert r.config == delivery.load(None, ["tau_minutes=20", "auction.rule=random", "n_uavs=5",
                                            "horizon_weeks=0.05"], seed=3)
    assert r.summary.loc[0, ["seed", "rule", "tau_minutes", "n_uavs"]].tolist() == [3, "random", 20.0, 5]
    assert r.summary.equals(r.tables["summary"]) and r.summary is r.summary  # converted once


def test_a_replenishment_run_has_its_own_tables_and_trials():
    r = dronefleet.run("replenishment", first_trial=5, strategy="fixed", n_chargers=0, **TINY["replenishment"])
    assert r.scenario.name == "replenishment" and (r.config.first_trial, r.config.params.mobile) == (5, False)
    assert set(r.tables) == {"summary", "timeseries"}
    assert r.summary.trial.tolist() == [5, 6]
    with pytest.raises(AttributeError, match="no attribute .orders.; its tables: summary, timeseries"):
        _ = r.orders


def test_sweep_rows_are_the_single_runs_summaries():
    table = dronefleet.sweep({"rule": ["least_confident", "random"], "tau_minutes": [15, 30]}, seeds=[0, 1],
                             set=TINY["delivery"], jobs=1)
    assert isinstance(table, pd.DataFrame) and len(table) == 8
    assert table[["rule", "tau_minutes", "seed"]].values.tolist()[:3] == [
        ["least_confident", 15.0, 0], ["least_confident", 15.0, 1], ["least_confident", 30.0, 0]]
    for i, row in table.iterrows():
        single = dronefleet.run(seed=row.seed, rule=row.rule, tau_minutes=row.tau_minutes, **TINY["delivery"]).summary
        pd.testing.assert_frame_equal(table.loc[[i], single.columns].reset_index(drop=True), single)

def test_a_replenishment_sweep_has_a_row_per_trial_of_each_run():
    table = dronefleet.sweep([{"strategy": ["fixed"], "n_chargers": [0]}, {"strategy": ["mobile"], "n_chargers": [2]}],
                             base=REPLENISHMENT, set=TINY["replenishment"], jobs=1)
    assert "first_trial" not in table  # no seed: a configuration is one run, told apart by the grid alone
    assert table[["strategy", "n_chargers", "trial"]].values.tolist() == [
        ["fixed", 0, 1], ["fixed", 0, 2], ["mobile", 2, 1], ["mobile", 2, 2]]
    single = dronefleet.run(REPLENISHMENT, strategy="mobile", n_chargers=2, **TINY["replenishment"]).summary
    pd.testing.assert_frame_equal(table[single.columns].iloc[2:].reset_index(drop=True), single)


def test_a_sweep_keeps_its_dataset_in_out_and_reuses_its_done_runs(tmp_path):
    out = tmp_path / "mine"
    grid = {"rule": ["least_confident", "random"]}
    table = dronefleet.sweep(grid, seeds=[0], set=TINY["delivery"], jobs=1, out=out)
    pd.testing.assert_frame_equal(table, pd.read_parquet(out / "collected.parquet"))
    for name in scenarios.get("delivery").tables:  # a table each, partitioned as the CLI's sweeps
        assert (out / name / "rule=random" / "seed=0" / "part-0.parquet").is_file()
    orders = pd.read_parquet(out / "orders")
    assert set(orders["rule"]) == {"least_confident", "random"}
    done = {path: path.stat().st_mtime_ns for path in out.rglob("part-0.parquet")}
    again = dronefleet.sweep(grid, seeds=[0], set=TINY["delivery"], jobs=1, out=out)
    pd.testing.assert_frame_equal(again, table)
    assert {path: path.stat().st_mtime_ns for path in out.rglob("part-0.parquet")} == done  # not run again


@pytest.mark.parametrize("other", ["file", "layout"])
def test_a_sweep_refuses_an_out_that_cannot_take_its_dataset_before_any_run(other, tmp_path):
    out = tmp_path / "mine"
    if other == "file":
        out.write_text("mine")
    else:  # a dataset of other keys
        dronefleet.sweep({"tau_minutes": [15]}, seeds=[0], set=TINY["delivery"], jobs=1, out=out)
    before = sorted(tmp_path.rglob("*"))
    with pytest.raises(ConfigError) as refused:
        dronefleet.sweep({"rule": ["random"]}, seeds=[0], set=TINY["delivery"], jobs=1, out=out)
    assert str(out) in str(refused.value) and "\n" not in str(refused.value)
    assert sorted(tmp_path.rglob("*")) == before


@pytest.mark.parametrize("call, message", [
    (lambda: dronefleet.run(tau_minute=20), r"unknown key 'tau_minute' \(did you mean 'tau_minutes'\?\)"),
    (lambda: dronefleet.run(3), r"config=3: expected None, a scenario name \('delivery', 'replenishment', 'items', 'lunar'\)"),
    (lambda: dronefleet.run("no-such-config.toml"), r"cannot read config file 'no-such-config.toml'"),
    (lambda: dronefleet.run(tau_minutes=-1), r"orders.tau_minutes = -1 is out of range: allowed \(0, 1.008e\+07\]"),
    (lambda: dronefleet.run(rule=5), r"auction.rule must be a string, got int 5"),
    (lambda: dronefleet.run(seed=-1), r"run.seed = -1 is out of range"),
    (lambda: dronefleet.run(set=["tau_minutes=20"]), r"set=\['tau_minutes=20'\]: expected a dict"),
    (lambda: dronefleet.run(set={"orders.tau_minutes": 20}, tau_minutes=25), r"tau_minutes is given twice"),
    (lambda: dronefleet.run(seed=1, set={"run.seed": 2}), r"seed is given twice"),
    (lambda: dronefleet.run(set={1: 2}), r"config key 1 is not a string"),
    (lambda: dronefleet.run("replenishment", seed=0), r"^seed=0 does not apply to a replenishment run, which has "
                                                      r"no root seed: .*first_trial \(from 1\) and trials$"),
    (lambda: dronefleet.run("replenishment", first_trial=0), r"run.first_trial = 0 is out of range"),
    (lambda: dronefleet.sweep({}, seeds=[0]), r"\[grid\] is empty"),
    (lambda: dronefleet.sweep("rule", seeds=[0]), r"grid='rule': expected a dict of config keys to lists"),
    (lambda: dronefleet.sweep({"rule": "random"}, seeds=[0]), r"rule must be a list of values"),
    (lambda: dronefleet.sweep({"rule": ["random"]}), r"seeds: give a non-empty list"),
    (lambda: dronefleet.sweep({"rule": ["random"]}, seeds=5), r"seeds=5: expected a list of integers"),
    (lambda: dronefleet.sweep({"rule": ["random"]}, seeds=[0, 0]), r"seed 0 is listed more than once"),
    (lambda: dronefleet.sweep({"rule": ["random"]}, seeds=[0], jobs=0), r"jobs=0: expected an integer >= 1"),
    (lambda: dronefleet.sweep({"rule": ["random"]}, seeds=[0], set={"rule": "random"}), r"rule is both fixed"),
    (lambda: dronefleet.sweep({"rule": ["random"]}, base="replenishment"), r"unknown key 'rule'"),
    (lambda: dronefleet.sweep({"strategy": ["fixed"]}, seeds=[0, 1], base="replenishment"),
     r"^seeds=\[0, 1\] does not apply to a replenishment run, which has no root seed"),
    (lambda: dronefleet.sweep({"n_uavs": [0]}, seeds=[0]), r"\[grid\] at n_uavs = 0: .*n_uavs"),
    (lambda: dronefleet.sweep({"rule": ["random"]}, seeds=[0], out=3), r"out=3: expected the path of a folder"),
    # sizes the CLI's cap refuses are refused here too, and before a list of them is built
    (lambda: dronefleet.sweep({"rule": ["random"]}, seeds=range(10**12)),
     r"seeds=range\(0, 1000000000000\): more than 100,000 seeds; a sweep may hold at most 100,000 runs"),
    (lambda: dronefleet.sweep({"rule": ["random"]}, seeds=itertools.count()), r"seeds=count\(0\): more than"),
    (lambda: dronefleet.sweep({"tau_minutes": range(1, 10**12)}, seeds=[0]),
     r"grid\['tau_minutes'\]=range\(1, 1000000000000\): more than 100,000 values"),
], ids=lambda value: None if callable(value) else "")
def test_bad_arguments_are_one_line_value_errors_before_any_work(call, message):
    with pytest.raises(ConfigError, match=message) as refused:
        call()
    assert isinstance(refused.value, ValueError) and "\n" not in str(refused.value)


def test_dronefleet_sweep_is_the_api_function_whatever_is_imported_after():
    import dronefleet.sweeps  # the machinery has a name of its own, which cannot rebind dronefleet.sweep
    from dronefleet import api, sweep

    assert sweep is api.sweep and dronefleet.sweep is api.sweep


_PROBE = """
import json, sys
import dronefleet
loaded = lambda: [m for m in ("numpy", "pandas", "pyarrow") if m in sys.modules]
imported = loaded()
r = dronefleet.run(horizon_weeks=0.05, n_uavs=5)
ran = loaded()
r.summary
print(json.dumps([imported, ran, loaded()]))
"""


def test_import_loads_no_numerical_library_and_a_run_no_pandas_until_a_table_is_read():
    proc = subprocess.run([sys.executable, "-c", _PROBE], capture_output=True, text=True, timeout=600, check=False)
    assert proc.returncode == 0, proc.stderr
    assert json.loads(proc.stdout.splitlines()[-1]) == [[], ["numpy", "pyarrow"], ["numpy", "pandas", "pyarrow"]]


#: A sweep whose winner rule is defined in the script itself, on worker processes.
RULE_IN_SCRIPT = """
from numba import njit
import dronefleet

@njit(cache=False)
def fullest(f, w_norm, soc, theta, rng):
    return f >= 0.0, soc

fullest.bids_on = "policy"
try:
    dronefleet.sweep({"rule": ["least_confident", "__main__:fullest"]}, seeds=[0], jobs=2,
                     set={"horizon_weeks": 0.05, "n_uavs": 5})
except dronefleet.config.ConfigError as error:
    print(error)
"""


@pytest.mark.parametrize("rules", ['"least_confident", "__main__:fullest"', '"__main__:fullest"'],
                         ids=["two-runs", "one-run"])
def test_a_plugin_in_the_calling_script_is_refused_before_a_sweep_with_workers(tmp_path, rules):
    # The workers never run the script: "__main__" there is not it; with jobs > 1 every run runs in a
    # worker, a single one too (so that its death is one failed run). Said before any run, in one line.
    done = run_python("script", RULE_IN_SCRIPT.replace('"least_confident", "__main__:fullest"', rules), tmp_path)
    assert done.returncode == 0, done.stderr
    message, = done.stdout.splitlines()
    assert message.startswith("rule='__main__:fullest' ") and "jobs=1" in message


@pytest.mark.parametrize("folder", ["of files", "working directory", "of a summary table"])
def test_a_sweep_never_writes_over_files_it_did_not_write(folder, tmp_path, monkeypatch):
    import pyarrow as pa
    import pyarrow.parquet as pq

    mine = tmp_path / "mine"
    mine.mkdir()
    pq.write_table(pa.table({"mine": [1.5]}), mine / "collected.parquet")
    if folder != "of a summary table":
        (mine / "notes.txt").write_text("mine")
    out = mine
    if folder == "working directory":
        monkeypatch.chdir(mine)
        out = "."
    before = {path: path.read_bytes() for path in mine.iterdir()}
    with pytest.raises(ConfigError) as refused:
        dronefleet.sweep({"rule": ["random"]}, seeds=[0], set=TINY["delivery"], jobs=1, out=out)
    message = str(refused.value)
    assert "\n" not in message and ("notes.txt" in message if folder != "of a summary table" else
                                    "is not a summary table that dronefleet sweep collect wrote" in message), message
    assert {path: path.read_bytes() for path in mine.iterdir()} == before


@pytest.mark.parametrize("out", [5, None, ["a"]])
def test_save_to_something_not_a_path_is_refused_in_one_line(out):
    run = dronefleet.run("replenishment", trials=1, ticks=10)
    with pytest.raises(ConfigError, match=r"^out=.*: expected the path of a folder for the run's tables$"):
        run.save(out)
