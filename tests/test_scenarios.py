"""The scenario contract (dronefleet.scenarios), checked on every registered scenario, and the
replenishment scenario's config, ``run`` and ``bounds`` commands."""

import subprocess
import sys
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest

from dronefleet import cli, provenance, records, scenarios
from dronefleet.config import ConfigError
from dronefleet.delivery.config import load_config
from dronefleet.replenishment import Params, constant_supply_bounds, fixed_bounds

# A tiny run of each registered scenario (a new scenario must add one): config file text, --set.
CONFIGS = Path(__file__).resolve().parents[1] / "configs"   # read from any working directory
REPLENISHMENT, PAPER = CONFIGS / "replenishment.toml", CONFIGS / "paper.toml"
TINY = {
    "delivery": ("", ["horizon_weeks=0.02", "n_uavs=3"]),
    "replenishment": ('scenario = "replenishment"\n', ["trials=2", "ticks=300"]),
    "items": ('scenario = "items"\n', ["trials=2", "steps=200"]),
    "lunar": ('scenario = "lunar"\n', ["runs=2", "n_robots=30", "duration_s=60"]),
}
# Columns each scenario's summary table must have.
SUMMARY_COLUMNS = {
    "delivery": {"seed", "rule", "orders_arrived", "delivered", "lost_uavs"},
    "replenishment": {"trial", "seed", "work", "energy", "work_energy", "efficiency", "depleted_workers",
                      "depleted_chargers", "shared", "lost"},
    "items": {"trial", "seed", "generated", "served", "rate", "trips", "visits", "items_per_trip"},
    "lunar": {"run", "seed", "resources", "trips", "interruptions", "sessions", "deaths", "beacons", "alignment_T",
              "alignment_N", "alignment_R"},
}


def _config_file(tmp_path, text, name="tiny.toml"):
    path = tmp_path / name
    path.write_text(text)
    return path


def test_every_registered_scenario_has_a_tiny_run_here():
    assert set(TINY) == set(scenarios.SCENARIOS) == set(SUMMARY_COLUMNS)


@pytest.mark.parametrize("name", sorted(scenarios.SCENARIOS))
def test_scenario_contract(name, tmp_path, capsys):
    scenario = scenarios.SCENARIOS[name]
    text, tiny = TINY[name]
    # schema: every key documented, with a default
    assert set(scenario.schema) == set(scenario.defaults) and scenario.schema
    for field in scenario.schema.values():
        assert field.section and field.unit and field.allowed and field.doc
    assert isinstance(scenario.figures, tuple) and "summary" in scenario.tables
    # what sweeps need: key resolution, validated replacement, values, the seed key
    defaults = scenario.load(None)
    # the root seed (None: replenishment, whose trials are its streams) and whether a sweep must list seeds
    assert (scenario.seed_key is None or scenario.seed_key in scenario.schema) and isinstance(scenario.seeds_required,
                                                                                              bool)
    for key, field in scenario.schema.items():
        assert scenario.resolve_key(key) == scenario.resolve_key(f"{field.section}.{key}") == key
        assert scenario.value(defaults, key) == scenario.defaults[key]
    assert scenario.replace(defaults, {}) == defaults
    with pytest.raises(ConfigError):
        scenario.replace(defaults, {scenario.seed_key or "first_trial": -1})
    # loading: the file names its scenario; defaults with no file or an empty one
    path = _config_file(tmp_path, text)
    assert scenarios.scenario_of(path) is scenario
    found, defaults = scenarios.load(path)
    assert found is scenario and defaults.to_json() == scenario.load(None).to_json()
    _, config = scenarios.load(path, tiny)
    assert config.to_json() != defaults.to_json()
    # simulate -> its tables, summary columns, printed summary
    tables = scenario.simulate(config)
    assert tuple(tables) == scenario.tables
    assert SUMMARY_COLUMNS[name] <= set(tables["summary"].column_names)
    summary = scenario.format_summary(tables)
    assert summary and summary == summary.strip("\n")
    # the shared writer: config and provenance in every file, read back
    out = tmp_path / "written"
    records.write_tables(tables, out, config)
    assert records.run_dir_state(out, scenario.tables) == "complete"
    for table in scenario.tables:
        metadata = pq.read_schema(out / f"{table}.parquet").metadata
        assert provenance.KEY in metadata
        assert scenario.read_config(out / f"{table}.parquet").to_json() == config.to_json()
        assert pq.read_table(out / f"{table}.parquet").to_pandas().equals(tables[table].to_pandas())  # nan == nan
    # the CLI end to end: same tables, the summary printed from them
    run = tmp_path / "run"
    assert cli.main(["run", str(path), *(a for s in tiny for a in ("--set", s)), "--out", str(run)]) == 0
    printed = capsys.readouterr().out
    assert sorted(p.name for p in run.iterdir()) == sorted(f"{t}.parquet" for t in scenario.tables)
    written = {t: pq.read_table(run / f"{t}.parquet") for t in scenario.tables}
    assert scenario.format_summary(written) in printed
    assert scenario.read_config(run / "summary.parquet").to_json() == config.to_json()


def test_the_registry_imports_no_scenario_until_used():
    code = ("import sys, dronefleet.cli, dronefleet.scenarios as s; s.get('replenishment'); "
            "print(sorted(m for m in ('numpy', 'numba', 'pyarrow') if m in sys.modules))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert done.stdout.strip() == "[]"


# ---------------------------------------------------------------- config and dispatch


def test_configs_without_the_key_or_naming_delivery_stay_delivery(tmp_path):
    plain = _config_file(tmp_path, "[fleet]\nn_uavs = 3\n", "plain.toml")
    named = _config_file(tmp_path, 'scenario = "delivery"\n[fleet]\nn_uavs = 3\n', "named.toml")
    assert scenarios.scenario_of(plain).name == scenarios.scenario_of(named).name == "delivery"
    assert load_config(plain) == load_config(named)


def test_the_delivery_loader_refuses_a_replenishment_config_in_one_line():
    with pytest.raises(ConfigError, match="is for scenario 'replenishment'; only a delivery config"):
        load_config(REPLENISHMENT)


def test_the_committed_config_is_the_documented_default():
    scenario, config = scenarios.load(REPLENISHMENT)
    assert scenario.name == "replenishment"
    assert config.to_json() == scenario.load(None).to_json()
    assert (config.params.strategy, config.params.n_chargers, config.params.charger_capacity_factor,
            config.params.trials, config.params.ticks, config.first_trial) == ("mobile", 6, 2.0, 50, 6000, 1)
    text = REPLENISHMENT.read_text()
    for key in scenario.schema:
        assert f"\n{key} = " in text  # every key spelled out (and commented) in the file


def test_set_takes_bare_and_section_keys_with_strict_types():
    scenario = scenarios.SCENARIOS["replenishment"]
    config = scenario.load(None, ["strategy=fixed", "robots.n_chargers=0", "energy.work_ratio=2",
                                  "charge_rate=1", "first_trial=5"])
    p = config.params
    assert (p.strategy, p.n_chargers, p.work_ratio, p.charge_rate, config.first_trial) == ("fixed", 0, 2.0, 1.0, 5)
    assert isinstance(p.charge_rate, float)  # an int is taken for a float, as for delivery
    assert scenario.load(None, ["charge_rate=1"]).to_json() == scenario.load(None, ["charge_rate=1.0"]).to_json()


# ---------------------------------------------------------------- replenishment run


def _run(tmp_path, *sets, out="run"):
    changes = {"trials": "2", "ticks": "300", **dict(s.split("=", 1) for s in sets)}  # each key once
    args = ["run", str(REPLENISHMENT)]
    for key, value in changes.items():
        args += ["--set", f"{key}={value}"]
    assert cli.main([*args, "--out", str(tmp_path / out)]) == 0
    return tmp_path / out


def test_run_writes_one_summary_row_per_trial_and_the_time_series(tmp_path, capsys):
    out = _run(tmp_path, "first_trial=3", "sample_every=50")
    printed = capsys.readouterr().out
    summary = pq.read_table(out / "summary.parquet").to_pydict()
    assert summary["trial"] == [3, 4] and summary["seed"] == [876 * 3, 876 * 4]
    e = np.array(summary["efficiency"])
    assert np.array_equal(e, np.array(summary["work_energy"]) / np.array(summary["energy"]))
    series = pq.read_table(out / "timeseries.parquet").to_pandas()
    assert len(series) == 2 * (300 // 50 + 1)
    assert sorted(set(series["tick"])) == list(range(0, 301, 50))
    workers = series[["workers_charging", "workers_to_work", "workers_working", "workers_to_charge"]]
    chargers = series[["chargers_charging", "chargers_to_transfer", "chargers_sharing", "chargers_to_base"]]
    assert (workers.sum(axis=1) == 6).all() and (chargers.sum(axis=1) == 6).all()
    last = series[series["tick"] == 300].set_index("trial")["work"]
    assert list(last.loc[[3, 4]]) == summary["work"]  # cumulative work ends at the trial's W
    # the summary: every metric with mean, sd, min-max; the bounds beside work and efficiency
    params = Params(strategy="mobile", n_chargers=6, ticks=300, trials=2)
    for label in ("work [points]", "total energy [units]", "work energy [units]", "efficiency [fraction]",
                  "  with loss [fraction]", "depleted workers [robots]", "depleted chargers [robots]",
                  "shared [energy units]", "lost [energy units]"):
        assert f"\n  {label}" in printed
    assert f"{constant_supply_bounds(params).work:,.0f} (W_cs)" in printed
    assert f"{constant_supply_bounds(params).efficiency:.4f} (E_cs)" in printed
    work = np.array(summary["work"], dtype=float)
    assert f"{work.mean():,.1f}" in printed and f"{work.std(ddof=1):,.1f}" in printed


def test_a_fixed_summary_above_the_per_cycle_w_fix_names_the_strict_ceiling():
    # at k = 0.1 a trial holds 2.99 cycles; leaving the charger early fits part of a fourth
    from dronefleet.replenishment import scenario

    config = scenarios.SCENARIOS["replenishment"].load(REPLENISHMENT, ["strategy=fixed", "n_chargers=0",
                                                                       "charge_rate=0.1", "trials=2"])
    columns = {name: [1.0, 2.0] for name in scenario.summary_columns()}
    columns["work"] = [14_136.0, 14_000.0]  # W_fix = 14,108
    table = records.arrow_table(columns, {records.CONFIG_KEY: config.to_json()})
    printed = scenario.format_summary({"summary": table})
    assert "14,108 (W_fix)" in printed
    assert "strict ceiling within them is 16,600" in printed
    columns["work"] = [14_000.0, 14_000.0]
    table = records.arrow_table(columns, {records.CONFIG_KEY: config.to_json()})
    assert "ceiling" not in scenario.format_summary({"summary": table})


def test_set_overrides_reach_the_run_and_its_metadata(tmp_path, capsys):
    out = _run(tmp_path, "strategy=fixed", "n_chargers=0", "work_ratio=2")
    config = scenarios.SCENARIOS["replenishment"].read_config(out / "summary.parquet")
    assert (config.params.strategy, config.params.n_chargers, config.params.work_ratio) == ("fixed", 0, 2.0)
    summary = pq.read_table(out / "summary.parquet").to_pydict()
    assert summary["depleted_chargers"] == [0, 0] and summary["shared"] == [0.0, 0.0]
    printed = capsys.readouterr().out
    fixed = fixed_bounds(Params(work_ratio=2.0, ticks=300, trials=2))
    assert f"{fixed.work:,.0f} (W_fix)" in printed and "fixed chargers" in printed


def test_a_trial_is_the_same_alone_and_beside_others(tmp_path):
    both = pq.read_table(_run(tmp_path, out="both") / "summary.parquet").to_pylist()
    alone = pq.read_table(_run(tmp_path, "first_trial=2", "trials=1", out="alone") / "summary.parquet").to_pylist()
    assert alone == both[1:]


def test_default_folder_and_output_safety_are_delivery_s(tmp_path, monkeypatch, capsys):
    config = tmp_path / "repl.toml"
    config.write_text('scenario = "replenishment"\n[run]\ntrials = 1\nticks = 100\n')
    monkeypatch.chdir(tmp_path)
    assert cli.main(["run", str(config)]) == 0
    (folder,) = (tmp_path / "results" / "runs").iterdir()
    assert folder.name.startswith("repl-trials1-1-") and len(folder.name) == len("repl-trials1-1-") + 8
    assert cli.main(["run", str(config), "--out", str(folder)]) == 2
    assert "pass --overwrite" in capsys.readouterr().err
    assert cli.main(["run", str(config), "--out", str(folder), "--overwrite"]) == 0


# ---------------------------------------------------------------- bounds command


def _bounds_printed(capsys, *args):
    assert cli.main(["bounds", str(REPLENISHMENT), *args]) == 0
    rows = {}
    for line in capsys.readouterr().out.splitlines()[1:]:
        parts = line.split()
        if len(parts) >= 2 and parts[0][0].isupper():
            rows[parts[0]] = parts[1]
    return rows


def test_bounds_at_the_defaults_are_the_spec_s(capsys):
    rows = _bounds_printed(capsys)
    assert (rows["W_fix"], rows["E_fix"], rows["W_cs"], rows["E_cs"]) == ("26,865", "0.7807", "32,564", "0.9474")
    assert (rows["D"], rows["D_c"]) == ("0.74625", "83.33")
    assert rows["W_fix,T"] == "27,609"  # the strict ceiling within T ticks (spec section 9)
    for name in ("D_charge", "D_work", "D_cycle", "D_charge,cs", "D_work,cs"):
        assert float(rows[name]) > 0


def test_bounds_follow_set(capsys):
    rows = _bounds_printed(capsys, "--set", "work_ratio=2", "--set", "energy.transfer_loss=0.5")
    p = Params(strategy="mobile", n_chargers=6, work_ratio=2.0, transfer_loss=0.5)
    assert rows["W_fix"] == f"{fixed_bounds(p).work:,.0f}" != "26,865"
    assert rows["E_cs"] == f"{constant_supply_bounds(p).efficiency:.4f}" != "0.9474"


def test_e_cs_with_a_large_loss_is_a_positive_bound(capsys):
    # it was 1 - (lost energy per cycle) / c_w: -0.5793 at lambda = 0.6, below every simulated mean
    rows = _bounds_printed(capsys, "--set", "transfer_loss=0.6")
    assert rows["E_cs"] == "0.3731"


@pytest.mark.parametrize("args, why", [
    ([str(REPLENISHMENT), "--set", "transfer_loss=0.999"], "(1 - lambda) v_charge = 0.001 must exceed"),
    ([str(REPLENISHMENT), "--set", "charge_rate=0.005"], "v_charge = 0.005 must exceed v_min"),
    ([str(REPLENISHMENT), "--set", "worker_capacity=10"], "round-trip cost"),
    ([str(PAPER)], "bounds exist only for replenishment"),
    ([str(REPLENISHMENT), "--set", "transfer_loss=1"], "transfer_loss = 1.0 is not allowed"),
])
def test_bounds_refuse_where_none_exists(capsys, args, why):
    assert cli.main(["bounds", *args]) == 2
    captured = capsys.readouterr()
    assert why in captured.err and captured.err.count("\n") == 1 and captured.out == ""


# ---------------------------------------------------------------- hostile input


@pytest.mark.parametrize("file_text, args, message", [
    (None, ["--set", "n_workrs=3"], "unknown key 'n_workrs' (did you mean 'n_workers'?)"),
    (None, ["--set", "transfer_loss=-0.1"], "transfer_loss = -0.1 is not allowed: must be in [0, 1)"),
    (None, ["--set", "transfer_loss=1"], "transfer_loss = 1.0 is not allowed"),
    (None, ["--set", "n_workers=0"], "n_workers = 0 is not allowed"),
    (None, ["--set", "n_chargers=83"], "do not fit in the base: at most 88"),
    (None, ["--set", "strategy=mobil"], "did you mean 'mobile'?"),
    (None, ["--set", "strategy=fixed"], 'n_chargers = 6 is not allowed: must be 0 with strategy "fixed"'),
    (None, ["--set", "ticks=6000.0"], "run.ticks must be an integer, got float 6000.0 (write 6000)"),
    (None, ["--set", "trials=true"], "run.trials must be an integer, got bool"),
    (None, ["--set", "work_ratio=fast"], "energy.work_ratio must be a number, got str"),
    (None, ["--set", "ticks=10**9"], "run.ticks must be an integer"),
    (None, ["--set", "ticks=99999999999999999999999"], "run.ticks = 99999999999999999999999 is out of range"),
    (None, ["--set", "trials=100000000"], "trials = 100000000 is not allowed: must be <= 100000"),
    (None, ["--set", "trials=2000", "--set", "sample_every=1"], "time-series rows x 200 B)); at most 2 GB"),
    (None, ["--set", "trials=1000", "--set", "ticks=100000", "--set", "sample_every=100"],
     "robot-ticks (trials 1000 x (ticks 100000 x 12 robots + 1,000 per trial's set-up)); at most 1e+09"),
    (None, ["--set", "first_trial=0"], "run.first_trial = 0 is out of range"),
    (None, ["--seed", "3"], "--seed does not apply to a replenishment run, which has no root seed"),
    (None, ["--fleet", "f.parquet"], "--fleet applies to delivery runs only"),
    ('scenario = "replenishmnt"\n', [], "unknown scenario 'replenishmnt' (did you mean 'replenishment'?); "
                                        "registered scenarios: delivery, replenishment"),
    ("scenario = 3\n", [], "unknown scenario 3; registered scenarios: delivery, replenishment"),
    ('scenario = "replenishment"\nticks = 5\n', [], "key 'ticks' is at the top level; put it in section [run]"),
    ('scenario = "replenishment"\n[robot]\nn_workers = 5\n', [], "unknown section [robot] (did you mean 'robots'?)"),
    ('scenario = "replenishment"\n[run]\nn_workers = 5\n', [], "run.n_workers belongs in [robots]"),
])
def test_hostile_input_is_refused_in_one_line_before_any_work(tmp_path, capsys, file_text, args, message):
    path = REPLENISHMENT if file_text is None else _config_file(tmp_path, file_text)
    out = tmp_path / "run"
    assert cli.main(["run", str(path), *args, "--out", str(out)]) == 2
    captured = capsys.readouterr()
    assert message in captured.err, captured.err
    assert captured.err.count("\n") == 1 and captured.out == ""
    assert not out.exists()


def test_a_run_without_a_bound_still_runs_and_says_why(tmp_path, capsys):
    out = _run(tmp_path, "transfer_loss=0.999")
    printed = capsys.readouterr().out
    assert "no bound: no constant-supply bound" in printed and "(W_cs)" not in printed
    assert pq.read_table(out / "summary.parquet").num_rows == 2


def test_reproduce_draws_exactly_the_figures_the_scenarios_declare():
    from dronefleet import reproduce
    declared = [figure for s in scenarios.SCENARIOS.values() for figure in s.figures]
    assert sorted(declared) == sorted(reproduce.FIGURES) and len(set(declared)) == len(declared)
