"""numba's ``njit`` for the compiled kernels, loaded without scipy's linear algebra.

The first call of any compiled function (compiled or loaded from the cache) makes numba
import its implementations of numpy, and one of them, ``numba.np.arraymath``, probes for
BLAS by importing ``scipy.linalg``: 0.15-0.3 s of every process's start-up, for functions
the kernels do not use (no BLAS on the trajectory path: its results depend on the CPU;
see CONTRIBUTING.md). So that module is imported here, once, while ``scipy.linalg`` is
marked as missing: the probe fails quietly, and ``scipy.linalg`` itself is untouched and
imports normally afterwards, when something needs it (scikit-learn, or numba compiling a
function that does use linear algebra).

The modules at the root of every kernel (:mod:`dronefleet.fpmath`,
:mod:`dronefleet.supervisor`) take ``njit`` from here, so this runs before any kernel does.
If scipy.linalg is already imported, there is nothing to save and numba loads as usual.
"""

import importlib
import sys

from numba import njit

__all__ = ["borrowing", "njit"]


def borrowing(function=None, **options):
    """``njit(cache=True)`` without numba's reference counting, for kernels that borrow their arrays.

    A kernel that allocates nothing and reads and writes only arrays its caller holds for the
    whole call needs no reference counts: numba's would incref and decref every array a call
    passes (each an atomic operation; the delivery engine passes ~57 per call in its state
    tuples), and its pruning cannot remove them around a call of another kernel. That was
    28-31 % of the paper run (docs/guide/benchmarks.md). numba compiles its own hot string helpers
    the same way (``_nrt=False``). Such a kernel must not allocate: numba then refuses it when
    compiling. The functions it calls inherit the setting; one that allocates (a sort) must be
    compiled with ``_nrt=True`` said explicitly (see ``delivery.engine._sort``).
    """
    return njit(function, cache=True, _nrt=False, **options)


if "scipy.linalg" not in sys.modules and "numba.np.arraymath" not in sys.modules:
    sys.modules["scipy.linalg"] = None  # an import of it now raises ImportError, which numba catches
    try:
        importlib.import_module("numba.np.arraymath")
    finally:
        del sys.modules["scipy.linalg"]
