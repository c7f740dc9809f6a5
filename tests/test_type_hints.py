"""The public API keeps its type hints: every public function and method of the Python
orchestration modules annotates each parameter and its return value.

Read from the source (``ast``), so nothing is imported or compiled. Compiled kernels
(``@njit``) are left out: numba types them from their arguments, and the engine's modules
(``delivery/engine.py``, ``replenishment/kernel.py``, ...) are not listed at all.
"""

import ast
from pathlib import Path

import pytest

import dronefleet

PACKAGE = Path(dronefleet.__file__).resolve().parent
#: The modules whose public functions must be annotated, relative to the package.
MODULES = (
    *(f"{name}.py" for name in ("api", "cli", "config", "console", "outputs", "provenance", "records", "replay",
                                "reproduce", "scenarios", "sweeps", "executors", "figstyle", "fingerprint",
                                "supervisor", "contract", "plugins")),
    *(f"delivery/{name}.py" for name in ("config", "scenario", "simulation", "fleet", "records", "metrics",
                                         "analysis", "figures", "orders", "replay")),
    *(f"replenishment/{name}.py" for name in ("params", "bounds", "config", "scenario", "simulate", "experiments",
                                              "study", "figures", "replay")),
)


def _compiled(function):
    """True for a numba kernel: decorated with ``njit``/``jit``/``borrowing``, called or not."""
    for decorator in function.decorator_list:
        target = decorator.func if isinstance(decorator, ast.Call) else decorator
        name = target.id if isinstance(target, ast.Name) else getattr(target, "attr", None)
        if name in ("njit", "jit", "borrowing"):
            return True
    return False


def _public_functions(tree):
    """``(function, is_method)`` of the module's public functions and its public classes'
    public methods (and ``__init__``), compiled kernels left out."""
    def wanted(node, method):
        return (isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) and not _compiled(node)
                and (not node.name.startswith("_") or (method and node.name == "__init__")))

    for node in tree.body:
        if wanted(node, False):
            yield node, False
        elif isinstance(node, ast.ClassDef) and not node.name.startswith("_"):
            yield from ((member, True) for member in node.body if wanted(member, True))


def _missing(function, method):
    """Names of the parameters without an annotation, and ``return`` if that has none."""
    args = function.args
    parameters = [*args.posonlyargs, *args.args, *filter(None, [args.vararg]), *args.kwonlyargs,
                  *filter(None, [args.kwarg])]
    if method and parameters and parameters[0].arg in ("self", "cls"):
        parameters = parameters[1:]
    return [p.arg for p in parameters if p.annotation is None] + ([] if function.returns else ["return"])


def unannotated(source):
    """``name: [what lacks a hint]`` of every public function of ``source`` that is not fully annotated."""
    return [f"{function.name}: {', '.join(_missing(function, method))}"
            for function, method in _public_functions(ast.parse(source)) if _missing(function, method)]


@pytest.mark.parametrize("module", MODULES)
def test_every_public_function_is_annotated(module):
    source = (PACKAGE / module).read_text(encoding="utf-8")
    assert list(_public_functions(ast.parse(source))), f"{module} has no public function: is the list stale?"
    assert unannotated(source) == [], f"dronefleet/{module}: public functions without type hints"


def test_the_check_finds_what_lacks_a_hint():
    source = '''
def bare(a, b: int = 1, *args, key=None, **options): ...
def partial(a: int): ...
def full(a: int, *, key: str | None = None) -> None: ...
def _private(a): ...
@njit(cache=True)
def kernel(x): ...
class Machine:
    def __init__(self, n: int): ...
    def step(self, event) -> int: ...
    @property
    def size(self): ...
    def _helper(self, x): ...
class _Hidden:
    def shown(self, x): ...
'''
    assert unannotated(source) == ["bare: a, args, key, options, return", "partial: return",
                                   "__init__: return", "step: event", "size: return"]
