"""Closed-form energy of docs/delivery-model.md sections 2 and 3, checked against the formulas by hand."""

import math

import numpy as np
import pytest

from conftest import K, power, rate
from dronefleet.delivery import config as cfg
from dronefleet.delivery.energy import (
    LOSS_TOLERANCE,
    capable,
    charge_rate,
    drain_per_watt,
    flight_power,
    plan_attempt,
    soc_after_charging,
)

C = cfg.default_config()
POWER_ARGS = (C.frame_mass_kg, C.battery_mass_kg, C.n_rotors, C.rotor_area_m2, C.air_density_kg_m3,
              C.gravity_m_s2)
V = C.speed_m_s


def _rates(mass, soh=1.0):
    """(loaded, empty) drain rates in %/s computed by hand."""
    return rate(mass, soh), rate(0.0, soh)


# ---------------------------------------------------------------------------- power and drain


def test_flight_power_of_the_spec():
    assert flight_power(0.0, *POWER_ARGS) == pytest.approx(1194.6, abs=0.05)
    assert flight_power(5.0, *POWER_ARGS) == pytest.approx(1669.6, abs=0.05)
    # The Dorling formula itself, on an array.
    m = np.array([0.0, 0.5, 2.75, 5.0])
    assert flight_power(m, *POWER_ARGS) == pytest.approx([power(x) for x in m], rel=1e-13)


def test_full_battery_flies_28_75_minutes_at_5_kg():
    drain = drain_per_watt(C.capacity_wh, 1.0)
    r = flight_power(5.0, *POWER_ARGS) * drain  # %/s
    minutes = 100.0 / r / 60.0  # SoC 100 -> 0
    assert minutes == pytest.approx(28.75, abs=0.005)
    # SoH scales the capacity: half the health, half the flight.
    assert 100.0 / (flight_power(5.0, *POWER_ARGS) * drain_per_watt(C.capacity_wh, 0.5)) / 60.0 == pytest.approx(
        28.75 / 2, abs=0.005)


# ---------------------------------------------------------------------------- charging


def test_charge_rate_constant():
    k = charge_rate(C.capacity_wh, C.charger_power_w, C.charger_efficiency)
    assert k == pytest.approx(3.2986e-5, rel=1e-4)
    assert k == pytest.approx(K, rel=1e-14)
    assert 1.0 / k / 60.0 == pytest.approx(505.0, abs=0.5)


@pytest.mark.parametrize("s0", [0.0, 12.5, 50.0, 99.0, 100.0])
@pytest.mark.parametrize("seconds", [0.0, 1.0, 600.0, 3600.0, 30315.8, 200000.0])
def test_charging_closed_form(s0, seconds):
    expected = 100.0 - (100.0 - s0) * math.exp(-3.2986e-5 * seconds)
    assert soc_after_charging(s0, seconds, K) == pytest.approx(expected, abs=1e-4 * (1 + seconds / 1e4))
    assert soc_after_charging(s0, seconds, K) == pytest.approx(100.0 - (100.0 - s0) * math.exp(-K * seconds),
                                                               rel=1e-14, abs=1e-12)


def test_charging_after_one_time_constant():
    # After 1/k = 505 min, the gap to 100 % shrinks by e.
    assert soc_after_charging(0.0, 1.0 / K, K) == pytest.approx(100.0 * (1.0 - math.exp(-1.0)), rel=1e-12)
    assert soc_after_charging(0.0, 505 * 60.0, K) == pytest.approx(63.2, abs=0.05)


@pytest.mark.parametrize("s0", [0.0, 30.0, 75.0])
@pytest.mark.parametrize("t", [10.0, 5000.0, 50000.0])
def test_charging_solves_the_ode(s0, t):
    h = 1.0
    deriv = (soc_after_charging(s0, t + h, K) - soc_after_charging(s0, t - h, K)) / (2 * h)
    soc = soc_after_charging(s0, t, K)
    assert deriv == pytest.approx((100.0 - soc) * K, rel=1e-6)
    # Composition: charging for a then b equals charging for a + b (a memoryless ODE).
    assert soc_after_charging(soc_after_charging(s0, t, K), 123.0, K) == pytest.approx(
        soc_after_charging(s0, t + 123.0, K), rel=1e-12)


# ---------------------------------------------------------------------------- one attempt


def test_plan_delivered_attempt():
    d, m, s0, xi = 3000.0, 2.0, 90.0, 0.5
    rl, re = _rates(m, 0.8)
    delivered, out_s, soc_turn, home_s, soc_land, lost = plan_attempt(s0, d, V, rl, re, xi)
    assert delivered and not lost
    assert out_s == pytest.approx(300.0, rel=1e-14)          # d / v
    assert soc_turn == pytest.approx(s0 - 300.0 * rl, rel=1e-13)
    assert home_s == pytest.approx(300.0, rel=1e-14)         # flies home empty, same distance
    assert soc_land == pytest.approx(s0 - 300.0 * (rl + re), rel=1e-13)


@pytest.mark.parametrize("xi", [0.5, 0.6, 0.75])
def test_plan_aborted_attempt(xi):
    d, m, s0 = 6000.0, 5.0, 40.0
    rl, re = _rates(m)
    assert (d / V) * rl >= (1 - xi) * s0  # precondition: cannot reach d before the abort level
    delivered, out_s, soc_turn, home_s, soc_land, lost = plan_attempt(s0, d, V, rl, re, xi)
    assert not delivered and not lost
    t_abort = (1 - xi) * s0 / rl
    assert out_s == pytest.approx(t_abort, rel=1e-13)
    assert soc_turn == pytest.approx(xi * s0, rel=1e-13)
    # Flies back the same way carrying the parcel, at the loaded rate.
    assert home_s == pytest.approx(t_abort, rel=1e-13)
    assert soc_land == pytest.approx(xi * s0 - (1 - xi) * s0, abs=1e-9)


@pytest.mark.parametrize("s0", [100.0, 77.7, 31.4159, 3.0, 1e-3])
@pytest.mark.parametrize("m", [0.5, 2.2, 5.0])
def test_abort_with_xi_half_lands_at_zero_and_is_not_lost(s0, m):
    rl, re = _rates(m, 0.5)
    d = 1e6  # unreachable
    delivered, out_s, soc_turn, home_s, soc_land, lost = plan_attempt(s0, d, V, rl, re, 0.5)
    assert not delivered
    assert not lost
    assert 0.0 <= soc_land <= 1e-12  # exactly 0 up to rounding, never negative
    assert home_s == pytest.approx(out_s, rel=1e-13)
    assert out_s == pytest.approx(0.5 * s0 / rl, rel=1e-13)


def test_abort_with_xi_0_3_is_lost_when_soc_hits_zero():
    d, m, s0, xi = 6000.0, 5.0, 50.0, 0.3
    rl, re = _rates(m, 0.9)
    assert (d / V) * rl >= (1 - xi) * s0
    delivered, out_s, soc_turn, home_s, soc_land, lost = plan_attempt(s0, d, V, rl, re, xi)
    assert not delivered and lost
    assert out_s == pytest.approx(0.7 * s0 / rl, rel=1e-13)
    assert soc_turn == pytest.approx(0.3 * s0, rel=1e-13)
    # The SoC reaches 0 after 0.3 s0 / r of the flight home (loaded).
    assert home_s == pytest.approx(0.3 * s0 / rl, rel=1e-13)
    assert soc_land < 0.0


def test_delivered_then_lost():
    # Reaches d before the abort level but cannot come back empty.
    d, m, s0, xi = 5000.0, 1.0, 60.0, 0.2
    rl, re = _rates(m, 0.6)
    out = (d / V) * rl
    assert out < (1 - xi) * s0 and s0 - out - (d / V) * re < 0
    delivered, out_s, soc_turn, home_s, soc_land, lost = plan_attempt(s0, d, V, rl, re, xi)
    assert delivered and lost
    assert out_s == pytest.approx(d / V, rel=1e-14)
    assert soc_turn == pytest.approx(s0 - out, rel=1e-13)
    assert home_s == pytest.approx((s0 - out) / re, rel=1e-12)
    assert home_s < d / V


def test_loss_is_decided_with_a_tolerance():
    # Exactly enough charge to come back: landing at 0 is not a loss, a hair more drain is.
    rl, re = 0.05, 0.04
    d = 1000.0
    s0 = 100.0 * (rl + re)  # lands at exactly 0 in exact arithmetic (9.0 %)
    delivered, _, _, _, soc_land, lost = plan_attempt(s0, d, V, rl, re, 0.0)
    assert delivered and not lost and soc_land == pytest.approx(0.0, abs=1e-12) and soc_land >= 0.0
    delivered, _, _, _, soc_land, lost = plan_attempt(s0 - 1e-6, d, V, rl, re, 0.0)
    assert delivered and lost
    assert LOSS_TOLERANCE < 1e-6


def test_capable_agrees_with_plan_attempt():
    rng = np.random.default_rng(2024)
    n = 4000
    d = rng.uniform(1000, 6000, n)
    m = rng.uniform(0.5, 5.0, n)
    soc = rng.uniform(0, 100, n)
    soh = rng.uniform(0.5, 1.0, n)
    xi = rng.choice([0.0, 0.3, 0.5, 0.7], n)
    drain = drain_per_watt(C.capacity_wh, soh)
    p_loaded = flight_power(m, *POWER_ARGS)
    p_empty = flight_power(0.0, *POWER_ARGS)
    truth = np.array([capable(d[j], m[j], soc[j], drain[j], p_loaded[j], p_empty, V, xi[j]) for j in range(n)])
    planned = np.empty(n, bool)
    by_hand = np.empty(n, bool)
    for j in range(n):
        rl, re = rate(m[j], soh[j]), rate(0.0, soh[j])
        delivered, *_, lost = plan_attempt(soc[j], d[j], V, rl, re, xi[j])
        planned[j] = delivered and not lost
        leg = d[j] / V
        by_hand[j] = leg * rl < (1 - xi[j]) * soc[j] and soc[j] - leg * (rl + re) > 0
    assert 0.1 < truth.mean() < 0.9  # both answers occur
    np.testing.assert_array_equal(truth, by_hand)
    np.testing.assert_array_equal(planned, truth)
    # Vectorised call gives the same.
    np.testing.assert_array_equal(capable(d, m, soc, drain, p_loaded, p_empty, V, xi), truth)
