"""The items scenario's config: the committed file is the documented default, and hostile values
from every door (config file, ``--set``, the Python API) are refused in one line naming the key
and what is allowed, exit code 2, before any work and with nothing written."""

from pathlib import Path

import numpy as np
import pytest

from dronefleet import cli, scenarios
from dronefleet.config import ConfigError
from dronefleet.items import Params
from dronefleet.items import kernel as k
from dronefleet.items.simulate import kernel_inputs, trial_seeds

ITEMS = Path(__file__).resolve().parents[1] / "configs" / "items.toml"
SCENARIO = scenarios.SCENARIOS["items"]


def refused(capsys, args, *fragments):
    """Exit 2 and ONE stderr line holding every fragment, no traceback."""
    try:
        code = cli.main(args)
    except SystemExit as stop:
        code = stop.code
    err = capsys.readouterr().err
    assert code == 2, err
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1, err
    assert all(fragment in err for fragment in fragments), err


def test_the_committed_config_is_the_documented_default_and_spells_out_every_key():
    scenario, config = scenarios.load(ITEMS)
    assert scenario is SCENARIO and config.to_json() == SCENARIO.load(None).to_json()
    assert (config.mode, config.truth, config.algorithm, config.n_robots, config.capacity) == \
        ("foraging", "poisson", "GR", 5, 10)
    text = ITEMS.read_text()
    for key in SCENARIO.schema:
        assert f"\n{key} = " in text


def test_set_and_seed_reach_the_config_with_strict_types():
    config = SCENARIO.load(ITEMS, ["robots.capacity=3", "speed=1", "cas_variant=rate"], seed=9)
    assert (config.capacity, config.speed, config.cas_variant, config.seed) == (3, 1.0, "rate", 9)
    assert isinstance(config.speed, float)
    assert SCENARIO.replace(config, {"n_robots": 2}).n_robots == 2
    with pytest.raises(ConfigError, match="robots.n_robots must be an integer"):
        SCENARIO.replace(config, {"n_robots": 2.0})


@pytest.mark.parametrize("setting, fragments", [
    ("n_robots=0", ("robots.n_robots", "[1, 100]")),
    ("n_robots=true", ("robots.n_robots", "must be an integer")),
    ("capacity=2.0", ("robots.capacity", "write 2")),
    ("speed=0", ("robots.speed", "out of range")),
    ("speed=nan", ("robots.speed", "out of range")),
    ("speed=inf", ("robots.speed", "out of range")),
    ("grid_spacing=0.001", ("world.grid_spacing", "[0.02, 1]")),
    ("obs_range=2", ("world.obs_range", "[0, 1.5]")),
    ("truth=gaussian", ("generation.truth", "'bernoulli', 'poisson', 'logistic'")),
    ("algorithm=gr", ("robots.algorithm", "'GR'")),
    ("cas_variant=fastest", ("options.cas_variant", "'max_expected', 'rate', 'gr_no_earmark'")),
    ("ties=first", ("options.ties", "'random', 'lowest_index'")),
    ("cas_targets=seen", ("options.cas_targets", "'unseen', 'shared'")),
    ("lam_hat=-1", ("robots.lam_hat", "[0, 1000]")),
    ("lam_hat=mu", ("robots.lam_hat", "must be a number")),
    ("seed=-1", ("run.seed",)),
    (f"seed={2**31}", ("run.seed",)),
    ("first_trial=0", ("run.first_trial",)),
    (f"steps={10**30}", ("run.steps",)),
    ("m_min=-1", ("generation.m_min",)),
    ("sigma_e=2", ("generation.sigma_e", "[0, 1]")),
    ("algorithm=GRIC", ("GRIC", '"delivery" only')),
    ("algorithm=AS", ("AS", "logistic")),
    ("truth=logistic", ()),          # fine alone: GR in logistic foraging is defined
    ("trials=100000", ("the run would take", "lower trials")),
    ("bogus=1", ("unknown key 'bogus'",)),
    ("run.speed=1", ("unknown key 'run.speed'",)),
])
def test_hostile_set_values_are_refused_in_one_line_and_nothing_is_written(tmp_path, capsys, setting, fragments):
    out = tmp_path / "out"
    # each key once: a key given twice is refused for that alone
    base = [f"{key}={value}" for key, value in (("trials", 2), ("steps", 50)) if not setting.startswith(f"{key}=")]
    args = ["run", str(ITEMS), *(a for s in base for a in ("--set", s)), "--set", setting, "--out", str(out)]
    if setting.startswith("trials="):
        args = ["run", str(ITEMS), "--set", "steps=50", "--set", setting, "--set", "mode=delivery",
                "--set", "grid_spacing=0.02", "--out", str(out)]
    if not fragments:
        assert cli.main(args) == 0 and (out / "summary.parquet").exists()
        return
    refused(capsys, args, *fragments)
    assert not out.exists()


@pytest.mark.parametrize("overrides, fragments", [
    (["truth=logistic", "mode=delivery"], ('"logistic" is defined for mode "foraging" only',)),
    (["algorithm=SF"], ("SF", "logistic")),
    (["algorithm=GRIC", "mode=delivery", "sharing=destinations"], ("options.sharing",)),
    (["algorithm=CAS", "cas_variant=gr_no_earmark", "cas_targets=shared"], ("options.cas_targets", "GRIC")),
])
def test_combinations_the_text_does_not_define_are_refused(overrides, fragments):
    with pytest.raises(ConfigError) as error:
        SCENARIO.load(ITEMS, overrides)
    assert all(fragment in str(error.value) for fragment in fragments) and "\n" not in str(error.value)


@pytest.mark.parametrize("overrides", [
    # Foraging draws its locations each trial and builds their locations^2 travel table then.
    ["trials=100000", "locations=1000", "steps=1", "n_robots=1"],
    # Each trial seeds a stream per location of the grid (2,601 of them).
    ["trials=100000", "mode=delivery", "grid_spacing=0.02", "steps=1", "n_robots=1"],
])
def test_a_run_of_many_short_trials_counts_each_trials_set_up_and_is_refused(tmp_path, capsys, overrides):
    out = tmp_path / "out"
    args = ["run", "items", *(arg for o in overrides for arg in ("--set", o)), "--out", str(out)]
    refused(capsys, args, "the run would take", "set-up", "lower trials")
    assert not out.exists()


@pytest.mark.parametrize("text, fragments", [
    ('scenario = "items"\ntruth = "poisson"\n', ("top level", "[generation]")),
    ('scenario = "items"\n[robots]\nsteps = 10\n', ("robots.steps", "belongs in [run]")),
    ('scenario = "items"\n[robot]\nn_robots = 1\n', ("unknown section [robot]", "robots")),
    ('scenario = "items"\n[robots]\nn_robots = [1, 2]\n', ("robots.n_robots", "must be an integer")),
    ('scenario = "items"\n[robots]\nalgorithm = 3\n', ("robots.algorithm", "must be a string")),
])
def test_hostile_config_files_are_refused_naming_the_file_and_key(tmp_path, capsys, text, fragments):
    path = tmp_path / "hostile.toml"
    path.write_text(text)
    out = tmp_path / "out"
    refused(capsys, ["run", str(path), "--out", str(out)], str(path), *fragments)
    assert not out.exists()


def test_the_kernel_stops_at_once_when_its_stop_flag_is_set():
    p = Params(trials=3, steps=500)
    opts, pars, positions, truth_par = kernel_inputs(p)
    totals = np.full((3, k.N_TOTALS), -1, dtype=np.int64)
    per_robot = np.zeros((3, p.n_robots, k.N_PER_ROBOT), dtype=np.int64)
    k.run_trials(opts, pars, trial_seeds(p), positions, truth_par, totals, per_robot,
                 np.zeros((0, p.n_robots, 4), dtype=np.int64), np.zeros((0, len(positions))), np.ones(1, np.int8))
    assert (totals == -1).all()       # no trial ran


def test_the_python_api_refuses_in_one_line_too():
    import dronefleet

    with pytest.raises(ConfigError, match=r"robots.n_robots = 0 is out of range"):
        dronefleet.run(ITEMS, n_robots=0)


def test_a_local_sweep_pairs_the_algorithms_trial_by_trial(tmp_path, capsys):
    import pyarrow.parquet as pq

    sweep = tmp_path / "s.toml"
    sweep.write_text('[sweep]\nname = "items-pairs"\nscenario = "items"\n[set]\ntrials = 3\nsteps = 150\n'
                     'truth = "bernoulli"\n[[grid]]\nalgorithm = ["R", "GR", "CAS"]\nn_robots = [1, 4]\n')
    results = tmp_path / "res"
    assert cli.main(["sweep", "run", str(sweep), "--results", str(results), "--jobs", "1"]) == 0
    assert cli.main(["sweep", "collect", str(sweep), "--results", str(results)]) == 0
    table = pq.read_table(results / "items-pairs" / "collected.parquet").to_pandas()
    assert len(table) == 18
    per_trial = table.groupby("trial")["generated"].nunique()
    assert (per_trial == 1).all() and table.groupby("trial")["generated"].first().nunique() == 3
