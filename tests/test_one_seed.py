"""One meaning of "seed" on the command line, in Python and in sweeps, as a user meets it.

``dronefleet run NAME --seed N`` (a subprocess) and ``dronefleet.run("NAME", seed=N)`` (in a real
``python file.py``) give the same tables for every scenario with a root seed; replenishment has
none and refuses ``--seed``, ``seed=`` and ``seeds=`` alike, naming the word typed, while its
``first_trial`` means the same in both. The README's sweep pattern ``seeds=[0, 1]`` runs the
root seeds 0 and 1 of items and lunar, as ``--seed`` would.
"""

import subprocess
import sys
import textwrap

import pandas as pd
import pytest

#: Tiny runs: (shipped config / scenario name, its --set changes as KEY=VALUE).
RUNS = {
    "items": ["trials=2", "steps=50"],
    "lunar": ["runs=2", "n_robots=5", "duration_s=20.0"],
}


def cli(*args, cwd):
    return subprocess.run([sys.executable, "-m", "dronefleet", *args], cwd=cwd, capture_output=True, text=True,
                          timeout=900, check=False)


def script(tmp_path, body):
    """Run ``body`` as a real ``python file.py`` in ``tmp_path``; the finished process."""
    path = tmp_path / "study.py"
    path.write_text(textwrap.dedent(body))
    return subprocess.run([sys.executable, str(path)], cwd=tmp_path, capture_output=True, text=True, timeout=900,
                          check=False)


def keyword(change):
    key, value = change.split("=")
    return f"{key}={value}"


@pytest.mark.parametrize("name", sorted(RUNS))
def test_the_cli_seed_and_the_python_seed_are_one_root_seed(name, tmp_path):
    sets = [arg for change in RUNS[name] for arg in ("--set", change)]
    done = cli("run", name, "--seed", "7", *sets, "--out", "cli", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    ran = script(tmp_path, f"""
        import dronefleet
        r = dronefleet.run({name!r}, seed=7, {', '.join(map(keyword, RUNS[name]))})
        assert r.config.seed == 7, r.config.seed
        r.save("api")
    """)
    assert ran.returncode == 0, ran.stderr
    for table in ("summary",):
        from_cli, from_api = (pd.read_parquet(tmp_path / folder / f"{table}.parquet") for folder in ("cli", "api"))
        pd.testing.assert_frame_equal(from_cli, from_api)
    other = cli("run", name, "--seed", "8", *sets, "--out", "eight", cwd=tmp_path)
    assert other.returncode == 0, other.stderr
    assert not pd.read_parquet(tmp_path / "eight" / "summary.parquet").equals(
        pd.read_parquet(tmp_path / "cli" / "summary.parquet"))  # the seed is the root seed: another run


def test_replenishment_refuses_a_seed_in_every_interface_and_takes_first_trial_alike(tmp_path):
    sets = ["--set", "trials=2", "--set", "ticks=300"]
    refused = cli("run", "replenishment", "--seed", "3", *sets, cwd=tmp_path)
    assert refused.returncode == 2 and refused.stderr.count("\n") == 1
    assert refused.stderr.startswith("dronefleet: error: --seed does not apply to a replenishment run, which has "
                                     "no root seed") and "first_trial" in refused.stderr
    ran = script(tmp_path, """
        import dronefleet
        for call in (lambda: dronefleet.run("replenishment", seed=3, trials=2, ticks=300),
                     lambda: dronefleet.sweep({"strategy": ["fixed"]}, seeds=[0, 1], base="replenishment",
                                              set={"n_chargers": 0, "trials": 2, "ticks": 300})):
            try:
                call()
            except ValueError as error:
                print(error)
            else:
                raise SystemExit("not refused")
        dronefleet.run("replenishment", first_trial=3, trials=2, ticks=300).save("api")
    """)
    assert ran.returncode == 0, ran.stderr
    said = ran.stdout.splitlines()
    assert said[0].startswith("seed=3 does not apply to a replenishment run, which has no root seed")
    assert said[1].startswith("seeds=[0, 1] does not apply to a replenishment run, which has no root seed")
    done = cli("run", "replenishment", "--set", "first_trial=3", *sets, "--out", "cli", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    from_cli, from_api = (pd.read_parquet(tmp_path / f / "summary.parquet") for f in ("cli", "api"))
    pd.testing.assert_frame_equal(from_cli, from_api)
    assert from_cli["trial"].tolist() == [3, 4]


def test_the_readme_sweep_pattern_runs_root_seeds_of_items_and_lunar(tmp_path):
    ran = script(tmp_path, """
        import dronefleet
        items = dronefleet.sweep({"algorithm": ["R", "GR"]}, seeds=[0, 1], base="items",
                                 set={"trials": 2, "steps": 50}, jobs=1)
        print(items[["algorithm", "root_seed", "trial", "seed"]].values.tolist())
        alone = dronefleet.run("items", seed=1, algorithm="GR", trials=2, steps=50).summary
        mine = items[(items.algorithm == "GR") & (items.root_seed == 1)][alone.columns].reset_index(drop=True)
        assert mine.equals(alone), (mine, alone)
        lunar = dronefleet.sweep({"layout": ["OPEN"]}, seeds=[0, 1], base="lunar",
                                 set={"runs": 1, "n_robots": 5, "duration_s": 20.0}, jobs=1)
        print(lunar[["layout", "root_seed", "run", "seed"]].values.tolist())
    """)
    assert ran.returncode == 0, ran.stderr
    items, lunar = ran.stdout.splitlines()[-2:]
    # each row keeps its own trial's stream seed (root * 2**32 + trial) beside the run's root seed
    assert items == str([["R", 0, 1, 1], ["R", 0, 2, 2], ["R", 1, 1, 2**32 + 1], ["R", 1, 2, 2**32 + 2],
                         ["GR", 0, 1, 1], ["GR", 0, 2, 2], ["GR", 1, 1, 2**32 + 1], ["GR", 1, 2, 2**32 + 2]])
    assert lunar == str([["OPEN", 0, 0, 0], ["OPEN", 1, 0, 2**32]])
