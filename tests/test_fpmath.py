"""dronefleet.fpmath against Python's math (the reference: these tests are not a trajectory).

Errors are counted in units in the last place (ulp) between the two float64 results; each
function must be within 1 ulp of ``math`` everywhere it is used and over wide random ranges,
exact where the value is exact, and give the documented special values.
"""

import math

import numpy as np
import pytest
from numba import njit

from dronefleet import fpmath

TINY = 5e-324  # smallest subnormal
HUGE = 1.7976931348623157e308


def ulp_distance(a, b):
    """Number of float64 values between a and b (0 when bitwise equal; both nan: 0)."""
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    ia, ib = a.view(np.int64), b.view(np.int64)
    # Map the sign-magnitude bit patterns onto a monotone integer line.
    ia = np.where(ia < 0, np.int64(-(2 ** 63)) - ia, ia)
    ib = np.where(ib < 0, np.int64(-(2 ** 63)) - ib, ib)
    both_nan = np.isnan(a) & np.isnan(b)
    return np.where(both_nan, 0, np.abs(ia - ib))


@njit
def _apply(f, x):
    out = np.empty_like(x)
    for j in range(x.shape[0]):
        out[j] = f(x[j])
    return out


@njit
def _apply2(f, y, x):
    out = np.empty_like(x)
    for j in range(x.shape[0]):
        out[j] = f(y[j], x[j])
    return out


def _check(ours, reference, x):
    got = _apply(ours, np.asarray(x, dtype=np.float64))
    want = np.array([reference(v) for v in x])
    error = ulp_distance(got, want)
    worst = int(np.argmax(error))
    assert error.max() <= 1, f"{error.max()} ulp at x = {x[worst]!r}: {got[worst]!r} vs {want[worst]!r}"


RNG = np.random.default_rng(20261123)


def test_exp_within_one_ulp():
    model = np.concatenate([  # charging: exp(-k t), k ~ 3e-5 1/s, t up to weeks
        -np.exp(RNG.uniform(-30.0, 3.7, 4000)), RNG.uniform(-40.0, 0.0, 4000)])
    wide = np.concatenate([RNG.uniform(-745.0, 709.7, 8000), RNG.uniform(-1.0, 1.0, 4000),
                           RNG.uniform(-1e-8, 1e-8, 1000), RNG.uniform(-745.1, -708.5, 1000)])  # subnormal results
    edges = [0.0, -0.0, 1.0, -1.0, 0.5 * math.log(2.0), 1.5 * math.log(2.0), math.log(2.0), 2.0 ** -28,
             -(2.0 ** -28), 2.0 ** -29, 709.78, -708.39, -708.4, -745.13, 1e-300, -1e-300, TINY]
    _check(fpmath.exp, math.exp, np.concatenate([model, wide, edges]))


def test_exp_special_values():
    assert fpmath.exp(0.0) == 1.0 and fpmath.exp(-0.0) == 1.0
    assert fpmath.exp(-np.inf) == 0.0
    assert fpmath.exp(np.inf) == np.inf
    assert fpmath.exp(710.0) == np.inf and fpmath.exp(1e300) == np.inf   # overflow
    assert fpmath.exp(-746.0) == 0.0 and fpmath.exp(-1e300) == 0.0      # underflow
    assert math.isnan(fpmath.exp(np.nan))
    assert fpmath.exp(709.78) == math.exp(709.78)  # the largest finite results stay finite


def test_log_within_one_ulp():
    model = np.concatenate([  # (100 - SoC) / (100 - s*) of the charging-curve inverses, 1 - u of order gaps
        RNG.uniform(1.0, 1e4, 4000), 1.0 - RNG.random(4000)])
    wide = np.concatenate([np.exp(RNG.uniform(-700.0, 700.0, 8000)), RNG.uniform(0.0, 2.0, 4000),
                           RNG.uniform(0.999, 1.001, 4000), RNG.uniform(TINY, 1e-308, 1000)])
    edges = [1.0, 2.0, 0.5, math.e, 10.0, 1.0 + 2.0 ** -52, 1.0 - 2.0 ** -53, 1.0 + 2.0 ** -20,
             1.0 - 2.0 ** -20, math.sqrt(2.0), math.sqrt(0.5), TINY, 2.2250738585072014e-308, HUGE]
    _check(fpmath.log, math.log, np.concatenate([model, wide, edges]))


def test_log_special_values():
    assert fpmath.log(1.0) == 0.0
    assert fpmath.log(0.0) == -np.inf and fpmath.log(-0.0) == -np.inf
    assert fpmath.log(np.inf) == np.inf
    for x in (-1.0, -TINY, -np.inf, np.nan):
        assert math.isnan(fpmath.log(x))


@pytest.mark.parametrize("name", ["sin", "cos"])
def test_sin_cos_within_one_ulp(name):
    x = np.concatenate([RNG.uniform(-2.0 * math.pi, 2.0 * math.pi, 6000), RNG.uniform(-1e5, 1e5, 6000),
                        RNG.uniform(-fpmath.TRIG_DOMAIN, fpmath.TRIG_DOMAIN, 2000),
                        RNG.uniform(-1e-6, 1e-6, 1000),
                        # near multiples of pi/2, where the reduction cancels most
                        np.arange(-200, 201) * (math.pi / 2.0) + RNG.uniform(-1e-9, 1e-9, 401)])
    edges = [0.0, -0.0, 1e-300, 2.0 ** -27, 0.3, 0.78125, math.pi / 4.0, math.pi / 2.0, math.pi,
             3.0 * math.pi / 2.0, 2.0 * math.pi, 1e5, -1e5, fpmath.TRIG_DOMAIN, 355.0, 103993.0]
    _check(getattr(fpmath, name), getattr(math, name), np.concatenate([x, edges]))


def test_sin_cos_exact_values_and_domain():
    assert fpmath.sin(0.0) == 0.0 and fpmath.cos(0.0) == 1.0
    assert math.copysign(1.0, fpmath.sin(-0.0)) == -1.0
    for x in (np.inf, -np.inf, np.nan, 2.0 * fpmath.TRIG_DOMAIN):
        assert math.isnan(fpmath.sin(x)) and math.isnan(fpmath.cos(x))


@njit
def _sincos_all(x):
    s = np.empty_like(x)
    c = np.empty_like(x)
    for j in range(x.shape[0]):
        s[j], c[j] = fpmath.sincos(x[j])
    return s, c


def test_sincos_is_sin_and_cos_bit_for_bit():
    # the kernels call sincos on the trajectory path in place of sin and cos: any
    # last-bit difference would move the golden fingerprints
    x = np.concatenate([RNG.uniform(-2.0 * math.pi, 2.0 * math.pi, 20000), RNG.uniform(-1e5, 1e5, 2000),
                        np.arange(-200, 201) * (math.pi / 4.0) + RNG.uniform(-1e-9, 1e-9, 401),
                        [0.0, -0.0, 1e-300, -1e-300, math.pi, -math.pi, np.inf, -np.inf, np.nan,
                         fpmath.TRIG_DOMAIN, -fpmath.TRIG_DOMAIN, 2.0 * fpmath.TRIG_DOMAIN]])
    s, c = _sincos_all(x)
    np.testing.assert_array_equal(s.view(np.int64), _apply(fpmath.sin, x).view(np.int64))
    np.testing.assert_array_equal(c.view(np.int64), _apply(fpmath.cos, x).view(np.int64))

def test_atan2_within_one_ulp():
    n = 20000
    y = RNG.standard_normal(n) * np.exp(RNG.uniform(-20.0, 20.0, n))
    x = RNG.standard_normal(n) * np.exp(RNG.uniform(-20.0, 20.0, n))
    headings = RNG.uniform(-math.pi, math.pi, 4000)  # unit vectors of headings, as a robot's
    y = np.concatenate([y, np.sin(headings), [1.0, -1.0, 1e-300, 1e300, 3.0, -3.0]])
    x = np.concatenate([x, np.cos(headings), [1.0, 1.0, -1e300, 1e-300, 1.0, -1.0]])
    got = _apply2(fpmath.atan2, y, x)
    want = np.array([math.atan2(a, b) for a, b in zip(y, x)])
    error = ulp_distance(got, want)
    assert error.max() <= 1, (y[np.argmax(error)], x[np.argmax(error)])


@pytest.mark.parametrize("y", [0.0, -0.0, 1.0, -1.0, np.inf, -np.inf, np.nan])
@pytest.mark.parametrize("x", [0.0, -0.0, 1.0, -1.0, np.inf, -np.inf, np.nan])
def test_atan2_special_values_as_c99(y, x):
    got, want = fpmath.atan2(y, x), math.atan2(y, x)
    if math.isnan(want):
        assert math.isnan(got)
    else:
        assert got == want and math.copysign(1.0, got) == math.copysign(1.0, want)
