"""Multi-robot item delivery and foraging (Liemhetcharat, Yan, Tee, Lee; Robotics 2015).

The model is in docs/items-model.md; :mod:`dronefleet.items.scenario` is its scenario
``items``, :mod:`dronefleet.items.kernel` its compiled loop.
"""

from .params import Params, ParamsError
from .simulate import run_cell, simulate

__all__ = ["Params", "ParamsError", "run_cell", "simulate"]
