"""An example winner rule for dronefleet, installed as a plugin (see ../README.md).

Among the idle UAVs whose policy says "bid" (decision value f >= 0), the one with the
fullest battery wins: the order goes to the UAV most likely to have charge to spare,
whatever its confidence. Ties go to the highest UAV id, as for every rule.
"""

from numba import njit


@njit(cache=True)
def fullest_battery(f, w_norm, soc, theta, rng):
    """Bid iff f >= 0, with the state of charge [%] as score: the highest SoC wins."""
    if f >= 0.0:
        return True, soc
    return False, 0.0


# It bids exactly when f >= 0: the engine may skip ticks at which no policy says "bid".
fullest_battery.bids_on = "policy"
