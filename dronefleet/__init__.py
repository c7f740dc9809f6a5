"""dronefleet: fast, bit-reproducible simulators of robot and drone fleets that manage their energy.

Two scenarios, each a subpackage behind one contract (:mod:`dronefleet.scenarios`): UAV
delivery (:mod:`dronefleet.delivery`, docs/delivery-model.md) and energy replenishment
(:mod:`dronefleet.replenishment`, docs/replenishment-model.md); parameter sweeps are
:mod:`dronefleet.sweeps`.

From Python: ``dronefleet.run(...)`` simulates one run, ``dronefleet.sweep(grid, ...)`` a
grid of runs, of any scenario (:mod:`dronefleet.api`); ``dronefleet.sensitivity(sweep, metrics)``
the sensitivity indices of a sampled design's runs (:mod:`dronefleet.analyze`).
"""

from typing import TYPE_CHECKING, Any

from .provenance import __version__

__all__ = ["Run", "__version__", "run", "sensitivity", "sweep"]

if TYPE_CHECKING:
    from .analyze import sensitivity
    from .api import Run, run, sweep


def __getattr__(name: str) -> Any:
    # The API is imported on first use, not with the package: the command line (dronefleet.__main__)
    # imports its modules where a Ctrl-C can be answered, and `import dronefleet.config` stays light.
    if name in ("Run", "run", "sweep"):
        from . import api

        return getattr(api, name)
    if name == "sensitivity":
        from .analyze import sensitivity

        return sensitivity
    raise AttributeError(f"module 'dronefleet' has no attribute {name!r}")
