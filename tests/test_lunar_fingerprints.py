"""Golden fingerprints of the lunar model: the same bytes from the same config and seed, on any CPU.

Two small configurations (the default SOFT-RT rules, and HARD-NT with most section-17 options
turned the other way) must give exactly these SHA-256 digests of their tables
(:func:`dronefleet.fingerprint.table_digest`), here and compiled by numba for a generic x86-64
into a fresh cache. A speed-up must keep them; an intentional change of the model's numbers
regenerates them with ``python tests/test_lunar_fingerprints.py`` and pastes the dict here.
Also: a run is a pure function of (config, seed), and run j alone equals run j of a batch.
"""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

import dronefleet
from dronefleet.fingerprint import table_digest
from dronefleet.lunar.params import LunarParams
from dronefleet.lunar.simulate import simulate

RUNS = {
    "soft_rt": dict(n_robots=25, duration_s=240.0, runs=2),
    "hard_nt_options": dict(layout="HARD-NT", n_robots=30, duration_s=200.0, runs=2, first_run=3, seed=5,
                            avoidance="turn", broadcast_velocity="motion", weight_form="bracket", los_bodies=True,
                            redecide="beacon_change", completion="last_region", frames=True, battery_wh=0.5),
    "open_options": dict(layout="OPEN", n_robots=30, duration_s=200.0, runs=1, broadcast="update",
                         fallback="literal", turn_on="any", redecide="avoid_clear", weight_form="literal", eps=0.2),
}

EXPECTED = {
    "hard_nt_options": {
        "snapshots": "fd7a17e885a709ad986925c65bfb58fbcb37622ba63f2a91f8852d54721341b6",
        "summary": "d74e7c150de2777b1ad4b3ae7421abecb315ca56bc85f4d9815d6927cfa4f1aa",
        "timeseries": "45daf83f0528b7c085dea18b0caf6f5e9769bc4ac321b67879a9c9e9dca5b64d",
        "trips": "96fe7957537de563257296293c15ba715982ea58386e84f2828f4845f3d6c325",
    },
    "open_options": {
        "snapshots": "8da96b05a724f0466f0bd964372994eaf86bb18d200b3ee0677b3f62b3b13cfe",
        "summary": "f47e9a0920ab72495764e25e7700d3b58a7326bad98487a2f34e7d49dcbb46f1",
        "timeseries": "05f0198b2e0eaf9c9c27e261096e2bb27ccf4486074222b3faa7511047757fac",
        "trips": "74c095ddeee00e0dbbad1fdcab48c502708b920ec67378406b496cb011777531",
    },
    "soft_rt": {
        "snapshots": "7c9eaf073974ea4cb7b025cf077687c302f288bc23ffff2fbe6a90a204aba36d",
        "summary": "7dbe623aed82c36b4fd0a9085d08a371bd2dfe7dadb1a9a8a9790dd330ecaabb",
        "timeseries": "fdb01f3fa6f1590ed084d95a8587ce08d09b2a1cf19b4ba06f8500334328ce86",
        "trips": "a5bda8eef5e24f5878d155a128f2452716352288c94b389d316e2dadd10b0f42",
    },
}


def digests():
    """``{run: {table: sha256}}`` of every configuration of :data:`RUNS`."""
    return {name: {table: table_digest(t) for table, t in simulate(LunarParams(**changes)).items()}
            for name, changes in RUNS.items()}


@pytest.fixture(scope="module")
def fingerprints():
    return digests()


@pytest.mark.parametrize("run", sorted(RUNS))
def test_golden_fingerprints(fingerprints, run):
    assert fingerprints[run] == EXPECTED[run]


def test_same_fingerprints_compiled_for_a_generic_cpu(tmp_path):
    # A fresh cache: numba compiles the kernel again, for a CPU without SSE4/AVX/FMA, with every
    # array index checked.
    env = dict(os.environ, NUMBA_CPU_NAME="generic", NUMBA_CACHE_DIR=str(tmp_path / "numba-cache"),
               NUMBA_BOUNDSCHECK="1")
    package_root = str(Path(dronefleet.__file__).resolve().parents[1])
    env["PYTHONPATH"] = os.pathsep.join([package_root] + ([env["PYTHONPATH"]] if env.get("PYTHONPATH") else []))
    done = subprocess.run([sys.executable, str(Path(__file__).resolve())], env=env, cwd=tmp_path,
                          capture_output=True, text=True, timeout=1800)
    assert done.returncode == 0, done.stderr
    assert json.loads(done.stdout) == EXPECTED


def test_same_config_and_seed_give_the_same_bytes():
    params = LunarParams(n_robots=8, duration_s=100.0, runs=1, seed=11)
    first, second = simulate(params), simulate(params)
    assert {t: table_digest(v) for t, v in first.items()} == {t: table_digest(v) for t, v in second.items()}


def test_run_alone_equals_the_same_run_in_a_batch():
    batch = simulate(LunarParams(n_robots=25, duration_s=240.0, runs=3, seed=2))
    alone = simulate(LunarParams(n_robots=25, duration_s=240.0, runs=1, first_run=2, seed=2))
    for table, t in alone.items():
        rows = batch[table].filter(batch[table]["run"].to_numpy() == 2)
        assert rows.num_rows == t.num_rows and rows.num_rows > 0, table
        assert table_digest(rows) == table_digest(t), table


def test_run_j_draws_the_same_streams_in_every_layout():
    # common random numbers (section 13): the first robot's first heading decision (from the nest,
    # before any beacon exists) is the same draw in OPEN and HARD-RT
    first = [simulate(LunarParams(layout=layout, n_robots=1, duration_s=0.064, runs=1, frames=True,
                                  update_interval_s=0.064))["snapshots"].to_pandas().heading[0]
             for layout in ("OPEN", "HARD-RT", "SOFT-NR")]
    assert first[0] == first[1] == first[2]


if __name__ == "__main__":
    print(json.dumps(digests(), sort_keys=True))
