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
        "beacon_costs": "0aa631d8e3429cabc4a125d1b67974044552bbbf5531a086aab2609c1004abe8",
        "deaths": "47ff0b1b7e8562d15b6cf9d43dcc01e9014ca4b103cae885e8997177e900a70d",
        "recharge_triggers": "944b874b3e4aef94de958cf1e555b7a9bd461a06da60ebf631eb89159c506c7b",
        "robots": "5b4a3f550b3097403acc8bfd676b618a5e11218b2c17b79716672f1d2f1c0174",
        "snapshots": "e95451615b763bad65d0ded2e0bf0048d43fcc50abac5fb22fa8ed32d073fb1d",
        "summary": "b39decae672be11832f5cf485e40e68ac51367e022bfb20f875a79b042a3ea29",
        "timeseries": "83c2cd6cf1605b0a9883a740cf38cdef84610552022cd3bcf518b7fa853b12f7",
        "trips": "d639a308c01c7c338b03af1c8177ac2eac6b4389312031740f3319dc2a848e16",
    },
    "open_options": {
        "beacon_costs": "c81e7b78ed2a32e36e1984c96d2c0877f5ad891c39c36026a8fee58aef2d4be1",
        "deaths": "80ad4b9e6fad9ec727eacfde99496dea55215e00545537df684cf42a5d6d6831",
        "recharge_triggers": "bfa889435f369ca4d41b5f3b9a6f1e3ffb441b43dddc198f08d185ec989c6a0a",
        "robots": "eeeebb2a31a73abc3f8273488cbed38b4eb377021908ae132eb382e6fa898b2d",
        "snapshots": "a04ace463f1dbbf49deccb3eb8b210e144f48310fe873d0fc2a51e08ea91170e",
        "summary": "e3802c9c328d6692d03cbc8d13e2cbdeae6ca20669f8e50ad302962770023ef3",
        "timeseries": "49583f56102cafb626e25a247ce72e7d36075752d40a86e221a4bb701265a52b",
        "trips": "433eddbaf52bd5ae733239f0f1776f5bb6ae89f79d00c39a0f68fa3382469308",
    },
    "soft_rt": {
        "beacon_costs": "14a9129254c4f8f4a006e54465ae9fec328c9db26af83d7cc2f6e1905cddfa94",
        "deaths": "80ad4b9e6fad9ec727eacfde99496dea55215e00545537df684cf42a5d6d6831",
        "recharge_triggers": "bfa889435f369ca4d41b5f3b9a6f1e3ffb441b43dddc198f08d185ec989c6a0a",
        "robots": "553e26cdf1a7ccb5ef9290542b42951b0d4745f668c9d65c09276a91669368bf",
        "snapshots": "7e1523c784425a78e111832725c07a2f0c4db619d17f542d699cb56f9b5825a0",
        "summary": "33639e493a840fdf1355f905b442abfff7664bd3ad8bef1ff8b78dd2362719e3",
        "timeseries": "0134e657c6e5c93dbd57d3940091855d1baf62b81bfbd0c65885ee94884bc4a9",
        "trips": "3f34a3872a430f3497c4a9ef1808f7e7b823f28add401118ffc0c61874fd89b1",
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
    # a 1-Wh battery: run 2 has deaths and row-2 triggers too, so that every table has rows to compare
    batch = simulate(LunarParams(n_robots=25, duration_s=240.0, runs=3, seed=2, battery_wh=1.0))
    alone = simulate(LunarParams(n_robots=25, duration_s=240.0, runs=1, first_run=2, seed=2, battery_wh=1.0))
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
