"""The stream of orders arriving at the fulfilment centre (docs/delivery-model.md section 1)."""

from typing import NamedTuple

import numpy as np

from ..fpmath import log
from ..jit import njit
from .config import Config

#: Orders are drawn in fixed-size blocks so that the stream does not depend on the
#: horizon: a shorter run sees exactly the first orders of a longer one.
BLOCK = 1024


@njit(cache=True)
def exponential_gaps(u, tau_s):
    """Exp(tau) inter-arrival gaps [s] from uniforms ``u`` in [0, 1), shape (n,), by inversion.

    Not ``Generator.exponential``: its ziggurat calls libm's exp and log1p, whose last bit
    depends on the CPU; :func:`dronefleet.fpmath.log` does not.
    """
    gaps = np.empty_like(u)
    for j in range(u.shape[0]):
        gaps[j] = -tau_s * log(1.0 - u[j])
    return gaps


class Orders(NamedTuple):
    """Every order of a run, in arrival order; arrays of shape (n_orders,), float64."""

    arrival_s: np.ndarray
    distance_m: np.ndarray
    mass_kg: np.ndarray


def generate_orders(config: Config, rng: np.random.Generator) -> Orders:
    """Draw the orders arriving in [0, horizon) from the run's order stream ``rng``.

    The first order arrives at t = 0 and gaps are Exp(tau) (:func:`exponential_gaps`). Mass ~ U(mass_min, mass_max);
    distance ~ U(distance_min, distance_max) or, with ``distance_sampling = "annulus"``,
    sqrt(U(distance_min^2, distance_max^2)).
    """
    horizon = config.horizon_s
    arrivals, masses, distances = [], [], []
    next_arrival = 0.0
    while next_arrival < horizon:
        gaps = exponential_gaps(rng.random(BLOCK), config.tau_s)
        masses.append(rng.uniform(config.mass_min_kg, config.mass_max_kg, BLOCK))
        if config.distance_sampling == "annulus":
            distances.append(np.sqrt(rng.uniform(config.distance_min_m * config.distance_min_m,
                                                   config.distance_max_m * config.distance_max_m, BLOCK)))
        else:
            distances.append(rng.uniform(config.distance_min_m, config.distance_max_m, BLOCK))
        # cumsum adds sequentially: t[j+1] = t[j] + Z[j] exactly, across blocks too.
        times = np.cumsum(np.concatenate(([next_arrival], gaps)))
        arrivals.append(times[:-1])
        next_arrival = times[-1]
    arrival = np.concatenate(arrivals)
    n = int(np.searchsorted(arrival, horizon, side="left"))
    return Orders(arrival[:n], np.concatenate(distances)[:n], np.concatenate(masses)[:n])
