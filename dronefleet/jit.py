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

__all__ = ["njit"]

if "scipy.linalg" not in sys.modules and "numba.np.arraymath" not in sys.modules:
    sys.modules["scipy.linalg"] = None  # an import of it now raises ImportError, which numba catches
    try:
        importlib.import_module("numba.np.arraymath")
    finally:
        del sys.modules["scipy.linalg"]
