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
from dronefleet.delivery.policy import decision
from dronefleet.fpmath import exp, log

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


def _window_params(rng, reserves):
    return engine.Params(speed_m_s=10.0, xi=0.5, charge_rate=math.exp(rng.uniform(math.log(1e-6), math.log(1e-2))),
                         power_empty_w=100.0, alpha=0.01, t0=1.0, soc_mean=float(rng.uniform(20.0, 80.0)),
                         soc_std=float(rng.uniform(5.0, 40.0)), theta=80.0, advert_interval_s=2.0,
                         record_interval_s=900.0, rule=0, bids_on=engine.BIDS_ON_POLICY, reserves=reserves)


@pytest.mark.parametrize("seed", range(4))
def test_bid_window_flags_every_tick_with_a_bid(seed):
    """Wherever the exact decision value of a charging UAV is >= 0 at a tick, its window (from the
    closed form in u = e^{k (t - base)}) says it may bid; and it opens within a few ticks of the first bid."""
    rng = np.random.default_rng(seed)
    flagged = 0
    for _ in range(400):
        params = _window_params(rng, reserves=False)
        k, interval = params.charge_rate, params.advert_interval_s
        coef = rng.normal(0.0, 3.0, (1, 3))
        coef[0, 2] *= rng.choice([1.0, -1.0, 0.0], p=[0.6, 0.3, 0.1])
        intercept = rng.normal(0.0, 3.0, 1)
        x0, x1 = rng.normal(0.0, 1.0, 2)
        soc0 = float(rng.uniform(0.0, 100.0))
        charge_base = float(rng.uniform(0.0, 1e6))
        t_ref = charge_base + float(rng.uniform(0.0, engine.REBASE_EXPONENT / k))
        a = (100.0 - soc0) * exp(k * (t_ref - charge_base))
        value = coef[0, 0] * x0 + coef[0, 1] * x1
        open_u, close_u = engine._bid_window(value, intercept[0], coef[0, 2], a, params, np.inf, 0.0)
        first = engine.first_tick_at_or_after(t_ref, interval)
        # Ticks around the window's edges and at random, exactly as an auction evaluates them.
        edges = [t for t in (open_u, close_u) if 0.0 < t < np.inf]
        ticks = {first + int(d) for d in rng.integers(0, int(5.0 / (k * interval)) + 1, 30)}
        for edge in edges:
            centre = engine.first_tick_at_or_after(charge_base + log(edge) / k, interval)
            ticks.update(range(max(first, centre - 20), centre + 20))
        for tick in sorted(ticks):
            t = tick * interval
            soc = soc_after_charging(soc0, t - t_ref, k)
            f = decision(coef, intercept, 0, x0, x1, (soc - params.soc_mean) / params.soc_std)
            u = exp(k * (t - charge_base))
            may = open_u <= u or close_u >= u
            if f >= 0.0:
                flagged += 1
                assert may, (seed, tick, f, open_u, close_u, u)
            elif coef[0, 2] > 0.0 and open_u < np.inf and u > open_u * (1.0 + 1e-6):
                raise AssertionError(("opens long before the first bid", seed, tick, f, open_u, u))
    assert flagged > 1000


def test_bid_window_with_reservations_opens_at_once_if_a_full_charge_bids():
    rng = np.random.default_rng(7)
    params = _window_params(rng, reserves=True)
    x_full = (100.0 - params.soc_mean) / params.soc_std
    for coef_soc in (0.5, 2.0, 9.0):
        for slack in np.linspace(-5.0, 5.0, 41):
            open_u, _ = engine._bid_window(slack, 0.0, coef_soc, 50.0, params, np.inf, 0.0)
            full_bids = slack + coef_soc * x_full >= 0.0
            assert (open_u == 0.0) == full_bids or abs(slack + coef_soc * x_full) < 1e-6
