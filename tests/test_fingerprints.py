"""Golden fingerprints: the same bytes from the same config and seed, on any CPU.

Each pinned run (:data:`dronefleet.fingerprint.RUNS`: one week of 25 UAVs under every winner
rule, and a warm start) must give exactly these SHA-256 digests of its tables' data
(:func:`dronefleet.fingerprint.table_digest`, metadata aside), here and in subprocesses whose
CPU dispatch is turned to older code paths: glibc's libm without AVX2/FMA/AVX-512, numpy's
SIMD loops without X86_V3 (AVX2, FMA3), OpenBLAS as on a Prescott, and numba compiling for a
generic x86-64 into a fresh cache. Before the engine used :mod:`dronefleet.fpmath`, the first
of these changed 10 of the 30 digests on a Haswell-class machine.

After an intentional change of the model's numbers, regenerate the dict with
``python -m dronefleet.fingerprint`` and paste it here.
"""

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pyarrow as pa
import pytest

import dronefleet
from dronefleet import fingerprint

EXPECTED = {
    "least_confident": {
        "attempts": "fe4560d07d8a5c6c7b0e5d5b3230e1d93925e07dd6aac92dd8c450aa5902e27e",
        "fleet": "b0cb1f4d49d29153376b0dca91505264a2a23233ddf6973a5a6d2601c1750913",
        "orders": "97b0a1930b5a4c528188d8a9b19afa0fce39a7f786ee947c11a1896f7942408b",
        "summary": "dd7fa1e8af6ca4611f84c9f5d091c1aef59849d50c62ddaadeb503b6e6d341f5",
        "timeseries": "ff09d40b8657c820252d16bce0706df3a4671237a3cec83c8fe585c55c20b9e6",
    },
    "most_confident": {
        "attempts": "c4e0e4a84da08e270e21d7d65a87ea5d5a074dffa682d49b9e9114f874021cd1",
        "fleet": "fe61265e48fbc7facdbbaa336e48c6c5b4543c2e94b2bcb658298661fbbb418e",
        "orders": "2fa943a33df449655e9e0dc305ca7d37b1b76ce182619c14e3f2c43b12d93bd5",
        "summary": "f8b05620fe39c9801273c75e56220cab8f46231e1c9bf558750e6eef8fb58a09",
        "timeseries": "831fb229cfa64b1ddd99b047017dd4d9e5fd2e6b3a4096dcb9398d73ee75f5d7",
    },
    "random": {
        "attempts": "cc6b3653a85f5c8284ee57d54b3f65706313e79fdb0b3bfdaef41f2257ade356",
        "fleet": "75f171a4d5e7d4ebc647b2aaea99a52345655830951e01403a76f50aedf51cb6",
        "orders": "22920ebd672e8497d835f7c1dddb545e80c0662b3143de650ce7766546359e4d",
        "summary": "80fc7a49bbf9592e2ff4083fd382198df7d2fd4fd79e5c429aac439a2d029e6a",
        "timeseries": "345c8b21975b5e980d57df43cbc0c1a3339061dc22b5ba00c12cf4836f87f24a",
    },
    "reservation": {
        "attempts": "283941953f56e3b2fb08353c2098506717cf8d51392c48d3e335371e51b91e30",
        "fleet": "7e02adbf32629596863e004c5bbce937f9303298c58863c8209991440dbbd722",
        "orders": "4b1f7ed5358157dcadf3f0ef91d50c258a14fbc587078d5dbe9beca0445cc848",
        "summary": "9fdd00a37d25f131538dd01cd0ca8cc955854a2a312c6e40b8907037de8cb664",
        "timeseries": "f32e60933103059d1a30b48196af7d6962c52bc5d0fafbf5de1f3aa79ced240e",
    },
    "threshold": {
        "attempts": "fa23c645bebfb6d36e57e9197a3ab00ebf34417020b708aeef05f1af3c3b8cf0",
        "fleet": "e7096448ffead8af7cc8fa0745cf3272ecd953a2faeaf0d295c66e11dbcc7995",
        "orders": "d62f3586199be6c434fb558da4806289017f9a4e178a5b2c374c62c7820d689d",
        "summary": "786b74b244770e7659d1fb34d93be17d28bd91d7c77751bec5198968643ebe6d",
        "timeseries": "88057dd8afc0a302569a673e49bf7656b13160611c159e96b4a22aeeb0e4975c",
    },
    "warm_start": {
        "attempts": "f1272c0f779239510a9c731bef85bb0b3c317c75b0a6874189516136fd819f2a",
        "fleet": "0afef79406f18d0af747c47a47f7b987c3b2b8cae566b40e90682eb74a190e6b",
        "orders": "b16e59b037851d3d319b611c632deaa895520eb817550727189eb151a893295c",
        "summary": "041a3f7372bda6abbf9771ac3a083729f91859053806eae9b507e02769c2a899",
        "timeseries": "efa59efa4675bd5d072632ff63e0baf587543ba09931bf5a637f10f0e9fd0e86",
    },
}


def _numpy_knob():
    """NPY_DISABLE_CPU_FEATURES=X86_V3 where numpy dispatches on it; nothing where it cannot.

    numpy refuses at import to disable a feature of its build baseline (a build for x86-64-v3
    has X86_V3 there, and then AVX2/FMA code is all it has), and has nothing to disable where
    X86_V3 is not among its dispatch targets; the subprocess must not fail for the variable itself.
    """
    from numpy._core import _multiarray_umath as umath

    if "X86_V3" in umath.__cpu_dispatch__ and "X86_V3" not in umath.__cpu_baseline__:
        return {"NPY_DISABLE_CPU_FEATURES": "X86_V3"}
    return {}


def _fingerprints_in_subprocess(env_changes, tmp_path):
    """The fingerprints printed by ``python -m dronefleet.fingerprint`` with ``env_changes``, this package."""
    env = dict(os.environ, **env_changes)
    package_root = str(Path(dronefleet.__file__).resolve().parents[1])
    env["PYTHONPATH"] = os.pathsep.join([package_root] + ([env["PYTHONPATH"]] if env.get("PYTHONPATH") else []))
    done = subprocess.run([sys.executable, "-m", "dronefleet.fingerprint"], env=env, cwd=tmp_path,
                          capture_output=True, text=True, timeout=900)
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout)


@pytest.fixture(scope="module")
def fingerprints():
    return fingerprint.fingerprints()


def test_fingerprints_cover_every_winner_rule():
    from dronefleet.delivery.auction import RULES

    assert set(fingerprint.RUNS) == set(RULES)
    assert set(EXPECTED) == set(fingerprint.RUNS) | {"warm_start"}


@pytest.mark.parametrize("run", sorted(EXPECTED))
def test_golden_fingerprints(fingerprints, run):
    assert fingerprints[run] == EXPECTED[run]


def test_warm_start_differs_from_its_first_period(fingerprints):
    # The warm start is a second period with fresh orders, not a copy of the first.
    assert fingerprints["warm_start"]["orders"] != fingerprints[fingerprint.WARM_FROM]["orders"]
    assert fingerprints["warm_start"]["fleet"] != fingerprints[fingerprint.WARM_FROM]["fleet"]


def test_table_digest_ignores_metadata_and_nothing_else():
    table = pa.table({"t_s": [0.0, 0.1], "uav": pa.array([1, None], pa.int16()),
                      "winners": pa.array([[1, 2], []], pa.list_(pa.int16()))})
    digest = fingerprint.table_digest(table)
    assert fingerprint.table_digest(table.replace_schema_metadata({b"dronefleet.version": b"9"})) == digest
    one_ulp = pa.table({"t_s": [0.0, np.nextafter(0.1, 1.0)], "uav": table["uav"], "winners": table["winners"]})
    renamed = table.rename_columns(["t", "uav", "winners"])
    retyped = table.set_column(1, "uav", pa.array([1, None], pa.int32()))
    null_to_zero = table.set_column(1, "uav", pa.array([1, 0], pa.int16()))
    signed_zero = table.set_column(0, "t_s", pa.array([-0.0, 0.1]))
    for other in (one_ulp, renamed, retyped, null_to_zero, signed_zero):
        assert fingerprint.table_digest(other) != digest


def test_same_fingerprints_with_older_cpu_code_paths(tmp_path):
    # These libraries choose their code paths when they load, so the compiled engine (from the
    # numba cache, as any sweep worker loads it) calls the older paths too.
    knobs = {"GLIBC_TUNABLES": "glibc.cpu.hwcaps=-AVX2,-FMA,-AVX512F", "OPENBLAS_CORETYPE": "Prescott",
             **_numpy_knob()}
    assert _fingerprints_in_subprocess(knobs, tmp_path) == EXPECTED


def test_same_fingerprints_compiled_for_a_generic_cpu(tmp_path):
    # A fresh cache: numba compiles the engine again, for a CPU without SSE4/AVX/FMA, and with
    # every array index checked (an index derived from data that leaves its array raises).
    knobs = {"NUMBA_CPU_NAME": "generic", "NUMBA_CACHE_DIR": str(tmp_path / "numba-cache"),
             "NUMBA_BOUNDSCHECK": "1"}
    assert _fingerprints_in_subprocess(knobs, tmp_path) == EXPECTED
