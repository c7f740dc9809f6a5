"""The scenario contract (dronefleet.contract, docs/scenario-contract.md) held by every registered scenario,
and scenarios installed from other packages (entry points of ``dronefleet.scenarios``): the example
package runs through ``dronefleet run``, a local sweep and the Python API; one that fails to import or
breaks the contract is refused in one line naming its entry point; a config never names code."""

import itertools
import json
import os
import shutil
import signal
import subprocess
import sys
import time
import types
from pathlib import Path

import pyarrow.parquet as pq
import pytest

from dronefleet import cli, records, scenarios
from dronefleet.config import ConfigError
from dronefleet.contract import ENTRY_POINT_GROUP, ScenarioContract, contract_problems

ROOT = Path(__file__).resolve().parent.parent
EXAMPLE = ROOT / "examples" / "dronefleet-scenario-random-walk"
#: A tiny run of each scenario, as changes of its defaults (a scenario not listed runs its defaults).
TINY = {
    "delivery": {"horizon_weeks": 0.02, "n_uavs": 3},
    "replenishment": {"trials": 2, "ticks": 300},
    "items": {"trials": 2, "steps": 50},
    # fewer robots all become beacons (no trips); a small battery gives deaths and recharging interruptions
    "lunar": {"runs": 2, "n_robots": 50, "duration_s": 60.0, "battery_wh": 0.5},
    "random_walk": {"n_robots": 3, "steps": 50},
}
NAMES = (f"installed{n}" for n in itertools.count())  # imports and entry points are cached: a name per test


def check_contract(name, tmp_path):
    """Every rule of the contract that can be checked from outside, on the registered scenario ``name``."""
    scenario = scenarios.get(name)
    module = scenario.module
    assert contract_problems(module) == [] and isinstance(module, ScenarioContract) and module.NAME == name
    defaults = module.load(None, (), None)
    for key, default in module.DEFAULTS.items():
        assert module.resolve_key(key) == key == module.resolve_key(f"{module.SCHEMA[key].section}.{key}")
        assert module.value(defaults, key) == default and type(module.value(defaults, key)) is type(default), key
    with pytest.raises(ConfigError):
        module.resolve_key("no_such_key")
    config = module.replace(defaults, TINY.get(name, {}))
    assert config == module.replace(defaults, TINY.get(name, {})) and json.loads(config.to_json())
    tables = module.simulate(config)
    assert set(tables) == set(module.TABLES) and "summary" in tables
    schemas = module.table_schemas()
    for table_name, table in tables.items():
        assert [(f.name, f.type) for f in table.schema] == [(f.name, f.type) for f in schemas[table_name]]
        assert table.num_rows > 0, table_name
    assert module.format_summary(tables).strip()
    assert module.describe(config).strip() and "/" not in module.label(config)
    records.write_tables(tables, tmp_path / "run", config)
    assert module.read_config(tmp_path / "run" / "summary.parquet") == config


@pytest.mark.parametrize("name", sorted(scenarios.registered()))
def test_every_registered_scenario_meets_the_contract(name, tmp_path):
    check_contract(name, tmp_path)


def test_the_contract_names_what_a_scenario_lacks():
    class Partial:
        NAME, SCHEMA, DEFAULTS, TABLES, FIGURES, SEED_KEY, SEEDS_REQUIRED = "p", {}, {"x": 1}, ("runs",), (), "x", True

        def simulate(self, config, extra):
            """One parameter too many."""

    problems = contract_problems(Partial())
    assert "has no load" in problems and "has no format_summary" in problems
    assert "simulate does not take (config)" in problems


# ---------------------------------------------------------------- installed from another package


def install(folder, name, value, module=None, text="", distribution=None):
    """An installed distribution (by default ``<name>-scenario``) declaring the entry point ``name = value``,
    and ``module.py`` holding ``text``."""
    distribution = distribution or f"{name}-scenario"
    dist = folder / f"{distribution.replace('-', '_')}-0.1.dist-info"
    dist.mkdir()
    (dist / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {distribution}\nVersion: 0.1\n")
    (dist / "entry_points.txt").write_text(f"[{ENTRY_POINT_GROUP}]\n{name} = {value}\n")
    if module:
        (folder / f"{module}.py").write_text(text)


def refused(capsys, argv, *fragments):
    code = cli.main([str(arg) for arg in argv])
    err = capsys.readouterr().err
    assert code == 2 and len(err.splitlines()) == 1 and "Traceback" not in err, err
    for fragment in fragments:
        assert fragment in err, err
    return err


def config_file(tmp_path, scenario):
    path = tmp_path / "walk.toml"
    path.write_text(f"scenario = {json.dumps(scenario)}\n")
    return path


WALK = (EXAMPLE / "dronefleet_scenario_random_walk" / "__init__.py").read_text()


@pytest.mark.parametrize("text, fragment", [
    (None, "fails to load: ModuleNotFoundError"),
    ("raise RuntimeError('no licence server')\n", "fails to load: RuntimeError: no licence server"),
    ("import sys\nsys.exit(3)\n", "fails to load: ImportError: it calls sys.exit(3)"),
    (WALK.replace("\ndef simulate(config):", "\ndef simulated(config):"),
     "does not meet the scenario contract (docs/scenario-contract.md): has no simulate"),
    (WALK.replace("\ndef simulate(config):", "\ndef simulate(config, trials):"), "simulate does not take (config)"),
    (WALK.replace('NAME = "random_walk"', 'NAME = "walk"'), "its NAME is 'walk'"),
    (WALK.replace('"summary": pa.schema', '"totals": pa.schema').replace(
        'TABLES = ("robots", "summary")', 'TABLES = ("robots", "totals")'), "TABLES has no 'summary'"),
])
def test_an_installed_scenario_that_fails_to_load_or_breaks_the_contract_is_refused_in_one_line(
        tmp_path, monkeypatch, capsys, text, fragment):
    name = next(NAMES)
    install(tmp_path, name, f"{name}_module", None if text is None else f"{name}_module",
            (text or "").replace('NAME = "random_walk"', f'NAME = "{name}"'))
    monkeypatch.syspath_prepend(str(tmp_path))
    out = tmp_path / "out"
    refused(capsys, ["run", config_file(tmp_path, name), "--out", out],
            f"the {ENTRY_POINT_GROUP} entry point '{name}' ({name}_module) ", fragment)
    assert not out.exists()
    with pytest.raises(ConfigError, match=f"entry point '{name}'"):
        scenarios.get(name)


def walk(name, extra=""):
    """The example scenario's module as the scenario ``name``, with ``extra`` appended."""
    return WALK.replace('NAME = "random_walk"', f'NAME = "{name}"') + extra


def dronefleet_process(folder, *argv, limit_s=5.0):
    """``dronefleet argv`` in a process of its own (a broken plugin may end it), with the packages installed
    in ``folder`` and its plugin imports bounded at ``limit_s`` seconds (the shipped bound is 30 s)."""
    script = ("import sys; from dronefleet import cli, plugins; plugins.IMPORT_LIMIT_S = float(sys.argv[1]); "
              "sys.exit(cli.main(sys.argv[2:]))")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(map(str, (folder, ROOT)))}
    # the bound only detects a hang of the code before the fix: the limit ends a hanging import in seconds
    return subprocess.run([sys.executable, "-c", script, str(limit_s), *map(str, argv)], capture_output=True,
                          text=True, env=env, cwd=folder, timeout=240)


#: Installed scenarios broken one way each: (the module text of scenario ``name``, what the warning says).
BROKEN = {
    "study raises": (lambda name: walk(name, "\n\ndef study():\n    raise RuntimeError('no study today')\n"),
                     "its study fails: RuntimeError: no study today"),
    "study takes fig10": (lambda name: walk(name, STUDY.format(figures='"fig10",')),
                          "its study names its figure 'fig10', which 'replenishment' has"),
    "study without QUICK": (lambda name: walk(name, STUDY.format(figures='"walks",').replace(
        '    QUICK = "the same"\n', '')), "its study is no FigureStudy (docs/scenario-contract.md): its QUICK is a "
                                       "NoneType, not a str"),
    "import hangs": (lambda name: "import time\ntime.sleep(3600)\n", "fails to load: ImportError: its import "
                                                                       "does not end within 5 s"),
    "import calls os._exit": (lambda name: "import os\nos._exit(0)\n",
                              "fails to load: ImportError: its import ends the process (exit status 0)"),
    "import kills itself": (lambda name: "import os, signal\nos.kill(os.getpid(), signal.SIGKILL)\n",
                            "fails to load: ImportError: its import kills the process (SIGKILL)"),
}


@pytest.mark.parametrize("broken", [*BROKEN, "named delivery"])
def test_one_broken_installed_scenario_leaves_out_only_itself(tmp_path, broken):
    if broken == "named delivery":
        name, entry, fragment = "delivery", "the dronefleet.scenarios entry point 'delivery' (impostor)", \
            "is named like the built-in scenario"
        install(tmp_path, name, "impostor")
    else:
        name = next(NAMES)
        text, fragment = BROKEN[broken]
        install(tmp_path, name, f"{name}_module", f"{name}_module", text(name))
        entry = f"installed scenario {name!r} left out"
    # the built-in studies are listed, the broken one left out in one warning line
    listed = dronefleet_process(tmp_path, "reproduce", "--list")
    assert listed.returncode == 0, listed.stderr
    assert all(figure in listed.stdout.split() for figure in ("fig16", "fig10", "items-fig03", "lunar-fig03"))
    assert len(listed.stderr.splitlines()) == 1 and "left out" in listed.stderr, listed.stderr
    assert entry in listed.stderr and fragment in listed.stderr, listed.stderr
    # a built-in figure is still drawn
    shutil.copytree(ROOT / "results" / "fig10", tmp_path / "figures" / "fig10",
                    ignore=shutil.ignore_patterns("*.png", "*.pdf", "*.svg"))
    drawn = dronefleet_process(tmp_path, "reproduce", "fig10", "--redraw", "--jobs", "1", "--out", "figures")
    assert drawn.returncode == 0 and "Traceback" not in drawn.stderr, drawn.stderr
    assert (tmp_path / "figures" / "fig10" / "fig10.png").is_file()
    if "import" in broken:  # what names it is refused in one line naming it
        ran = dronefleet_process(tmp_path, "run", config_file(tmp_path, name), "--out", tmp_path / "out")
        assert ran.returncode == 2 and len(ran.stderr.splitlines()) == 1, ran.stderr
        assert f"entry point '{name}' ({name}_module)" in ran.stderr and fragment in ran.stderr, ran.stderr
        assert not (tmp_path / "out").exists()


def test_an_installed_scenario_named_like_a_built_in_is_left_out(tmp_path, monkeypatch, capsys):
    install(tmp_path, "delivery", "impostor")
    monkeypatch.syspath_prepend(str(tmp_path))
    assert "delivery" not in scenarios.installed() and "delivery" in scenarios.loading()
    assert scenarios.get("delivery") is scenarios.SCENARIOS["delivery"]  # the built-in is what a config runs
    assert "is named like the built-in scenario" in capsys.readouterr().err


def test_one_scenario_name_of_two_installed_packages_is_refused_naming_both(tmp_path, monkeypatch, capsys):
    name = next(NAMES)
    for distribution in ("alpha-walks", "beta-walks"):
        module = f"{name}_{distribution[:4]}"
        install(tmp_path, name, module, module, walk(name), distribution)
    monkeypatch.syspath_prepend(str(tmp_path))
    both = f"is declared by several installed distributions: alpha-walks ({name}_alph), beta-walks ({name}_beta)"
    refused(capsys, ["run", config_file(tmp_path, name), "--out", tmp_path / "out"], f"entry point '{name}'", both)
    assert not (tmp_path / "out").exists()
    with pytest.raises(SystemExit) as stop:
        cli.main(["reproduce", "--list"])
    printed = capsys.readouterr()
    assert stop.value.code == 0 and "fig16" in printed.out and name not in printed.out
    assert len(printed.err.splitlines()) == 1 and "left out" in printed.err and both in printed.err


def test_ctrl_c_while_a_plugin_import_is_tried_exits_130_and_ends_the_try(tmp_path):
    name = next(NAMES)
    started = tmp_path / "started"
    install(tmp_path, name, f"{name}_module", f"{name}_module",
            f"import os, time\nopen({str(started)!r} + '.tmp', 'w').write(str(os.getpid()))\n"
            f"os.replace({str(started)!r} + '.tmp', {str(started)!r})\ntime.sleep(3600)\n")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(map(str, (tmp_path, ROOT)))}
    process = subprocess.Popen([sys.executable, "-m", "dronefleet.cli", "reproduce", "--list"], env=env, cwd=tmp_path,
                               stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    try:
        for _ in range(2400):  # a generous bound (240 s) on the start of the import, not a timing
            if started.exists() or process.poll() is not None:
                break
            time.sleep(0.1)
        importer = int(started.read_text())
        assert importer != process.pid  # tried in a child process, not in dronefleet's own
        process.send_signal(signal.SIGINT)
        err = process.communicate(timeout=240)[1]
    finally:
        process.kill()
    assert process.returncode == 130 and "Traceback" not in err, err
    assert err.splitlines()[-1] == f"dronefleet: interrupted while importing module '{name}_module' of scenario '{name}'"
    with pytest.raises(ProcessLookupError):  # the child was ended and reaped
        os.kill(importer, 0)


@pytest.mark.parametrize("text", [
    "raise RuntimeError('no licence server')\n",
    WALK.replace("\ndef simulate(config):", "\ndef simulated(config):"),  # imports, breaks the contract
])
def test_a_broken_installed_scenario_breaks_only_what_names_it(tmp_path, monkeypatch, capsys, text):
    name = next(NAMES)
    install(tmp_path, name, f"{name}_module", f"{name}_module", text.replace('NAME = "random_walk"', f'NAME = "{name}"'))
    monkeypatch.syspath_prepend(str(tmp_path))
    entry = f"the {ENTRY_POINT_GROUP} entry point '{name}' ({name}_module)"
    # the built-in studies are listed; the broken one is left out, said in one line on stderr
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(map(str, (tmp_path, ROOT)))}
    listed = subprocess.run([sys.executable, "-m", "dronefleet.cli", "reproduce", "--list"], capture_output=True,
                            text=True, env=env, cwd=tmp_path, timeout=300)
    assert listed.returncode == 0, listed.stderr
    assert "fig16" in listed.stdout and "fig09" in listed.stdout and "items-ttests" in listed.stdout
    assert len(listed.stderr.splitlines()) == 1 and entry in listed.stderr and "left out" in listed.stderr

    def own_refusal(argv, fragment):  # the command's own one-line error; at most the warning beside it
        assert cli.main([str(arg) for arg in argv]) == 2
        *warned, error = capsys.readouterr().err.splitlines()
        assert fragment in error and entry not in error and all("left out" in line for line in warned)

    # a built-in figure reaches its own check (no tables to redraw), not the broken scenario
    own_refusal(["reproduce", "fig17", "--redraw", "--out", tmp_path / "results"],
                "run dronefleet reproduce fig17 without --redraw first")
    # a built-in config's own refusal names the scenarios with bounds, not the broken one's error
    own_refusal(["bounds", ROOT / "configs" / "items.toml"], "analytic bounds exist only for replenishment")
    # a built-in run and its replay page
    run = tmp_path / "run"
    assert cli.main(["run", str(ROOT / "configs" / "replenishment.toml"), "--set", "trials=1", "--set", "ticks=100",
                     "--out", str(run)]) == 0
    assert cli.main(["replay", str(run), "--out", str(tmp_path / "page.html")]) == 0
    assert (tmp_path / "page.html").is_file()
    # what names the broken scenario is refused in one line naming it
    refused(capsys, ["run", config_file(tmp_path, name), "--out", tmp_path / "out"], entry)
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("named", ["sidefx", "sidefx:simulate", "dronefleet.delivery.scenario", "os"])
def test_a_config_selects_a_registered_scenario_never_a_module(tmp_path, monkeypatch, capsys, named):
    (tmp_path / "sidefx.py").write_text(f"open({str(tmp_path / 'imported')!r}, 'w').close()\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    refused(capsys, ["run", config_file(tmp_path, named)], f"unknown scenario {named!r}",
            "registered scenarios: delivery, replenishment")
    sweep = tmp_path / "sweep.toml"
    sweep.write_text(f"[sweep]\nname = 'x'\nscenario = {json.dumps(named)}\nseeds = [0]\n")
    refused(capsys, ["sweep", "plan", sweep, "--results", tmp_path / "results"], f"unknown scenario {named!r}")
    assert not (tmp_path / "imported").exists() and "sidefx" not in sys.modules
    assert not (tmp_path / "results").exists()


def test_reproduce_lists_every_study_and_its_figures(capsys):
    with pytest.raises(SystemExit) as stop:
        cli.main(["reproduce", "--list"])
    printed = capsys.readouterr().out.splitlines()
    assert stop.value.code == 0
    assert printed[0].startswith("delivery: ") and "D4.4" in printed[0]
    assert printed[1].split() == ["fig16", "fig17", "fig18", "fig19", "fig20"]
    assert printed[2].startswith("replenishment: ") and printed[3].split() == ["fig09", "fig10", "fig11", "fig12"]


#: A study of the random walk: one figure, its table the robots of one run.
STUDY = """

class _Study:
    TITLE = "random walks"
    FIGURES = ({figures})
    QUICK = "the same"
    TABLE_COLUMNS = {{"robots": {{"robot": "count", "moved": "count"}}}}

    def run_together(self, study, figures):
        pass

    def tidy(self, study, figure):
        table = simulate(Config(**DEFAULTS))["robots"].to_pandas()
        study.write_table(table, study.figure_dir(figure) / "robots.parquet")

    def draw(self, study, figure):
        return [study.figure_dir(figure) / f"{{len(study.read_table(figure, 'robots'))}}.txt"]

    def check(self, study, figure):
        return []


def study():
    return _Study()
"""


def test_an_installed_scenarios_study_is_listed_and_reproduced(tmp_path, monkeypatch, capsys):
    name = next(NAMES)
    install(tmp_path, name, f"{name}_module", f"{name}_module",
            WALK.replace('NAME = "random_walk"', f'NAME = "{name}"') + STUDY.format(figures=f'"{name}-fig1",'))
    monkeypatch.syspath_prepend(str(tmp_path))
    with pytest.raises(SystemExit):
        cli.main(["reproduce", "--list"])
    assert f"{name}: random walks\n  {name}-fig1\n" in capsys.readouterr().out
    assert cli.main(["reproduce", f"{name}-fig1", "--out", str(tmp_path / "out")]) == 0
    assert pq.read_table(tmp_path / "out" / f"{name}-fig1" / "robots.parquet").num_rows == 4


@pytest.fixture(scope="module")
def example_site(tmp_path_factory):
    """The example package installed as a user would, into a folder of its own (from a copy: the
    build leaves files beside the sources)."""
    tmp = tmp_path_factory.mktemp("example")
    source, site = tmp / "source", tmp / "site"
    shutil.copytree(EXAMPLE, source, ignore=shutil.ignore_patterns("__pycache__", "build", "*.egg-info"))
    subprocess.run([sys.executable, "-m", "pip", "install", "--quiet", "--no-deps", "--no-build-isolation",
                    "--target", str(site), str(source)], check=True, capture_output=True, timeout=300)
    return site


def test_the_installed_example_meets_the_contract(example_site, tmp_path, monkeypatch):
    monkeypatch.syspath_prepend(str(example_site))
    assert "random_walk" in scenarios.installed()
    check_contract("random_walk", tmp_path)


def test_the_installed_example_runs_through_run_a_local_sweep_and_the_api(example_site, tmp_path):
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(map(str, (example_site, ROOT)))}

    def dronefleet(*argv):
        done = subprocess.run([sys.executable, "-m", "dronefleet.cli", *map(str, argv)], capture_output=True,
                              text=True, env=env, cwd=tmp_path, timeout=300)
        assert done.returncode == 0, done.stderr
        return done.stdout

    (tmp_path / "walk.toml").write_text('scenario = "random_walk"\n[run]\nseed = 2\nn_robots = 5\n')
    printed = dronefleet("run", "walk.toml", "--set", "steps=80", "--out", "run")
    assert "stranded robots" in printed
    ran = pq.read_table(tmp_path / "run" / "summary.parquet").to_pylist()
    (tmp_path / "walks.toml").write_text('[sweep]\nname = "walks"\nbase = "walk.toml"\nseeds = [1, 2]\n'
                                         '[set]\nsteps = 80\n[grid]\nbattery = [30, 40]\n')
    dronefleet("sweep", "run", "walks.toml", "--results", "results", "--jobs", "2")
    # the run of the sweep with the run's config (its seed a partition key, not a column): the same numbers
    swept = pq.read_table(tmp_path / "results" / "walks" / "summary" / "battery=30" / "seed=2" / "part-0.parquet")
    assert [{**row, "seed": 2} for row in swept.to_pylist()] == ran
    dronefleet("sweep", "collect", "walks.toml", "--results", "results")
    assert pq.read_table(tmp_path / "results" / "walks" / "collected.parquet").num_rows == 4
    api = subprocess.run([sys.executable, "-c", "import dronefleet, json; r = dronefleet.run('random_walk', seed=2, "
                          "n_robots=5, steps=80); print(json.dumps(r.summary.to_dict('records')))"],
                         capture_output=True, text=True, env=env, cwd=tmp_path, timeout=300, check=True)
    assert json.loads(api.stdout) == ran


def test_every_built_in_study_is_a_figure_study_by_the_check_installed_ones_meet():
    from dronefleet import reproduce
    from dronefleet.contract import study_problems

    assert {name: study_problems(study) for name, study in reproduce.studies().items()} == \
        {name: [] for name in ("delivery", "replenishment", "items", "lunar")}
    assert study_problems(object()) == [
        "its TITLE is a NoneType, not a str", "its QUICK is a NoneType, not a str",
        "its FIGURES is a NoneType, not a tuple", "its TABLE_COLUMNS is a NoneType, not a Mapping",
        "its run_together does not take (study, figures)", "its tidy does not take (study, figure)",
        "its draw does not take (study, figure)", "its check does not take (study, figure)"]
    # an optional member, if present, is of its type (reproduce looks a table's name up in it)
    assert "its MAY_BE_EMPTY is a str, not a tuple" in study_problems(types.SimpleNamespace(MAY_BE_EMPTY="deaths"))
