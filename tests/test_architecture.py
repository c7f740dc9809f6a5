"""The package's layers hold (docs/scenario-contract.md): each module imports only from its own layer
or below, the scenario packages are independent, and no import circle exists anywhere.

The layers are the ``[tool.importlinter]`` contracts of pyproject.toml, checked by ``lint-imports``;
the import graph is grimp's (import-linter's), which counts every import: at the top of a module,
inside a function, and under ``if TYPE_CHECKING``.
"""

import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

import grimp
import pytest

ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture(scope="module")
def graph():
    return grimp.build_graph("dronefleet", cache_dir=None)  # writes no cache into the repository


def _contracts():
    return tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["importlinter"]["contracts"]


def test_lint_imports_keeps_every_contract():
    # the executable beside this interpreter (a venv's bin/), else the one on PATH
    lint = shutil.which("lint-imports", path=str(Path(sys.executable).parent)) or shutil.which("lint-imports")
    assert lint is not None, "lint-imports is not installed: pip install -e '.[test]'"
    done = subprocess.run([lint, "--no-cache"], cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stdout + done.stderr
    assert f"{len(_contracts())} kept, 0 broken" in done.stdout


def test_every_module_of_the_package_is_in_a_layer(graph):
    (layers,) = [contract["layers"] for contract in _contracts() if contract["type"] == "layers"]
    placed = {name.strip() for layer in layers for name in layer.replace("|", ":").split(":")}
    children = {module.removeprefix("dronefleet.") for module in graph.find_children("dronefleet")}
    assert children - placed == set(), "place each new module in a layer of pyproject.toml's [tool.importlinter]"
    assert placed - children == set()


def test_no_module_imports_one_that_imports_it_back(graph):
    circles = [graph.find_shortest_chain(importer=imported, imported=importer)
               for importer in sorted(graph.modules) if importer.startswith("dronefleet")
               for imported in sorted(graph.find_modules_directly_imported_by(importer))
               if graph.chain_exists(importer=imported, imported=importer)]
    assert circles == [], "\n".join(f"{chain[-1]} -> " + " -> ".join(chain) for chain in circles)
