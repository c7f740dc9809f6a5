"""The lunar scenario's config: the committed file is the documented default (every key of
LunarParams, the contract's option words), hostile values from every door (config file, ``--set``,
the Python API, a tampered table) are refused in one line naming the key, the value and what is
allowed, exit code 2, before any work and with nothing written; the shipped sweep files plan the
experiments of the spec's section 14."""

import dataclasses
import math
import re
import subprocess
import sys
from pathlib import Path

import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from dronefleet import cli, scenarios
from dronefleet import sweeps as sw
from dronefleet.config import ConfigError
from dronefleet.datafiles import DataError
from dronefleet.lunar import LunarParams
from dronefleet.lunar import scenario as lunar
from dronefleet.lunar.keys import region_gap

ROOT = Path(__file__).resolve().parents[1]
LUNAR = ROOT / "configs" / "lunar.toml"
SWEEPS = ROOT / "configs" / "sweeps"
SCENARIO = scenarios.SCENARIOS["lunar"]
LAYOUTS = ("OPEN", "HARD-RT", "SOFT-RT", "HARD-NT", "SOFT-NT", "HARD-NR", "SOFT-NR")
#: The option words of the contract (LUNAR-CONTRACT.md; spec section 17), first the default.
OPTIONS = {"avoidance": ("offset", "turn"), "broadcast_velocity": ("planned", "motion"),
           "broadcast": ("tick", "update"), "weight_form": ("exponent", "bracket", "literal"),
           "fallback": ("visited", "literal"), "turn_on": ("region", "any"),
           "redecide": ("none", "avoid_clear", "beacon_change"), "completion": ("role", "last_region")}
#: The option words of the readings of the spec's section 21, first the default.
READINGS = {"depletion": ("fatal", "recorded"), "experience": ("any", "leaving")}


def refused(capsys, args, *fragments):
    """Exit 2 and ONE stderr line holding every fragment, no traceback."""
    try:
        code = cli.main([str(a) for a in args])
    except SystemExit as stop:
        code = stop.code
    err = capsys.readouterr().err
    assert code == 2, err
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1, err
    assert all(fragment in err for fragment in fragments), err


def test_every_key_of_lunar_params_is_a_config_key_with_its_default():
    params = {f.name: f.default for f in dataclasses.fields(LunarParams)}
    assert list(SCENARIO.schema) != [] and set(SCENARIO.schema) == set(params) == set(lunar.KEYS)
    assert SCENARIO.defaults == params
    config = SCENARIO.load(None)
    assert isinstance(config, LunarParams) and config == lunar.Config(**params)
    assert (config.layout, config.runs, config.n_robots, config.battery_wh, config.duration_s, config.layout_scale,
            config.eps) == ("SOFT-RT", 50, 50, 10.0, 3600.0, 0.75, 0.05)


def test_the_committed_config_is_the_documented_default_and_spells_out_every_key():
    scenario, config = scenarios.load(LUNAR)
    assert scenario is SCENARIO and config.to_json() == SCENARIO.load(None).to_json()
    lines = LUNAR.read_text().splitlines()
    for key in SCENARIO.schema:
        (line,) = [line for line in lines if line.startswith(f"{key} = ")]
        assert "#" in line and line.split("#", 1)[1].strip(), key  # a comment: unit, range, meaning
    for name, words in OPTIONS.items():  # each option says what it decides, in words, and names its words
        (line,) = [line for line in lines if line.startswith(f"{name} = ")]
        assert len(line.split("#", 1)[1].split()) >= 4 and not re.search(r"\bA\d+\b", line), name
        assert all(f'"{word}"' in "\n".join(lines) for word in words), name


def test_the_option_words_and_layouts_are_exactly_the_contracts():
    for name, words in OPTIONS.items():
        assert lunar.KEYS[name].kind == words and SCENARIO.defaults[name] == words[0]
        for word in words:
            assert SCENARIO.load(None, [f"{name}={word}"]).value(name) == word
    assert lunar.KEYS["layout"].kind == LAYOUTS
    for layout in LAYOUTS:
        assert SCENARIO.load(None, [f"layout={layout}"]).layout == layout
    assert SCENARIO.load(None, ["los_bodies=true", "frames=true"]).los_bodies is True


def test_set_and_seed_reach_the_config_with_strict_types():
    config = SCENARIO.load(LUNAR, ["energy.battery_wh=7", "layout=HARD-NT", "runs=3", "avoidance=turn"], seed=9)
    assert (config.battery_wh, config.layout, config.runs, config.avoidance, config.seed) == \
        (7.0, "HARD-NT", 3, "turn", 9)
    assert isinstance(config.battery_wh, float)  # an int is taken for a float
    assert SCENARIO.replace(config, {"n_robots": 10}).n_robots == 10
    assert SCENARIO.replicates(config) == range(0, 3)
    assert SCENARIO.replicates(SCENARIO.replace(config, {"first_run": 50})) == range(50, 53)
    with pytest.raises(ConfigError, match="robots.n_robots must be an integer"):
        SCENARIO.replace(config, {"n_robots": 10.0})
    with pytest.raises(ConfigError, match="unknown key 'n_robot' .did you mean 'n_robots'"):
        SCENARIO.replace(config, {"n_robot": 10})


def test_describe_and_label_name_the_configuration():
    config = SCENARIO.load(None, ["layout=HARD-RT", "battery_wh=7.5", "runs=2", "first_run=4", "avoidance=turn"])
    line = SCENARIO.describe(config)
    assert "HARD-RT" in line and "7.5 Wh" in line and "runs 4-5" in line and "avoidance=turn" in line
    assert "\n" not in line
    assert SCENARIO.label(config) == "HARD-RT-n50-7.5Wh-runs4-5"
    assert "options" not in SCENARIO.describe(SCENARIO.load(None))
    assert "; run 3 (root seed 0)" in SCENARIO.describe(SCENARIO.load(None, ["runs=1", "first_run=3"]))


def _every_key_hostile():
    """(``--set`` text, fragments the one-line refusal must hold) for every key: wrong kinds, NaN and
    infinities, out of range, words in the wrong case, booleans as strings."""
    cases = []
    for name, key in lunar.KEYS.items():
        where = f"{key.section}.{name}"
        if key.kind is bool:
            cases += [(f'{name}="true"', (where, "true or false", "'true'")), (f"{name}=1", (where, "true or false")),
                      (f"{name}=yes", (where, "true or false", "'yes'"))]
        elif isinstance(key.kind, tuple):
            cases += [(f"{name}=1", (where, "must be a string")), (f"{name}=true", (where, "must be a string")),
                      (f"{name}=nonsense", (where, "'nonsense' is not allowed", repr(key.kind[0]))),
                      (f"{name}=[]", (where, "must be a string"))]
        else:
            kind = "an integer" if key.kind is int else "a number"
            cases += [(f"{name}=true", (where, f"must be {kind}")), (f'{name}="1"', (where, f"must be {kind}")),
                      (f"{name}=nan", (where,)), (f"{name}=inf", (where,)), (f"{name}=-inf", (where,)),
                      (f"{name}={key.low - 1}", (where, "out of range", "allowed [")),
                      (f"{name}={key.high * 10 + 1}", (where, "out of range"))]
            if key.kind is int:
                cases += [(f"{name}=2.0", (where, "write 2")), (f"{name}=1.5", (where, "must be an integer")),
                          (f"{name}={10**30}", (where, "out of range"))]
            else:
                cases.append((f"{name}=1e999", (where, "out of range")))
    return cases


@pytest.mark.parametrize("setting, fragments", _every_key_hostile())
def test_every_key_refuses_hostile_values_naming_key_and_value(setting, fragments):
    with pytest.raises(ConfigError) as error:
        SCENARIO.load(None, [setting])
    message = str(error.value)
    assert "\n" not in message and all(f in message for f in fragments), message
    assert f"--set {setting}" in message  # where the value came from


@pytest.mark.parametrize("setting, fragments", [
    ("layout=soft-rt", ("world.layout", "'soft-rt'", "did you mean 'SOFT-RT'", "'OPEN'")),
    ("layout=RT", ("world.layout", "'RT'", "'HARD-RT'")),
    ("avoidance=Offset", ("options.avoidance", "'Offset'", "'offset', 'turn'")),
    ("n_robots=100000", ("robots.n_robots", "[1, 500]")),
    ("n_robots=500", ("pair-ticks", "at most 1e+11", "lower runs, duration_s or n_robots")),
    ("duration_s=86400", ("robot-ticks", "at most 2e+09")),
    ("frames=true", ()),              # the defaults with frames fit the snapshot limit
    ("tau=0.5", ("v0 * tau", "robots.r_body")),
    ("update_interval_s=0.01", ("guidance.update_interval_s", "shorter than one tick")),
    ("layot=OPEN", ("unknown key 'layot'", "did you mean 'layout'")),
    ("run.layout=OPEN", ("unknown key 'run.layout'",)),
    ("battery_wh", ("--set needs key=value",)),
    ("decision_step_m=3", ("guidance.decision_step_m = 3 m is not below robots.comm_radius = 2 m",)),
    ("soc0_low=1.5", ("energy.soc0_low", "out of range", "[0, 1]")),
    ("energy_scale=0", ("energy.energy_scale", "out of range", "[0.001, 1000]")),
    ("depletion=dead", ("options.depletion", "'dead'", "'fatal', 'recorded'")),
    ("experience=away", ("options.experience", "'away'", "'any', 'leaving'")),
])
def test_hostile_set_values_are_refused_in_one_line_and_nothing_is_written(tmp_path, capsys, setting, fragments):
    out = tmp_path / "out"
    args = ["run", LUNAR, "--set", setting, "--out", out]
    if not fragments:
        assert SCENARIO.load(LUNAR, [setting])  # valid; the run itself is test_lunar_cli's
        return
    refused(capsys, args, *fragments)
    assert not out.exists() and list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("overrides, fragments", [
    (["frames=true", "runs=60"], ("snapshot-rows", "60 x 50 robots", "set frames = false")),
    (["runs=10000", "n_robots=1", "update_interval_s=0.064"], ("records", "raise update_interval_s")),
    (["snapshot_every_s=0.064", "runs=1000", "n_robots=1"], ("snapshot-rows", "raise snapshot_every_s")),
    (["runs=10000", "n_robots=1", "duration_s=86400", "tau=0.01", "v0=1"], ("robot-ticks",)),
    (["v0=20", "r_body=0.5"], ("v0 * tau = 20 * 0.064",)),
    (["rate_window_s=0.01"], ("records.rate_window_s", "shorter than one tick")),
    (["duration_s=1", "tau=1", "v0=0.1"], ()),  # one tick of one second: allowed
    (["first_run=1000000000", "runs=2"], ("go beyond run index",)),
    (["runs=147"], ("could hold up to", "trip-rows", "1,364 trips a robot can make", "3.3 m between regions")),
    (["v0=20", "r_body=1", "tau=0.05", "runs=10"], ("trip-rows", "lower runs, n_robots, duration_s or v0")),
    (["runs=146"], ()),
    # each link tested against every body: 500 robots for 600 s would take minutes (~1.2e12)
    (["runs=1", "n_robots=500", "duration_s=600", "los_bodies=true"],
     ("occlusion-tests", "runs 1 x 9,375 ticks x 500^3", "at most 6e+11", "set los_bodies = false")),
    (["runs=1", "n_robots=500", "duration_s=600"], ()),
    (["los_bodies=true"], ()),  # E4's runs
    # decisions by distance only within a beacon's range; initial SOCs drawn below soc0
    (["decision_step_m=2"], ("guidance.decision_step_m = 2 m", "robots.comm_radius = 2 m", "0 turns them off")),
    (["decision_step_m=1.5", "comm_radius=1"], ("decision_step_m = 1.5 m", "comm_radius = 1 m")),
    (["decision_step_m=1.99"], ()),
    (["soc0=0.8", "soc0_low=0.9"], ("energy.soc0_low = 0.9 is above energy.soc0 = 0.8", "set 0 < soc0_low <= soc0")),
    (["soc0=0.8"], ()),
    (["soc0=0.8", "soc0_low=0.8"], ()),
    (["soc0_low=0.8"], ()),
    (["energy_scale=0.001", "depletion=recorded", "experience=leaving"], ()),
    # a frame every tick: 56,267 snapshots of 50 robots in one run
    (["runs=1", "frames=true", "frame_every_s=0.064"],
     ("snapshot-rows", "runs 1 x 50 robots x 56,267 snapshots", "raise snapshot_every_s or frame_every_s")),
    (["runs=1", "frames=true", "frame_every_s=0.01"], ("records.frame_every_s = 0.01 s is shorter than one tick",)),
    (["frame_every_s=0.64"], ("records.frame_every_s = 0.64 s", "records.frames = false records none")),
    (["runs=1", "frames=true", "frame_every_s=0.64"], ()),  # E0's
])
def test_runs_too_large_or_undefined_are_refused_before_any_work(overrides, fragments):
    if not fragments:
        assert SCENARIO.load(None, overrides)
        return
    with pytest.raises(ConfigError) as error:
        SCENARIO.load(None, overrides)
    assert all(f in str(error.value) for f in fragments) and "\n" not in str(error.value), str(error.value)


def test_the_limits_hold_the_documented_numbers():
    size = lunar.run_size(SCENARIO.load(None))
    assert size == {"robot_ticks": 50 * 56_250 * 50, "pair_ticks": 50 * 56_250 * 50**2, "occlusion_tests": 0,
                    "records": 50 * 361,
                    "snapshot_rows": 50 * 50 * 16, "trip_rows": 50 * 50 * (4500 // 3.3 + 1)}
    assert lunar.RUN_LIMITS == {"robot_ticks": 2e9, "pair_ticks": 1e11, "occlusion_tests": 6e11, "records": 5e6,
                                "snapshot_rows": 1e6, "trip_rows": 1e7}
    assert lunar.run_size(SCENARIO.load(None, ["los_bodies=true"]))["occlusion_tests"] == 50 * 56_250 * 50**3
    assert math.isclose(region_gap(SCENARIO.load(None)), 6.3 - 3.0)  # R-T, the closest regions
    assert math.isclose(region_gap(SCENARIO.load(None, ["layout_scale=1"])), 8.4 - 3.0)
    assert lunar.run_size(SCENARIO.load(None, ["frames=true"]))["snapshot_rows"] == 942_500
    text = LUNAR.read_text()
    assert "<= 2e9" in text and "<= 1e11" in text and "<= 5e6" in text and "<= 1e6" in text and "<= 1e7" in text and "<= 6e11" in text


@pytest.mark.parametrize("text, fragments", [
    ('scenario = "lunar"\nlayout = "OPEN"\n', ("top level", "[world]")),
    ('scenario = "lunar"\n[robots]\nlayout = "OPEN"\n', ("robots.layout", "belongs in [world]")),
    ('scenario = "lunar"\n[robot]\nn_robots = 1\n', ("unknown section [robot]", "robots")),
    ('scenario = "lunar"\n[robots]\nn_robots = [1, 2]\n', ("robots.n_robots", "must be an integer")),
    ('scenario = "lunar"\n[options]\nlos_bodies = "false"\n', ("options.los_bodies", "true or false")),
    ('scenario = "lunar"\n[options]\navoidance = "swerve"\n', ("options.avoidance", "'swerve'")),
    ('scenario = "lunar"\n[energy]\nbattery_wh = -10.0\n', ("energy.battery_wh", "-10.0")),
    ('scenario = "lunar"\n[energy]\nbattery_wh = nan\n', ("energy.battery_wh", "nan")),
    ('scenario = "lunar"\n[run]\nruns = 1_000_000\n', ("run.runs", "1000000")),
    ('scenario = "lunar"\n[options]\nweight = "literal"\n', ("unknown key 'options.weight'", "weight_form")),
    ('scenario = "lunar"\n[run]\nrun = { a = 1 }\n', ("unknown key 'run.run'", "runs")),
    ('scenario = "lunar"\n[world]\nlayout = "OPEN"\nlayout = "OPEN"\n', ("cannot parse",)),
    ('scenario = "lunar"\n[world\n', ("cannot parse",)),
])
def test_hostile_config_files_are_refused_naming_the_file_and_key(tmp_path, capsys, text, fragments):
    path = tmp_path / "hostile.toml"
    path.write_text(text)
    out = tmp_path / "out"
    refused(capsys, ["run", path, "--out", out], str(path), *fragments)
    assert not out.exists()


@pytest.mark.parametrize("args, fragments", [
    (["--set", "n_robots=1000000"], ("robots.n_robots", "1000000")),
    (["--set", "los_bodies=\"true\""], ("options.los_bodies", "true or false")),
    (["--set", "layout=MOON"], ("world.layout", "'MOON'")),
    (["--set", "duration_s=1e300"], ("run.duration_s", "out of range")),
])
def test_the_command_line_refuses_in_one_line_with_exit_code_2(tmp_path, args, fragments):
    out = tmp_path / "out"
    done = subprocess.run([sys.executable, "-m", "dronefleet", "run", "lunar", *args, "--out", str(out)],
                          capture_output=True, text=True, cwd=tmp_path, timeout=300)
    assert done.returncode == 2 and done.stdout == "", done.stderr
    assert len(done.stderr.splitlines()) == 1 and done.stderr.startswith("dronefleet: error: "), done.stderr
    assert all(f in done.stderr for f in fragments), done.stderr
    assert list(tmp_path.iterdir()) == []


def test_the_python_api_refuses_in_one_line_too():
    import dronefleet

    with pytest.raises(ConfigError, match=r"robots.n_robots = 0 is out of range: allowed \[1, 500\]"):
        dronefleet.run(LUNAR, n_robots=0)


def _table_with_config(path, config_text):
    pq.write_table(pa.table({"run": [0]}).replace_schema_metadata({b"dronefleet.config": config_text}), path)


@pytest.mark.parametrize("config_text, fragments", [
    ('{"scenario": "lunar", "world": {"layout": "MARS"}}', ("world.layout", "'MARS'")),
    ('{"scenario": "lunar", "robots": {"n_robots": 1e9}}', ("robots.n_robots",)),
    ('{"scenario": "lunar", "run": {"runs": 700, "duration_s": 86400.0}}', ("robot-ticks",)),
    ('{"scenario": "items", "run": {"runs": 2}}', ("scenario = 'items', expected 'lunar'",)),
    ('{"scenario": "lunar", "options": {"los_bodies": 1}}', ("options.los_bodies", "true or false")),
])
def test_a_tampered_table_config_is_refused_naming_the_file(tmp_path, config_text, fragments):
    path = tmp_path / "summary.parquet"
    _table_with_config(path, config_text)
    with pytest.raises(DataError) as error:
        SCENARIO.read_config(path)
    assert str(path) in str(error.value) and all(f in str(error.value) for f in fragments), str(error.value)


def test_a_config_round_trips_through_its_dict_and_json():
    config = SCENARIO.load(None, ["layout=SOFT-NR", "los_bodies=true", "p_move=116", "first_run=7"])
    assert lunar.config_from_dict(config.to_dict()) == config
    assert lunar.config_from_dict({"scenario": "lunar"}) == SCENARIO.load(None)
    assert config.to_dict()["options"]["los_bodies"] is True and '"los_bodies": true' in config.to_json()


# ---------------------------------------------------------------- the shipped sweep files (spec section 14)

E1 = ("OPEN", "HARD-RT", "SOFT-RT")


def _conditions(sweep):
    return [(run.value("layout"), run.value("battery_wh")) for run in sweep.runs]


def test_the_core_experiments_plan_their_conditions(tmp_path, capsys):
    plans = {name: sw.load_sweep(SWEEPS / f"lunar-{name}.toml") for name in ("e1", "e2", "e3", "eps1")}
    for sweep in plans.values():
        assert sweep.scenario is SCENARIO
        assert all(run.config.runs == 50 and run.config.first_run == 0 for run in sweep.runs)
    assert _conditions(plans["e1"]) == [(layout, 10.0) for layout in E1]
    assert _conditions(plans["e2"]) == [("SOFT-RT", 7.5), ("SOFT-RT", 12.5)]
    assert _conditions(plans["e3"]) == [(layout, 10.0) for layout in ("HARD-NT", "SOFT-NT", "HARD-NR", "SOFT-NR")]
    assert _conditions(plans["eps1"]) == [(layout, 10.0) for layout in E1]
    assert {run.config.eps for run in plans["eps1"].runs} == {1.0}
    assert {run.config.eps for name in ("e1", "e2", "e3") for run in plans[name].runs} == {0.05}
    for name, sweep in plans.items():  # the command plans them: a job script of one task per configuration
        assert cli.main(["sweep", "plan", f"lunar-{name}", "--results", str(tmp_path)]) == 0
        script = (tmp_path / f"lunar-{name}" / f"lunar-{name}.sbatch").read_text()
        assert f"#SBATCH --array=0-{len(sweep.runs) - 1}\n" in script
    capsys.readouterr()


def test_the_sensitivity_sweep_runs_each_variant_over_the_e4_conditions(tmp_path, capsys):
    sweep = sw.load_sweep(SWEEPS / "lunar-e4.toml")
    assert cli.main(["sweep", "plan", "lunar-e4", "--results", str(tmp_path)]) == 0
    assert "#SBATCH --array=0-89\n" in (tmp_path / "lunar-e4" / "lunar-e4.sbatch").read_text()
    capsys.readouterr()
    defaults = SCENARIO.load(None)
    conditions = [(layout, 10.0) for layout in E1] + [("SOFT-RT", 7.5), ("SOFT-RT", 12.5)]
    variants = {}
    for run in sweep.runs:
        changed = tuple(sorted((k, run.value(k)) for k in SCENARIO.schema if k not in ("layout", "battery_wh")
                               and run.value(k) != defaults.value(k)))
        variants.setdefault(changed, []).append((run.value("layout"), run.value("battery_wh")))
        assert run.config.runs == 50
    assert all(sorted(found) == sorted(conditions) for found in variants.values())
    assert set(variants) == {
        (), (("eps", 1.0),), (("p_move", 5.8), ("v0", 0.125)), (("layout_scale", 1.0),), (("kappa_soft", 2.0),),
        (("kappa_soft", 5.0),),
        (("p_move", 29.0),), (("p_move", 116.0),), (("p_move", 232.0),),
        (("weight_form", "bracket"),), (("weight_form", "literal"),), (("broadcast", "update"),),
        (("turn_on", "any"),), (("los_bodies", True),), (("redecide", "avoid_clear"),),
        (("redecide", "beacon_change"),), (("fallback", "literal"),),
        (("avoidance", "turn"), ("broadcast_velocity", "motion"))}
    assert len(sweep.runs) == 18 * 5 == 90
    assert all(math.isclose(p.p_move / p.v0, 46.4) for p in (r.config for r in sweep.runs) if p.v0 == 0.125)


def test_a_switch_is_a_partition_key_of_its_own_type():
    # los_bodies, a bool, is a grid key of the E4 sweep: its dataset's partition column is a bool
    sweep = sw.load_sweep(SWEEPS / "lunar-e4.toml")
    schema = sw._partition_schema(sweep)
    assert schema.field("los_bodies").type == pa.bool_() and schema.field("root_seed").type == pa.int64()
    assert schema.field("layout").type == pa.string() and schema.field("battery_wh").type == pa.float64()


def test_every_shipped_lunar_file_is_listed(capsys):
    assert cli.main(["configs"]) == 0
    listed = capsys.readouterr().out
    for name in ("lunar ", "lunar-e1 ", "lunar-e2 ", "lunar-e3 ", "lunar-e4 ", "lunar-eps1 "):
        assert f"\n  {name}" in listed, name


def test_the_guide_lists_every_key_and_every_option_word():
    guide = (ROOT / "docs" / "guide" / "lunar.md").read_text()
    for name, key in lunar.KEYS.items():
        assert f"| `{name}` | {key.section} |" in guide, name
    for name, words in OPTIONS.items():
        assert all(f'"{word}"' in guide for word in words), name
    for name, words in READINGS.items():
        assert lunar.KEYS[name].kind == words and SCENARIO.defaults[name] == words[0], name
        assert all(f'"{word}"' in guide for word in words), name
    for limit in ("Deaths", "Guidance quality", "Network growth and decay"):  # the known limits
        assert f"**{limit}.**" in guide


def test_the_figures_are_the_studys():
    study = SCENARIO.study
    assert SCENARIO.figures == study.FIGURES and SCENARIO.figures[0] == "lunar-fig03"
    assert all(name.startswith("lunar-") for name in SCENARIO.figures)
