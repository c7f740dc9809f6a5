"""The small things of daily use, as a user meets them on the command line and in a ``python file.py``.

Did-you-mean for config names in Python, figure names and values (``algorithm=gr``); a key given
twice refused alike in both interfaces; ``configs show NAME``; CSV export of any table; ``--mem``
and ``--time`` in job scripts; a quick figure marked as such; a sweep on a platform without
signal masks.
"""

import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import pandas as pd
import pytest

ROOT = Path(__file__).resolve().parents[1]


def cli(*args, cwd):
    return subprocess.run([sys.executable, "-m", "dronefleet", *args], cwd=cwd, capture_output=True, text=True,
                          timeout=900, check=False)


def script(tmp_path, body):
    path = tmp_path / "mine.py"
    path.write_text(textwrap.dedent(body))
    return subprocess.run([sys.executable, str(path)], cwd=tmp_path, capture_output=True, text=True, timeout=900,
                          check=False)


def refused(done, *fragments):
    assert done.returncode == 2 and done.stderr.count("\n") == 1, done.stderr
    for fragment in fragments:
        assert fragment in done.stderr


def test_did_you_mean_for_figures_values_and_configs_in_both_interfaces(tmp_path):
    refused(cli("reproduce", "items-fig3", cwd=tmp_path), "'items-fig3' is not a figure (did you mean 'items-fig03'?)")
    assert "fig09, fig10" not in cli("reproduce", "fig13", cwd=tmp_path).stderr  # a suggestion, not the 33 names
    refused(cli("run", "items", "--set", "algorithm=gr", cwd=tmp_path), "(did you mean 'GR'?)")
    refused(cli("run", "lunr", cwd=tmp_path), "(did you mean 'lunar'?)")
    ran = script(tmp_path, """
        import dronefleet
        for config in ("lunr", "item"):
            try:
                dronefleet.run(config)
            except ValueError as error:
                print(error)
    """)
    assert ran.returncode == 0, ran.stderr
    assert ran.stdout.splitlines()[0].startswith("config='lunr' is neither a scenario, a shipped config nor a file "
                                                 "(did you mean 'lunar'?)")
    assert "(did you mean 'items'?)" in ran.stdout.splitlines()[1]


def test_a_key_given_twice_is_refused_alike_on_the_command_line_and_in_python(tmp_path):
    refused(cli("run", "items", "--set", "trials=1", "--set", "run.trials=2", cwd=tmp_path),
            "trials is given twice (as --set trials=1 and as --set run.trials=2): give each key once")
    refused(cli("run", "lunar", "--seed", "3", "--set", "seed=4", cwd=tmp_path),
            "seed is given twice (as --set seed=4 and as --seed 3): give each key once")
    ran = script(tmp_path, """
        import dronefleet
        try:
            dronefleet.run("items", set={"run.trials": 1}, trials=2)
        except ValueError as error:
            print(error)
    """)
    assert ran.stdout.strip() == "trials is given twice (as set['run.trials'] and as trials=2): give each key once"


def test_configs_show_prints_a_shipped_file_to_copy(tmp_path):
    shown = cli("configs", "show", "lunar-e1", cwd=tmp_path)
    assert shown.returncode == 0 and shown.stdout == (ROOT / "configs" / "sweeps" / "lunar-e1.toml").read_text()
    (tmp_path / "mine.toml").write_text(cli("configs", "show", "items", cwd=tmp_path).stdout)
    assert cli("run", "mine.toml", "--set", "trials=1", "--set", "steps=20", "--out", "r", cwd=tmp_path).returncode == 0
    refused(cli("configs", "show", "paperr", cwd=tmp_path), "'paperr' is not a shipped config or sweep file "
                                                             "(did you mean 'paper'?)")


def test_every_table_of_a_run_folder_exports_as_csv_that_reads_back(tmp_path):
    assert cli("run", "items", "--set", "trials=2", "--set", "steps=30", "--out", "run", cwd=tmp_path).returncode == 0
    done = cli("export", "run", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    for table in ("summary", "robots"):
        pd.testing.assert_frame_equal(pd.read_csv(tmp_path / "run-csv" / f"{table}.csv"),
                                      pd.read_parquet(tmp_path / "run" / f"{table}.parquet"), check_dtype=False)
    refused(cli("export", "run", cwd=tmp_path), "--out 'run-csv' is not empty", "--overwrite")
    assert cli("export", "run", "--overwrite", cwd=tmp_path).returncode == 0
    refused(cli("export", "nowhere", cwd=tmp_path), "'nowhere' does not exist")


def test_a_job_script_asks_for_memory_and_says_when_it_has_no_time_limit(tmp_path):
    assert cli("sweep", "plan", "smoke", cwd=tmp_path).returncode == 0
    script_text = (tmp_path / "results" / "smoke" / "smoke.sbatch").read_text()
    assert "#SBATCH --mem=2G\n" in script_text and "# No --time: the partition's default time limit" in script_text
    assert cli("sweep", "plan", "smoke", "--time", "01:00:00", "--mem", "8G", cwd=tmp_path).returncode == 0
    script_text = (tmp_path / "results" / "smoke" / "smoke.sbatch").read_text()
    assert "#SBATCH --mem=8G\n" in script_text and "#SBATCH --time=01:00:00\n" in script_text
    assert "No --time" not in script_text
    refused(cli("sweep", "plan", "smoke", "--mem", "lots", cwd=tmp_path), "--mem 'lots' is not a SLURM memory size")


def test_a_quick_figure_is_marked_and_a_paper_figure_is_not(tmp_path):
    done = cli("reproduce", "items-fig01", "--quick", "--out", "out", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    svg = (tmp_path / "out" / "quick" / "items-fig01" / "items-fig01.svg").read_text()
    assert "QUICK CHECK" in svg and "not the published figure" in svg
    shutil.copytree(ROOT / "results" / "items-fig01", tmp_path / "paper" / "items-fig01")
    assert cli("reproduce", "items-fig01", "--redraw", "--out", "paper", cwd=tmp_path).returncode == 0
    assert "QUICK CHECK" not in (tmp_path / "paper" / "items-fig01" / "items-fig01.svg").read_text()


@pytest.mark.skipif(sys.platform == "win32", reason="the masks are taken away here to stand for such a platform")
def test_a_sweep_runs_on_a_platform_without_signal_masks(tmp_path):
    ran = script(tmp_path, """
        import signal
        del signal.pthread_sigmask  # as on Windows
        import dronefleet
        table = dronefleet.sweep({"rule": ["least_confident", "random"]}, seeds=[0], jobs=2,
                                 set={"horizon_weeks": 0.02, "n_uavs": 3})
        print(len(table))
    """)
    assert ran.returncode == 0, ran.stderr
    assert ran.stdout.strip() == "2"
