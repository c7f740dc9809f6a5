"""The energy-replenishment scenario (docs/replenishment-model.md): workers shuttle between a
base and a work area and recharge at fixed chargers or from mobile chargers.

``Params`` (parameters and validation), ``simulate`` (all trials of one
configuration in one compiled kernel), ``bounds`` (analytic upper bounds).
"""

from .bounds import BoundUndefinedError, Bounds, bounds, constant_supply_bounds, fixed_bounds, fixed_work_ceiling
from .params import Params, ParamsError
from .simulate import simulate

__all__ = ["Params", "ParamsError", "simulate", "Bounds", "BoundUndefinedError", "bounds",
           "fixed_bounds", "fixed_work_ceiling", "constant_supply_bounds"]
