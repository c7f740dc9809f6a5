"""No result from stale compiled code: a kernel's cache is keyed by the source of everything it imports.

numba's own cache checks only the file defining a kernel; :mod:`dronefleet.jit` puts each cached
kernel in a folder named by the digest of its module and every module of the package that module
imports (directly or not). These tests hold every kernel to it, check the digest's import closure
against grimp's import graph, and run the stale-kernel reproducer: edit a shared module
(``fpmath.exp``) in a copy of the package, run again, get the edited code's numbers.
"""

import ast
import importlib
import os
import shutil
import subprocess
import sys
from pathlib import Path

import grimp
import pytest
from numba.core.dispatcher import Dispatcher

from dronefleet import jit

ROOT = Path(__file__).resolve().parent.parent
PACKAGE = ROOT / "dronefleet"


def _modules():
    for path in sorted(PACKAGE.rglob("*.py")):
        yield path, ".".join(path.relative_to(ROOT).with_suffix("").parts)


def _kernel_modules():
    return [(path, name) for path, name in _modules() if "cache=True" in path.read_text(encoding="utf-8")
            or "@borrowing" in path.read_text(encoding="utf-8")]


def test_every_module_takes_njit_from_dronefleet_jit():
    # numba's own njit would cache a kernel by its own file only
    offenders = []
    for path, name in _modules():
        if path.name == "jit.py" and path.parent == PACKAGE:
            continue
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom) and node.module and node.module.split(".")[0] == "numba":
                offenders += [f"{name}: from {node.module} import {a.name}" for a in node.names
                              if a.name in ("njit", "jit", "generated_jit", "cfunc", "vectorize", "guvectorize")]
            if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) and node.value.id == "numba" \
                    and node.attr in ("njit", "jit", "cfunc", "vectorize", "guvectorize"):
                offenders.append(f"{name}: numba.{node.attr}")
    assert offenders == []


def test_every_cached_kernel_lives_in_the_folder_of_its_source_digest():
    checked = 0
    for path, name in _kernel_modules():
        module = importlib.import_module(name)
        for value in vars(module).values():
            if isinstance(value, Dispatcher) and value.__module__ == name and value._cache.__class__.__name__ != \
                    "NullCache":
                folder = Path(value._cache.cache_path).parent
                assert folder.name == f"kernels-{jit.source_digest(path)}", (name, value.__name__, folder)
                checked += 1
    assert checked >= 40  # every scenario's kernels, fpmath's, rng's, the supervisor's


@pytest.fixture(scope="module")
def graph():
    return grimp.build_graph("dronefleet", cache_dir=None)


@pytest.mark.parametrize("name", [name for _, name in _kernel_modules()])
def test_the_digest_covers_every_module_the_kernel_module_imports(graph, name):
    # grimp counts every import (top, inside functions, under TYPE_CHECKING): the digest's closure
    # must hold at least those, or an edit of one would leave a stale kernel
    imported = {name, *graph.find_upstream_modules(name)}
    closure, pending = set(), [jit._module_file(name)]
    while pending:
        module = pending.pop()
        if module not in closure:
            closure.add(module)
            pending.extend(jit._imports(module))
    covered = {jit._dotted(path) for path in closure}
    assert imported - covered == set()


def _copy_package(tmp_path):
    shutil.copytree(PACKAGE, tmp_path / "dronefleet", ignore=shutil.ignore_patterns("__pycache__"))
    return tmp_path / "dronefleet"


def _python(tmp_path, code):
    env = {key: value for key, value in os.environ.items() if key not in ("NUMBA_CACHE_DIR", "PYTHONPATH")}
    env.update(PYTHONPATH=str(tmp_path), XDG_CACHE_HOME=str(tmp_path / "xdg"))
    done = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, env=env, capture_output=True, text=True,
                          timeout=600)
    assert done.returncode == 0, done.stderr
    return done.stdout.split()


def test_an_edit_of_an_imported_module_changes_exactly_the_digests_that_import_it(tmp_path):
    copy = _copy_package(tmp_path)
    code = ("from pathlib import Path; from dronefleet import jit, __file__ as f; p = Path(f).parent; "
            "print(*(jit.source_digest(p / m) for m in ('lunar/kernel.py', 'items/kernel.py', 'fpmath.py')))")
    before = _python(tmp_path, code)
    with open(copy / "rng.py", "a", encoding="utf-8") as rng:
        rng.write("\n# edited\n")
    after_rng = _python(tmp_path, code)
    assert after_rng[0] != before[0] and after_rng[1] != before[1]  # both kernels draw from rng
    assert after_rng[2] == before[2]  # fpmath does not import rng
    with open(copy / "cli.py", "a", encoding="utf-8") as cli:
        cli.write("\n# edited\n")
    assert _python(tmp_path, code) == after_rng  # no kernel imports the command line


def test_a_kernel_compiled_before_an_edit_of_a_module_it_calls_is_not_loaded(tmp_path):
    # the reproducer, on a small kernel: soc_after_charging calls fpmath.exp (inlined by LLVM)
    copy = _copy_package(tmp_path)
    code = ("from dronefleet.delivery.energy import soc_after_charging as f; v = f(20.0, 600.0, 1e-3); "
            "print(repr(v), f.stats.cache_hits.get(f.signatures[0], 0) if f.signatures else 0)")
    first, hits = _python(tmp_path, code)
    assert hits == "0"  # compiled: nothing cached yet
    again, hits = _python(tmp_path, code)
    assert (again, hits) == (first, "1")  # loaded from the cache: caching still works
    fpmath = copy / "fpmath.py"
    original = fpmath.read_text(encoding="utf-8")
    head = "def exp(x):\n"
    assert original.count(head) == 1
    body = original.index('"""', original.index('"""', original.index(head)) + 3) + 3
    fpmath.write_text(original[:body] + "\n    x = x * 1.01" + original[body:], encoding="utf-8")
    edited, hits = _python(tmp_path, code)
    assert hits == "0" and edited != first  # the edited exp's numbers, compiled anew
    fpmath.write_text(original, encoding="utf-8")
    restored, hits = _python(tmp_path, code)
    assert (restored, hits) == (first, "1")  # the unedited source's kernel is found again
    assert list((copy / "__pycache__").glob("kernels-*"))  # the package's own __pycache__, not a user folder


@pytest.mark.parametrize("kind", ["file", "under a file"])
def test_a_numba_cache_dir_where_kernels_cannot_be_written_is_refused_in_one_line(tmp_path, kind):
    afile = tmp_path / "afile"
    afile.write_text("mine\n")
    value = afile if kind == "file" else afile / "cache"
    env = {**os.environ, "NUMBA_CACHE_DIR": str(value)}
    done = subprocess.run([sys.executable, "-m", "dronefleet", "run", "replenishment", "--set", "trials=1",
                           "--set", "ticks=10", "--out", str(tmp_path / "out")], capture_output=True, text=True,
                          env=env, timeout=300)
    assert done.returncode == 2 and len(done.stderr.splitlines()) == 1, done.stderr
    assert f"NUMBA_CACHE_DIR={str(value)!r} is not a folder where the compiled kernels can be written" in done.stderr
    assert not (tmp_path / "out").exists() and afile.read_text() == "mine\n"


def test_with_no_writable_cache_folder_the_private_one_is_removed_at_exit(tmp_path):
    code = ("import atexit, sys; from pathlib import Path; from dronefleet import jit; "
            "jit._writable = lambda folder: False; root = jit.cache_root(''); print(root); "
            "assert root.is_dir() and root.name.startswith('dronefleet-kernels-')")
    root = Path(_python(tmp_path, code)[0])
    assert not root.exists()


_BORROWED_RETURNS = """
import importlib, pkgutil
from numba.core import types
from numba.core.dispatcher import Dispatcher
import dronefleet
from dronefleet import api

api.run("lunar", set={"runs": 1, "n_robots": 10, "duration_s": 60.0})
api.run("delivery", set={"horizon_weeks": 1})
api.run("items", set={"trials": 1, "steps": 50})

def holds_array(t):
    return isinstance(t, types.Array) or (isinstance(t, types.BaseTuple) and any(map(holds_array, t.types)))

for module in pkgutil.walk_packages(dronefleet.__path__, "dronefleet."):
    for name, value in vars(importlib.import_module(module.name)).items():
        if isinstance(value, Dispatcher) and value.__module__ == module.name:
            for compiled in value.overloads.values():
                if not compiled.target_context.enable_nrt and holds_array(compiled.signature.return_type):
                    print(f"{module.name}.{name} -> {compiled.signature.return_type}")
"""


def test_the_scenarios_with_borrowing_kernels_are_the_ones_checked_below():
    lenders = {path.resolve() for path, _ in _modules() if "@borrowing" in path.read_text(encoding="utf-8")}
    scenarios = set()
    for path, name in _kernel_modules():
        closure, pending = set(), [path.resolve()]
        while pending:
            module = pending.pop()
            if module not in closure:
                closure.add(module)
                pending.extend(jit._imports(module))
        if closure & lenders and name.count(".") == 2:  # dronefleet.<scenario>.<module>
            scenarios.add(name.split(".")[1])
    assert scenarios == {"delivery", "items", "lunar"}  # a new one: add a run of it to _BORROWED_RETURNS


def test_no_kernel_compiled_without_reference_counts_returns_an_array(tmp_path):
    # A function called from a `borrowing` kernel is compiled without reference counts too (numba
    # passes the setting on), and numba keeps one compiled version per signature, whoever called
    # first: called later from ordinary compiled code, an array it returns is a reference that
    # caller releases once too often (freed memory, then a crash in a later allocation). The
    # flags are known only for kernels compiled in this process: an empty cache folder.
    env = {**{key: value for key, value in os.environ.items() if key != "PYTHONPATH"},
           "NUMBA_CACHE_DIR": str(tmp_path / "cache")}
    done = subprocess.run([sys.executable, "-c", _BORROWED_RETURNS], cwd=tmp_path, env=env, capture_output=True,
                          text=True, timeout=900)
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout == ""
