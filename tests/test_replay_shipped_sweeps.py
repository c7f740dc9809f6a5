"""A run of a shipped sweep file of every scenario replays, whatever keys the sweep varies.

As a user would: copy the shipped file, make its runs tiny in ``[set]``, ``dronefleet sweep run``
it (or one job-array task of it), then ``dronefleet replay DATASET --run KEY=VALUE ...`` by the
grid values of a run, the keys its summary holds too (lunar's ``layout`` and ``battery_wh``).
"""

import json
import re
import subprocess
import sys

import pytest

from dronefleet.config import shipped_config

#: shipped sweep -> (tiny [set] values, --task-id or None for all runs, the --run selection, the run's id)
SWEEPS = {
    "smoke": ({"horizon_weeks": "0.02", "n_uavs": "3"}, 0, ["rule=least_confident", "tau_minutes=15", "seed=1"],
              "rule=least_confident,tau_minutes=15.0,seed=1"),
    "replenishment-fig09": ({"trials": "1", "ticks": "200"}, 0, ["strategy=fixed"],
                            "charger_capacity_factor=2.0,n_chargers=0,strategy=fixed"),
    "items-e1": ({"trials": "1", "steps": "50"}, 0, ["algorithm=R", "n_robots=1", "capacity=3"],
                 "algorithm=R,capacity=3,cas_variant=max_expected,n_robots=1,root_seed=2015"),
    "lunar-e1": ({"runs": "1", "n_robots": "5", "duration_s": "20.0"}, None, ["layout=OPEN"],
                 "layout=OPEN,root_seed=0"),
    "lunar-e2": ({"runs": "1", "n_robots": "5", "duration_s": "20.0"}, None, ["battery_wh=12.5", "seed=0"],
                 "battery_wh=12.5,root_seed=0"),
}


def tiny_copy(name, values, folder):
    """The shipped sweep file ``name`` copied into ``folder`` with ``values`` in its [set] (replaced or added)."""
    text = shipped_config("sweeps", f"{name}.toml").read_text()
    head, _, rest = text.partition("\n[set]\n")
    body, grid, tail = rest.partition("\n[")
    for key, value in values.items():
        body, found = re.subn(rf"(?m)^{key} = \S+", f"{key} = {value}", body)
        if not found:
            body = f"{key} = {value}\n{body}"
    path = folder / f"{name}.toml"
    path.write_text(f"{head}\n[set]\n{body}{grid}{tail}")
    return path


def dronefleet(*args, cwd):
    return subprocess.run([sys.executable, "-m", "dronefleet", *args], cwd=cwd, capture_output=True, text=True,
                          timeout=900, check=False)


@pytest.mark.parametrize("name", sorted(SWEEPS))
def test_a_run_of_a_shipped_sweep_replays_by_its_grid_values(name, tmp_path):
    values, task, selection, run_id = SWEEPS[name]
    path = tiny_copy(name, values, tmp_path)
    tasks = [] if task is None else ["--task-id", str(task)]
    ran = dronefleet("sweep", "run", str(path), "--jobs", "1", *tasks, cwd=tmp_path)
    assert ran.returncode == 0, ran.stderr
    runs = [arg for pair in selection for arg in ("--run", pair)]
    played = dronefleet("replay", f"results/{name}", *runs, cwd=tmp_path)
    assert played.returncode == 0, played.stderr
    page = tmp_path / "results" / name / "_replay" / f"{run_id}.html"
    assert page.is_file()
    data = json.loads(re.search(r'id="run-data">(.*?)</script>', page.read_text(), re.S)[1])
    assert data["source"] == f"sweep dataset {name}, run {run_id.replace(',', '/')}"
