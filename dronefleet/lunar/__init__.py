"""Lunar foraging with recharging: a beacon-guided swarm of rovers (Angyal, TU Delft MSc thesis 2024).

The model is the spec LUNAR-FORAGING.md (docs/guide/lunar.md tells how it is run);
:mod:`dronefleet.lunar.scenario` is its scenario ``lunar``, :mod:`dronefleet.lunar.kernel` its
compiled loop, :mod:`dronefleet.lunar.params` its parameters.
"""

from .params import LunarParams
from .simulate import simulate

__all__ = ["LunarParams", "simulate"]
