"""numba's ``njit`` for the compiled kernels: cached by their source, loaded without scipy's linear algebra.

**Never a kernel compiled from other source.** numba's disk cache checks only the file that
defines a kernel, but a kernel also holds, compiled in, every function it calls or inlines
from other modules (:mod:`dronefleet.fpmath`, :mod:`dronefleet.rng`, :mod:`dronefleet.supervisor`
...) and the values of the module constants it reads. So :func:`njit` (and :func:`borrowing`)
puts a cached kernel's files in a folder named by a digest of the source of its module and of
every module of this package that module imports, directly or not (:func:`source_digest`):
after an edit of any of them (a ``git pull``, a change to the model in an editable install),
the kernels that depend on it compile again, and the others load as before. Every compiled
kernel of the package takes ``njit`` from here, never from numba (``tests/test_jit.py``).

The folders are under numba's own ``NUMBA_CACHE_DIR`` if it is set (a sweep's job script sets
it), else in the package's ``__pycache__`` where numba would put them, else, if that cannot be
written (an installed, read-only package), in the user's cache folder (``$XDG_CACHE_HOME``,
default ``~/.cache``, then ``dronefleet``): :func:`cache_root`. A folder of a digest no longer
in use is left as it is (a few MB per scenario; delete the ``kernels-*`` folders to reclaim it).

**Start-up.** The first call of any compiled function (compiled or loaded from the cache) makes
numba import its implementations of numpy, and one of them, ``numba.np.arraymath``, probes for
BLAS by importing ``scipy.linalg``: 0.15-0.3 s of every process's start-up, for functions the
kernels do not use (no BLAS on the trajectory path: its results depend on the CPU; see
CONTRIBUTING.md). So that module is imported here, once, while ``scipy.linalg`` is marked as
missing: the probe fails quietly, and ``scipy.linalg`` itself is untouched and imports normally
afterwards, when something needs it (scikit-learn, or numba compiling a function that does use
linear algebra). If scipy.linalg is already imported, there is nothing to save and numba loads
as usual.
"""

import atexit
import contextlib
import functools
import hashlib
import importlib
import os
import re
import shutil
import sys
import tempfile
from collections.abc import Callable, Iterator
from pathlib import Path

import numba

from .config import check_numba_cache_dir

__all__ = ["borrowing", "cache_root", "njit", "source_digest"]

#: The package whose modules a kernel's digest covers.
_PACKAGE = Path(__file__).resolve().parent

# `from X import names` (names possibly in parentheses, over lines) and `import dronefleet.X`,
# anywhere in a module: an import inside a function counts too (more modules than needed only
# costs a compilation, one too few a stale kernel).
_FROM_IMPORT = re.compile(r"^[ \t]*from[ \t]+([.\w]+)[ \t]+import[ \t]+(\([^)]*\)|[^\n]*)", re.MULTILINE)
_PLAIN_IMPORT = re.compile(r"^[ \t]*import[ \t]+(dronefleet(?:\.\w+)*)", re.MULTILINE)


def _module_file(dotted: str) -> Path | None:
    """The source file of the package's module ``dotted`` (``dronefleet.x.y``), or None if it is none."""
    parts = dotted.split(".")
    if parts[0] != _PACKAGE.name:
        return None
    base = _PACKAGE.joinpath(*parts[1:])
    for candidate in (base.with_suffix(".py"), base / "__init__.py"):
        if candidate.is_file():
            return candidate
    return None


def _dotted(path: Path) -> str:
    """``dronefleet/x/y.py`` -> ``dronefleet.x.y`` (a package's ``__init__.py`` -> the package)."""
    parts = path.relative_to(_PACKAGE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


@functools.cache
def _imports(path: Path) -> frozenset[Path]:
    """The package's modules that the module at ``path`` imports."""
    text = path.read_text(encoding="utf-8")
    package = _dotted(path) if path.name == "__init__.py" else _dotted(path).rpartition(".")[0]
    found = {_module_file(name) for name in _PLAIN_IMPORT.findall(text)}
    for source, names in _FROM_IMPORT.findall(text):
        if source.startswith("."):
            dots = len(source) - len(source.lstrip("."))
            anchor = package.split(".")[:len(package.split(".")) - dots + 1]
            source = ".".join([*anchor, source.lstrip(".")]).rstrip(".")
        found.add(_module_file(source))
        for name in re.findall(r"\w+", names.split("#")[0]):  # a name may be a submodule
            found.add(_module_file(f"{source}.{name}"))
    return frozenset(found - {None})


@functools.cache
def source_digest(path: Path) -> str:
    """SHA-256 (hex, 16 digits) of the source of the package's module at ``path`` and of every
    module of the package it imports, directly or through others; sorted by path, so that it
    is the same in every process and on every machine with the same files."""
    closure, pending = set(), [Path(path).resolve()]
    while pending:
        module = pending.pop()
        if module not in closure:
            closure.add(module)
            pending.extend(_imports(module))
    digest = hashlib.sha256()
    for module in sorted(closure):
        digest.update(module.relative_to(_PACKAGE.parent).as_posix().encode() + b"\0")
        digest.update(module.read_bytes() + b"\0")
    return digest.hexdigest()[:16]


def _writable(folder: Path) -> bool:
    try:
        folder.mkdir(parents=True, exist_ok=True)
        tempfile.TemporaryFile(dir=folder).close()
    except OSError:
        return False
    return True


@functools.cache
def cache_root(numba_cache_dir: str) -> Path:
    """Where the kernels' cache folders go (see the module doc), given numba's ``NUMBA_CACHE_DIR``
    (empty: unset; ConfigError if it cannot be written). The first of them that can be written; if
    none can, a folder of this process's own, removed at its end (every kernel compiles, and
    nothing stale can load)."""
    if numba_cache_dir:
        check_numba_cache_dir({"NUMBA_CACHE_DIR": numba_cache_dir})
        candidates = [Path(numba_cache_dir)]
    else:
        user_cache = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
        candidates = [_PACKAGE / "__pycache__", user_cache / "dronefleet"]
    for candidate in candidates:
        if _writable(candidate):
            return candidate
    private = tempfile.mkdtemp(prefix="dronefleet-kernels-")
    atexit.register(shutil.rmtree, private, ignore_errors=True)
    return Path(private)


@contextlib.contextmanager
def _caching_by_source(function: Callable) -> Iterator[None]:
    """numba's cache folder, while ``function`` is decorated, is the folder of its module's digest.

    numba picks a function's cache folder when it is decorated (``config.CACHE_DIR`` first), so
    the setting is changed around the decoration only and numba's own value restored after it.
    """
    path = Path(function.__code__.co_filename)
    if not path.resolve().is_relative_to(_PACKAGE):  # not a module of this package's: numba's own rules
        yield
        return
    user = numba.config.CACHE_DIR
    numba.config.CACHE_DIR = str(cache_root(user) / f"kernels-{source_digest(path)}")
    try:
        yield
    finally:
        numba.config.CACHE_DIR = user


def njit(function: Callable | None = None, **options):
    """numba's ``njit``; with ``cache=True``, cached by the source the kernel depends on (module doc)."""
    if function is None:
        return functools.partial(njit, **options)
    if not options.get("cache"):
        return numba.njit(function, **options)
    with _caching_by_source(function):
        return numba.njit(function, **options)


def borrowing(function=None, **options):
    """``njit(cache=True)`` without numba's reference counting, for kernels that borrow their arrays.

    A kernel that allocates nothing and reads and writes only arrays its caller holds for the
    whole call needs no reference counts: numba's would incref and decref every array a call
    passes (each an atomic operation; the delivery engine passes ~57 per call in its state
    tuples), and its pruning cannot remove them around a call of another kernel. That was
    28-31 % of the paper run (docs/guide/benchmarks.md). numba compiles its own hot string helpers
    the same way (``_nrt=False``). Such a kernel must not allocate: numba then refuses it when
    compiling. The functions it calls inherit the setting; one that allocates (a sort) must be
    compiled with ``_nrt=True`` said explicitly (see ``delivery.engine._sort``). And none of them
    may return an array: numba keeps one compiled version of a function per signature, so one
    compiled for a borrowing kernel also serves ordinary compiled code, which would release the
    returned array once too often (``tests/test_jit.py``).
    """
    return njit(function, cache=True, _nrt=False, **options)


if "scipy.linalg" not in sys.modules and "numba.np.arraymath" not in sys.modules:
    sys.modules["scipy.linalg"] = None  # an import of it now raises ImportError, which numba catches
    try:
        importlib.import_module("numba.np.arraymath")
    finally:
        del sys.modules["scipy.linalg"]
