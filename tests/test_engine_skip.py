"""The structures behind the tick skip, against brute force on random inputs built here.

Each bound the skip relies on must hold for every input, not only along one machine's
trajectory: the inputs are drawn in the test, the expected answers found by scanning.
"""

import functools
import math

import numpy as np
import pytest

from dronefleet.delivery import engine
from dronefleet.delivery.energy import soc_after_charging
from dronefleet.fpmath import log

THETAS = [100.0, np.nextafter(100.0, 0.0), 99.99, 90.0, 80.0, 64.0, 50.0, 33.3, 0.5]


def _bids_at_tick(tick, soc0, interval, t_ref, k, theta):
    """Whether a UAV charging from ``soc0`` at ``t_ref`` meets ``theta`` at advertisement ``tick``."""
    return soc_after_charging(soc0, tick * interval - t_ref, k) >= theta


@pytest.mark.parametrize("theta", THETAS)
def test_threshold_crossing_is_a_tight_lower_bound(theta):
    """No tick before the closed-form crossing has SoC >= theta as computed; the first one is at most a tick later."""
    rng = np.random.default_rng(int(theta * 1000))
    gap = engine.threshold_gap(theta)
    for _ in range(300):
        k = math.exp(rng.uniform(math.log(1e-6), math.log(1e-3)))  # charge rate, 1/s
        interval = float(rng.choice([0.5, 2.0, 7.0]))
        soc0 = rng.uniform(0.0, theta) if rng.random() < 0.9 else float(rng.integers(0, 100))
        t_ref = interval * float(rng.integers(0, 10 ** 6)) + rng.uniform(0.0, interval)
        crossing = t_ref + log((100.0 - soc0) / gap) / k
        first = engine.first_tick_at_or_after(crossing, interval)
        # Brute force: the computed SoC, exactly as an auction evaluates it, tick by tick.
        bids = functools.partial(_bids_at_tick, soc0=soc0, interval=interval, t_ref=t_ref, k=k, theta=theta)
        start = max(engine.first_tick_at_or_after(t_ref, interval), first - 50)
        for tick in range(start, first):
            assert not bids(tick), (theta, soc0, k, tick, first)
        # Tight: a bid within a couple of ticks of the bound (never 10^4 ticks later).
        if first < engine.NO_TICK and soc0 < theta:
            assert any(bids(tick) for tick in range(first, first + 3)), (theta, soc0, k, first)
