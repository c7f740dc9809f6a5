"""A real SLURM: the job-array script of `sweep plan`, submitted to a one-node cluster on
this machine, writes the very dataset that a local `sweep run` writes, for a delivery, a
replenishment and an items sweep.

Needs Debian's slurm-wlm and munge (`.ci/run` installs them) and root, to start the
daemons; skipped, saying which is missing, otherwise. ``tests/slurm/cluster.sh`` starts
munged, slurmctld and slurmd on localhost (or reuses them if already up from the same
directory), and stops them at the end.
"""

import os
import shutil
import subprocess
import tempfile
from pathlib import Path

import pandas as pd
import pytest

from conftest import TINY_SWEEPS
from dronefleet import cli
from dronefleet.delivery.records import TABLES
from dronefleet.scenarios import SCENARIOS

SMOKE = Path(__file__).resolve().parents[1] / "configs" / "sweeps" / "smoke.toml"
CLUSTER = Path(__file__).resolve().parent / "slurm" / "cluster.sh"
STATE = Path(tempfile.gettempdir()) / "dronefleet-slurm"
SEARCH = f"{os.environ.get('PATH', '')}:/usr/sbin:/sbin"
MISSING = [b for b in ("munged", "slurmctld", "slurmd", "sbatch", "sinfo") if shutil.which(b, path=SEARCH) is None]

pytestmark = [
    pytest.mark.skipif(bool(MISSING), reason=f"SLURM is not installed (no {', '.join(MISSING)}); "
                                             "apt-get install slurm-wlm munge"),
    pytest.mark.skipif(os.geteuid() != 0, reason="starting slurmctld and slurmd needs root"),
]


@pytest.fixture(scope="module")
def slurm():
    """A running one-node cluster: the environment for its clients (SLURM_CONF, PATH)."""
    env = {**os.environ, "SLURM_CONF": str(STATE / "slurm.conf"), "PATH": SEARCH}
    try:
        started = subprocess.run(["bash", str(CLUSTER), "start", str(STATE)], capture_output=True, text=True,
                                 timeout=120)
        assert started.returncode == 0, f"the SLURM cluster did not start:\n{started.stdout}{started.stderr}"
        yield env
    finally:
        subprocess.run(["bash", str(CLUSTER), "stop", str(STATE)], timeout=120)


def table_files(out, tables=TABLES):
    return {p.relative_to(out): p.read_bytes() for table in tables for p in sorted((out / table).rglob("*.parquet"))}


def submit(slurm, out):
    """``sbatch --wait`` the job-array script that `sweep plan` wrote into the dataset ``out``;
    its tasks' logs, after asserting that the array succeeded."""
    try:
        job = subprocess.run(["sbatch", "--wait", str(out / f"{out.name}.sbatch")], env=slurm, capture_output=True,
                             text=True, timeout=600)
    except subprocess.TimeoutExpired:
        subprocess.run(["scancel", f"--name=dronefleet-{out.name}"], env=slurm)
        raise
    logs = sorted((out / "_logs").glob("*.out"))
    printed = "".join(f"--- {log.name}\n{log.read_text()}" for log in logs)
    assert job.returncode == 0, f"{job.stdout}{job.stderr}\n{printed}"
    return logs, printed


def test_the_job_array_writes_the_dataset_of_a_local_run(slurm, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert cli.main(["sweep", "plan", str(SMOKE), "--results", "slurm"]) == 0
    logs, printed = submit(slurm, tmp_path / "slurm" / "smoke")
    assert len(logs) == 3 and printed.count("ran 3, skipped 0") == 2 and "ran 2, skipped 0" in printed

    assert cli.main(["sweep", "run", str(SMOKE), "--results", "local", "--jobs", "2"]) == 0
    for results in ("slurm", "local"):
        assert cli.main(["sweep", "status", str(SMOKE), "--results", results]) == 0
        assert cli.main(["sweep", "collect", str(SMOKE), "--results", results]) == 0
    on_slurm, local = tmp_path / "slurm" / "smoke", tmp_path / "local" / "smoke"
    collected = pd.read_parquet(on_slurm / "collected.parquet")
    assert len(collected) == 8
    pd.testing.assert_frame_equal(collected, pd.read_parquet(local / "collected.parquet"))
    assert (on_slurm / "collected.parquet").read_bytes() == (local / "collected.parquet").read_bytes()
    assert table_files(on_slurm) == table_files(local)
    assert len(table_files(local)) == len(TABLES) * 8


@pytest.mark.parametrize("name", ["replenishment", "items", "lunar"])
def test_a_job_array_of_another_scenario_writes_the_dataset_of_a_local_run(name, slurm, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    path = tmp_path / "tiny.toml"
    path.write_text(TINY_SWEEPS[name])
    assert cli.main(["sweep", "plan", str(path), "--results", "slurm"]) == 0
    logs, printed = submit(slurm, tmp_path / "slurm" / "tiny")
    assert len(logs) == 2 and printed.count("ran 2, skipped 0") == 2

    assert cli.main(["sweep", "run", str(path), "--results", "local", "--jobs", "2"]) == 0
    for results in ("slurm", "local"):
        assert cli.main(["sweep", "collect", str(path), "--results", results]) == 0
    on_slurm, local = tmp_path / "slurm" / "tiny", tmp_path / "local" / "tiny"
    assert len(pd.read_parquet(on_slurm / "collected.parquet")) == 4 * 2  # a row per trial
    assert (on_slurm / "collected.parquet").read_bytes() == (local / "collected.parquet").read_bytes()
    tables = SCENARIOS[name].tables
    files = table_files(local, tables)
    assert table_files(on_slurm, tables) == files
    assert len(files) == len(tables) * 4


def test_a_hostile_results_path_reaches_the_tasks_as_it_is(slurm, tmp_path, monkeypatch):
    """Spaces, quotes, % and $(...) in --results: sbatch reads the quoted #SBATCH --output as one
    path (%% its literal %), bash expands nothing, and the tasks write the dataset there."""
    monkeypatch.chdir(tmp_path)
    path = tmp_path / "tiny.toml"
    path.write_text(TINY_SWEEPS["delivery"])
    results = tmp_path / "r $(touch ran) it's %x"
    assert cli.main(["sweep", "plan", str(path), "--results", str(results)]) == 0
    logs, printed = submit(slurm, results / "tiny")
    assert len(logs) == 2 and printed.count("ran 2, skipped 0") == 2
    assert cli.main(["sweep", "status", str(path), "--results", str(results)]) == 0
    assert not list(tmp_path.rglob("ran")), "a command in the path was run"
