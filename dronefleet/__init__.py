"""dronefleet: event-driven simulator of on-demand parcel delivery by UAV fleets.

The model is ``docs/delivery-model.md`` of the study; the tree follows its domain:
orders, energy, policy, auction, supervisor, engine, records, config, cli.

From Python: ``dronefleet.run(...)`` simulates one run, ``dronefleet.sweep(grid, ...)`` a
grid of runs, of any scenario (:mod:`dronefleet.api`).
"""

__version__ = "0.1.0"

from types import ModuleType

from . import api
from . import sweep as _sweep_machinery
from .api import Run, run

__all__ = ["Run", "__version__", "run", "sweep"]


class _CallableModule(ModuleType):
    """``dronefleet.sweep`` is both the module of the sweep machinery (which the package and
    its users import as ``from dronefleet import sweep``) and the function
    :func:`dronefleet.api.sweep`: a module cannot be replaced by a function under its own
    name (importing it sets the attribute back), so calling the module calls the function."""

    __call__ = staticmethod(api.sweep)


_sweep_machinery.__class__ = _CallableModule
