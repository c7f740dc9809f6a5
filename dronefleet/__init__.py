"""dronefleet: fast, bit-reproducible simulators of robot and drone fleets that manage their energy.

Two scenarios, each a subpackage behind one contract (:mod:`dronefleet.scenarios`): UAV
delivery (:mod:`dronefleet.delivery`, docs/delivery-model.md) and energy replenishment
(:mod:`dronefleet.replenishment`, docs/replenishment-model.md); parameter sweeps are
:mod:`dronefleet.sweeps`.

From Python: ``dronefleet.run(...)`` simulates one run, ``dronefleet.sweep(grid, ...)`` a
grid of runs, of any scenario (:mod:`dronefleet.api`).
"""

__version__ = "0.1.0"

from .api import Run, run, sweep

__all__ = ["Run", "__version__", "run", "sweep"]
