"""The package as a user installs it: a wheel built from this tree, installed non-editable
(``pip install --target``), run from a directory that is not the repository.

The test environment has dronefleet installed editable; the wheel's copy goes first on
``PYTHONPATH``, and every check asserts that it is that copy which ran.
"""

import importlib.util
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
#: What the wheel is built from (copied, so that building leaves nothing in the tree).
SOURCES = ("pyproject.toml", "README.md", "LICENSE", "dronefleet", "configs")

pytestmark = pytest.mark.skipif(importlib.util.find_spec("setuptools") is None,
                                reason="building the wheel needs setuptools (pip install -e '.[test]')")


def _python(args, cwd, site, timeout=120):
    """``python args`` in ``cwd`` with only the wheel's copy of dronefleet on ``PYTHONPATH``."""
    env = {**os.environ, "PYTHONPATH": str(site)}
    done = subprocess.run([sys.executable, *args], cwd=cwd, env=env, capture_output=True, text=True,
                          timeout=timeout, stdin=subprocess.DEVNULL)
    assert done.returncode == 0, f"python {' '.join(map(str, args))}:\n{done.stdout}\n{done.stderr}"
    return done.stdout


@pytest.fixture(scope="module")
def installed(tmp_path_factory):
    """``(site, elsewhere)``: the folder the wheel is installed in, and an empty working directory."""
    tmp = tmp_path_factory.mktemp("package")
    source = tmp / "source"
    source.mkdir()
    for name in SOURCES:
        if (ROOT / name).is_dir():
            shutil.copytree(ROOT / name, source / name, ignore=shutil.ignore_patterns("__pycache__"))
        else:
            shutil.copy2(ROOT / name, source / name)
    pip = [sys.executable, "-m", "pip", "--disable-pip-version-check", "--no-input"]
    # offline, with the environment's setuptools (the [test] extra pins one that builds wheels)
    subprocess.run([*pip, "wheel", "--no-deps", "--no-build-isolation", "--wheel-dir", str(tmp / "wheel"),
                    str(source)], check=True, capture_output=True, timeout=300)
    wheel, = (tmp / "wheel").glob("dronefleet-*.whl")
    site = tmp / "site"
    subprocess.run([*pip, "install", "--no-deps", "--no-index", "--target", str(site), str(wheel)],
                   check=True, capture_output=True, timeout=300)
    elsewhere = tmp / "elsewhere"
    elsewhere.mkdir()
    return site, elsewhere


def _files(folder, prefix=""):
    """The files below ``folder`` as ``prefix`` + relative paths, leaving out caches (__pycache__)."""
    return {prefix + p.relative_to(folder).as_posix() for p in folder.rglob("*")
            if p.is_file() and "__pycache__" not in p.relative_to(folder).parts}


def test_the_wheel_holds_every_file_of_the_package_and_of_configs(installed):
    # a subpackage or data file missing from pyproject.toml's lists would be missing here
    site, _ = installed
    assert _files(site / "dronefleet") == _files(ROOT / "dronefleet") | _files(ROOT / "configs", "configs/")


def test_the_installed_copy_finds_its_configs_and_says_its_version(installed):
    site, elsewhere = installed
    probe = ("import dronefleet, importlib.metadata, importlib.resources, json\n"
             "from dronefleet.config import shipped_config\n"
             "print(json.dumps([dronefleet.__file__, str(importlib.resources.files('dronefleet.configs')),\n"
             "                  str(shipped_config('sweeps', 'rules.toml')), importlib.metadata.version('dronefleet')]))")
    package, configs, rules, version = json.loads(_python(["-c", probe], elsewhere, site))
    assert Path(package).parent == site / "dronefleet"
    assert Path(configs) == site / "dronefleet" / "configs"
    assert Path(rules) == site / "dronefleet" / "configs" / "sweeps" / "rules.toml"
    # the installed version, without a git commit: an installed copy is no checkout
    assert _python(["-m", "dronefleet", "--version"], elsewhere, site) == f"dronefleet {version}\n"
    # the reproduce study loads its sweep files (and the paper config they name as base) from the package
    probe = ("import logging\nfrom dronefleet import console, reproduce\nconsole.configure(logging.DEBUG)\n"
             "study = reproduce.Study('results', quick=True)\nprint(study.sweep('rules').runs[0].config.n_uavs)")
    out = _python(["-c", probe], elsewhere, site)
    assert f"  sweep rules: {site / 'dronefleet' / 'configs' / 'sweeps' / 'rules.toml'}\n" in out
    assert out.endswith("\n25\n")  # the sweep's base, ../paper.toml, was found beside it


def test_the_installed_copy_lists_and_takes_its_shipped_files_by_name(installed):
    site, elsewhere = installed
    shipped = site / "dronefleet" / "configs"
    listed = _python(["-m", "dronefleet", "configs"], elsewhere, site)
    assert f"(in {shipped})" in listed and f"(in {shipped / 'sweeps'})" in listed and "\n  rules " in listed
    assert _python(["-m", "dronefleet", "bounds"], elsewhere, site).startswith("dronefleet bounds: replenishment,")
    _python(["-m", "dronefleet", "sweep", "plan", "rules", "--results", "plans"], elsewhere, site)
    assert str(shipped / "sweeps" / "rules.toml") in (elsewhere / "plans" / "rules" / "rules.sbatch").read_text()


def test_python_dash_m_dronefleet_runs_from_another_directory(installed):
    site, elsewhere = installed
    out = _python(["-m", "dronefleet", "run", "--set", "horizon_weeks=0.02", "--set", "n_uavs=3", "--out", "X"],
                  elsewhere, site, timeout=600)  # the installed copy compiles the engine afresh
    assert "orders arrived" in out
    assert sorted(p.name for p in (elsewhere / "X").iterdir()) == [
        "attempts.parquet", "fleet.parquet", "orders.parquet", "summary.parquet", "timeseries.parquet"]
