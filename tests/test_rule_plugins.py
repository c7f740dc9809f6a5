"""Winner rules as plugins: an entry point or a dotted path in the config, no change to the package.

The example plugin (``examples/dronefleet-rule-fullest-battery``) is installed into a temporary
folder and run in a sweep by the real command line; bad plugins are refused in one line.
"""

import itertools
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pyarrow.parquet as pq
import pytest
from conftest import ALWAYS, NEVER, run_state, scenario, scenario_config
from test_scenario_contract import dronefleet_process

import dronefleet
from dronefleet import cli
from dronefleet.delivery import auction, simulation
from dronefleet.delivery.auction import PLUGIN, RuleError, resolve_rule
from dronefleet.config import ConfigError

REPO = Path(dronefleet.__file__).resolve().parent.parent
EXAMPLE = REPO / "examples" / "dronefleet-rule-fullest-battery"
DOTTED = "dronefleet_rule_fullest_battery:fullest_battery"
MODULE_NUMBERS = itertools.count()

# Rules of a test module: a copy of the built-in most_confident, and bad plugins.
RULES_MODULE = """
import numpy as np
from numba import njit


@njit(cache=True)
def most_confident_copy(f, w_norm, soc, theta, rng):
    if f >= 0.0:
        return True, f / w_norm
    return False, 0.0


most_confident_copy.bids_on = "policy"


def not_compiled(f, w_norm, soc, theta, rng):
    return True, soc


not_compiled.bids_on = "policy"


@njit
def no_bids_on(f, w_norm, soc, theta, rng):
    return True, soc


@njit
def bids_sometimes(f, w_norm, soc, theta, rng):
    return True, soc


bids_sometimes.bids_on = "sometimes"


@njit
def three_values(f, w_norm, soc, theta, rng):
    return True, soc, 1.0


three_values.bids_on = "any"


@njit
def two_arguments(f, soc):
    return True, soc


two_arguments.bids_on = "any"


@njit
def listed_bids_on(f, w_norm, soc, theta, rng):
    return True, soc


listed_bids_on.bids_on = ["policy"]


@njit
def score_first(f, w_norm, soc, theta, rng):
    if f >= 0.0:
        return soc, True
    return 0.0, False


score_first.bids_on = "policy"


@njit
def nan_score(f, w_norm, soc, theta, rng):
    if f >= 0.0:
        return True, np.nan
    return False, 0.0


nan_score.bids_on = "policy"


@njit
def raises(f, w_norm, soc, theta, rng):
    if f >= 0.0:
        raise ValueError("no battery reading")
    return False, 0.0


raises.bids_on = "policy"


@njit
def int_score(f, w_norm, soc, theta, rng):
    if f >= 0.0:
        return True, 1
    return False, 0


int_score.bids_on = "policy"


@njit
def out_of_bounds(f, w_norm, soc, theta, rng):
    scores = np.zeros(2)  # allocates, as a rule may
    return True, scores[int(soc) * 1000000 + 7]


out_of_bounds.bids_on = "any"


def __getattr__(name):
    if name == "unready":
        raise RuntimeError(f"{name} is not ready")
    raise AttributeError(name)
"""


def write_rules(folder, module):
    """The test rules as module ``module`` in ``folder``, and entry points of an installed distribution."""
    (folder / f"{module}.py").write_text(RULES_MODULE)
    dist = folder / f"{module}_plugins-0.1.dist-info"
    dist.mkdir()
    (dist / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {module}-plugins\nVersion: 0.1\n")
    (dist / "entry_points.txt").write_text(
        f"[dronefleet.winner_rules]\ncopied_rule = {module}:most_confident_copy\n"
        f"broken_rule = {module}_missing:rule\n")


@pytest.fixture
def rules_module(tmp_path, monkeypatch):
    """A module of test rules on sys.path (a fresh name per test: imports are cached), with two entry points."""
    module = f"rules{next(MODULE_NUMBERS)}"
    write_rules(tmp_path, module)
    monkeypatch.syspath_prepend(str(tmp_path))
    return module


@pytest.mark.parametrize("rule, fragment", [
    ("nosuch_rule", "auction.rule = 'nosuch_rule' is not a registered winner rule. Allowed: 'least_confident'"),
    ("{m}_missing:rule", "names module '{m}_missing', which cannot be imported (ModuleNotFoundError"),
    ("{m}:absent", "names 'absent', which module '{m}' does not have"),
    ("{m}:not_compiled", "is a function, not a numba @njit function rule(f, w_norm, soc, theta, rng)"),
    ("{m}:no_bids_on", ("has bids_on = None; set the function's attribute bids_on to one of 'policy', "
                        "'soc_threshold', 'any'")),
    ("{m}:bids_sometimes", "has bids_on = 'sometimes'"),
    ("{m}:three_values", ("does not compile as rule(f, w_norm, soc, theta, rng) -> (bool, float) with floats and a "
                          "numpy Generator: No conversion from Tuple(Literal[bool](True), float64, float64) to "
                          "Tuple(bool, float64)")),
    ("{m}:two_arguments", "does not compile as rule(f, w_norm, soc, theta, rng) -> (bool, float)"),
    ("{m}:listed_bids_on", "has bids_on = ['policy']; set the function's attribute bids_on to one of"),
    ("{m}:unready", "names 'unready', which module '{m}' fails to give (RuntimeError: unready is not ready)"),
    ("broken_rule", ("is an entry point of dronefleet.winner_rules ({m}_missing:rule) that fails to load: "
                     "ModuleNotFoundError")),
    ("{m}:score_first", "returns Tuple(float64, bool), not (bids, score): a bool, then a float, in this order"),
    ("exiting:rule", "names module 'exiting', which cannot be imported (ImportError: it calls sys.exit(3))"),
    ("exiting_quietly:rule", "names module 'exiting_quietly', which cannot be imported (ImportError: it calls "
                             "sys.exit(0))"),
    ("exiting_in_words:rule", "which cannot be imported (ImportError: it calls sys.exit('bye\\n\\x1b[31m red'))"),
    ("exiting_on_lookup:rule", "names 'rule', which module 'exiting_on_lookup' fails to give (ImportError: it calls "
                               "sys.exit(0))"),
    ("garbled:rule", "names module 'garbled', which cannot be imported (ImportError: two lines \\x1b[2J of error)"),
])
def test_a_bad_rule_is_refused_in_one_line(rule, fragment, rules_module, tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(simulation, "simulate", lambda *a, **k: pytest.fail("the run was simulated"))
    for module, source in {"exiting": "import sys\nsys.exit(3)\n",
                           "exiting_quietly": "import sys\nsys.exit(0)\n",
                           "exiting_in_words": "raise SystemExit('bye\\n\\x1b[31m red')\n",
                           "exiting_on_lookup": "def __getattr__(name):\n    raise SystemExit(0)\n",
                           "garbled": "raise ImportError('two lines\\n\\x1b[2J of error')\n"}.items():
        (tmp_path / f"{module}.py").write_text(source)
    rule, fragment = rule.format(m=rules_module), fragment.format(m=rules_module)
    code = cli.main(["run", "--set", f"rule={rule}", "--out", str(tmp_path / "out")])
    lines = capsys.readouterr().err.splitlines()
    assert code == 2
    assert len(lines) == 1 and lines[0].startswith(f"dronefleet: error: auction.rule = '{rule}' "), lines
    assert fragment in lines[0] and lines[0].isprintable()
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("rule", ["exiting_quietly:rule", "exiting_on_lookup:rule"])
def test_a_plugin_that_exits_is_a_config_error_of_the_api(rule, tmp_path, monkeypatch):
    (tmp_path / "exiting_quietly.py").write_text("import sys\nsys.exit(0)\n")
    (tmp_path / "exiting_on_lookup.py").write_text("def __getattr__(name):\n    raise SystemExit(0)\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    with pytest.raises(ConfigError, match="it calls sys.exit"):
        dronefleet.run(rule=rule)


@pytest.mark.parametrize("rule, fragment", [
    ("nan_score", "the winner rule '{m}:nan_score' scored the bid of UAV 0 at t = 0 s NaN or infinite; "
                  "a rule's score must be a finite number"),
    ("raises", "the winner rule '{m}:raises' raised ValueError: no battery reading ({m}.py, line "),
    ("out_of_bounds", "the winner rule '{m}:out_of_bounds' raised IndexError"),  # a crash (SIGSEGV) otherwise
])
def test_a_rule_that_breaks_the_contract_while_running_stops_the_run_in_one_line(rule, fragment, rules_module,
                                                                                 tmp_path, capsys):
    code = cli.main(["run", "--set", f"rule={rules_module}:{rule}", "--set", "horizon_weeks=0.01",
                     "--out", str(tmp_path / "out")])
    lines = capsys.readouterr().err.splitlines()
    assert code == 2
    assert len(lines) == 1 and lines[0].startswith("dronefleet: error: "), lines
    assert fragment.format(m=rules_module) in lines[0]
    assert not (tmp_path / "out").exists()


def test_an_int_score_is_still_a_score(rules_module):
    assert resolve_rule(f"{rules_module}:int_score").code == PLUGIN


@pytest.mark.parametrize("source, fragment", [
    ("import os\nos._exit(0)\n", "its import ends the process (exit status 0)"),
    ("import time\ntime.sleep(3600)\n", "its import does not end within 5 s"),
])
def test_a_plugin_module_whose_import_ends_the_process_or_hangs_is_refused_in_one_line(tmp_path, source, fragment):
    (tmp_path / "ending.py").write_text(source)
    done = dronefleet_process(tmp_path, "run", "--set", "rule=ending:rule", "--out", tmp_path / "out")
    assert done.returncode == 2 and len(done.stderr.splitlines()) == 1, done.stderr
    assert done.stderr.startswith("dronefleet: error: auction.rule = 'ending:rule' names module 'ending', which "
                                  f"cannot be imported (ImportError: {fragment}"), done.stderr
    assert not (tmp_path / "out").exists()


def test_a_plugin_module_slow_to_import_is_said(tmp_path, monkeypatch, caplog):
    (tmp_path / "slow_plugin.py").write_text(
        "import time\nfrom numba import njit\ntime.sleep(1.0)\n\n\n@njit\n"
        "def rule(f, w_norm, soc, theta, rng):\n    return True, soc\n\n\nrule.bids_on = 'any'\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setattr(auction, "IMPORT_NOTICE_S", 0.05)
    assert resolve_rule("slow_plugin:rule").code == PLUGIN
    assert "still importing module 'slow_plugin' of winner rule 'slow_plugin:rule' after 0.05 s" in caplog.text


def test_the_unknown_rule_message_lists_the_installed_plugins(rules_module):
    from dronefleet.delivery.config import ConfigError, load_config

    with pytest.raises(ConfigError) as e:
        load_config(overrides=["rule=copied_rul"])
    assert "(did you mean 'copied_rule'?)" in str(e.value)
    assert "'reservation', 'broken_rule', 'copied_rule', or a plugin's 'package.module:function'" in str(e.value)


def test_an_entry_point_and_its_dotted_path_are_the_same_plugin(rules_module):
    by_name, by_path = resolve_rule("copied_rule"), resolve_rule(f"{rules_module}:most_confident_copy")
    assert by_name.code == by_path.code == PLUGIN
    assert by_name.kernel is by_path.kernel and by_name.bids_on == "policy"
    assert resolve_rule("most_confident").code != PLUGIN  # built-ins keep their static dispatch


def test_a_rule_that_does_not_compile_is_refused_naming_the_plugins_line(rules_module):
    with pytest.raises(RuleError) as refused:
        resolve_rule(f"{rules_module}:three_values")
    line = RULES_MODULE.splitlines().index("    return True, soc, 1.0") + 1  # three_values' return
    assert str(refused.value).endswith(f'{rules_module}.py", line {line})'), str(refused.value)


def test_an_entry_point_named_like_a_built_in_rule_is_not_used_and_said_so(tmp_path, monkeypatch, caplog):
    dist = tmp_path / "shadow-0.1.dist-info"
    dist.mkdir()
    (dist / "METADATA").write_text("Metadata-Version: 2.1\nName: shadow\nVersion: 0.1\n")
    (dist / "entry_points.txt").write_text("[dronefleet.winner_rules]\nthreshold = shadow:lowest_soc\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    auction._warn_if_shadowed.cache_clear()  # it warns once per name and process: earlier tests resolved it
    assert resolve_rule("threshold").code != PLUGIN
    assert "entry point 'threshold' (shadow:lowest_soc) is not used: 'threshold' is the built-in rule" in caplog.text


def test_the_example_rule_gives_the_order_to_the_fullest_bidder(monkeypatch):
    # UAV 0 is the fullest bidder, UAV 1 the most confident, UAV 2 the least, UAV 3 (full) never bids.
    monkeypatch.syspath_prepend(str(EXAMPLE))
    policies = [((0.0, 0.0, 1.0), 2e3), ((0.0, 0.0, 1.0), 3e3), ALWAYS, NEVER]
    soc = [90.0, 60.0, 50.0, 100.0]
    winners = {}
    for rule in (DOTTED, "most_confident", "least_confident"):
        c = scenario_config(n_uavs=4, rule=rule)
        st = scenario(c, [0.0], [2000.0], [1.0], policies=policies, soc=soc)
        winners[rule] = run_state(st, c, t_stop=1.0).attempts["uav"].tolist()
    assert winners == {DOTTED: [0], "most_confident": [1], "least_confident": [2]}


SWEEP = """
[sweep]
name = "plugins"
seeds = [0]
[set]
horizon_weeks = 0.1
n_uavs = 5
[grid]
rule = ["fullest_battery", "{dotted}", "most_confident", "{module}:most_confident_copy"]
"""
TRAJECTORY = ("orders", "attempts", "fleet", "timeseries")


def test_the_installed_example_plugin_runs_in_a_sweep(tmp_path):
    # Installed as a user would, into a folder of its own: nothing in the package changes. From a
    # copy, as the build leaves files beside the sources.
    source, site = tmp_path / "example", tmp_path / "site"
    shutil.copytree(EXAMPLE, source, ignore=shutil.ignore_patterns("__pycache__", "build", "*.egg-info"))
    subprocess.run([sys.executable, "-m", "pip", "install", "--quiet", "--no-deps", "--no-build-isolation",
                    "--target", str(site), str(source)], check=True, capture_output=True, timeout=300)
    write_rules(tmp_path, "copies")
    sweep_file = tmp_path / "plugins.toml"
    sweep_file.write_text(SWEEP.format(dotted=DOTTED, module="copies"))
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(map(str, (site, tmp_path, REPO)))}
    done = subprocess.run([sys.executable, "-m", "dronefleet.cli", "sweep", "run", str(sweep_file),
                           "--results", str(tmp_path / "results"), "--jobs", "1"],
                          check=False, capture_output=True, text=True, env=env, cwd=tmp_path, timeout=600)
    assert done.returncode == 0, done.stderr
    out = tmp_path / "results" / "plugins"

    def table(rule, name):
        path = out / name / f"rule={rule.replace(':', '%3A')}" / "seed=0" / "part-0.parquet"
        return pq.read_table(path)

    # The entry point and the dotted path are one rule; the rule is named as the config names it.
    for name in TRAJECTORY:
        assert table("fullest_battery", name).equals(table(DOTTED, name)), name
    assert sorted(pq.read_table(out / "summary")["rule"].to_pylist()) == sorted(
        ["fullest_battery", DOTTED, "most_confident", "copies:most_confident_copy"])
    # A plugin that scores like the built-in most_confident gives the built-in's tables, byte for
    # byte: the engine calls the plugin exactly where it calls a built-in rule.
    for name in TRAJECTORY:
        assert table("copies:most_confident_copy", name).equals(table("most_confident", name)), name
    # The example rule gives other orders to other UAVs than most_confident.
    ours, theirs = table("fullest_battery", "attempts"), table("most_confident", "attempts")
    assert ours.num_rows > 20
    assert ours.select(["uav", "order_id"]).to_pylist() != theirs.select(["uav", "order_id"]).to_pylist()
