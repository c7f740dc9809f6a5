"""The project's own elementary functions: the same bits on every CPU.

libm's and numpy's ``exp``, ``log``, ``sin`` ... pick code paths by CPU (SSE2, AVX2, FMA,
AVX-512) whose results differ in the last bit, and the online learner turns one last-bit
difference into another trajectory. These are ports of fdlibm 5.3 (Sun Microsystems,
freely redistributable: ``e_exp.c``, ``e_log.c``, ``k_sin.c``, ``k_cos.c``,
``e_rem_pio2.c``, ``s_atan.c``, ``e_atan2.c``), written with IEEE-754 ``+ - * /`` only,
each correctly rounded on every CPU, plus operations that are exact everywhere
(``math.frexp``, scaling by 2^k within the normal range, ``math.floor``, comparisons,
conversions of small integers). fdlibm's high-word bit tests are replaced by the same
tests on ``frexp``'s mantissa. numba compiles them without ``fastmath``, so LLVM neither
reorders nor contracts ``a * b + c`` into an FMA (numba's default).

Every function takes and returns one float64 (``sincos``: both of ``(sin(x), cos(x))``, bit
for bit) and is a module-level ``@njit(cache=True)`` kernel; on arrays, call it in a compiled loop.

Accuracy, measured against Python's ``math`` (glibc, close to correctly rounded) by
``tests/test_fpmath.py`` over the ranges the model uses and wide random ranges:

======  =====================================  ==============  ==================
name    domain                                 max error       special values
======  =====================================  ==============  ==================
exp     all float64                            1 ulp           exp(-inf) = 0, exp(inf) = inf,
                                                               overflow (x > 709.78) -> inf,
                                                               underflow (x < -745.13) -> 0, nan -> nan
log     all float64                            1 ulp           log(0) = -inf, log(x < 0) = nan,
                                                               log(inf) = inf, nan -> nan
sin     |x| <= 1e6 (nan outside, and inf)      1 ulp
cos     |x| <= 1e6 (nan outside, and inf)      1 ulp
atan2   all float64 pairs                      1 ulp           as C99 (signed zeros, infinities)
======  =====================================  ==============  ==================

exp(0) = 1 and log(1) = 0 exactly. The 1e6 domain of sin/cos is that of fdlibm's
"medium" argument reduction (pi/2 in three parts, exact products for n < 2^20): enough
for headings of any simulated motion; a larger argument means a heading that was never
wrapped, which is a bug upstream.
"""

import math

import numpy as np
from numba import types
from numba.extending import intrinsic

from .jit import njit


@intrinsic
def _bitcast(typingctx, value, to):
    """``value``'s 64 bits read as the type ``to`` (int64 <-> float64), as C's union or memcpy."""
    target = to.dtype if isinstance(to, types.NumberClass) else None
    if target not in (types.int64, types.float64) or value not in (types.int64, types.float64):
        return None

    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], context.get_value_type(target))

    return target(value, to), codegen


@njit(cache=True)
def _scale_normal(y, k):
    """``y * 2**k`` for a normal ``y`` and a normal result: ``k`` added to the exponent bits.

    Exact, and the bits of ``math.ldexp(y, k)``, without its call into C (``scalbn``:
    2 % of the delivery paper run).
    """
    return _bitcast(_bitcast(y, np.int64) + (np.int64(k) << 52), np.float64)

# --- exp (e_exp.c) -------------------------------------------------------------------------
_LN2_HI = 6.93147180369123816490e-01   # 0x3fe62e42 fee00000: ln 2 rounded to 32 bits, k * _LN2_HI is exact
_LN2_LO = 1.90821492927058770002e-10   # 0x3dea39ef 35793c76
_INV_LN2 = 1.44269504088896338700e+00
_EXP_OVERFLOW = 7.09782712893383973096e+02   # above: exp(x) > DBL_MAX
_EXP_UNDERFLOW = -7.45133219101941108420e+02  # below: exp(x) < min subnormal / 2
_P1 = 1.66666666666666019037e-01
_P2 = -2.77777777770155933842e-03
_P3 = 6.61375632143793436117e-05
_P4 = -1.65339022054652515390e-06
_P5 = 4.13813679705723846039e-08
_HALF_LN2 = 0.5 * 6.93147180559945286227e-01  # 0x3fd62e42 fefa39ef
_THREE_HALVES_LN2 = 1.5 * 6.93147180559945286227e-01
_TWO_M28 = 2.0 ** -28
_TWO_M1000 = 2.0 ** -1000


@njit(cache=True)
def exp(x):
    """e ** x, float64 (fdlibm's algorithm: x = k ln2 + r, |r| <= ln2 / 2, rational approximation of e^r)."""
    if x != x:
        return x + x
    if x > _EXP_OVERFLOW:
        return np.inf
    if x < _EXP_UNDERFLOW:
        return 0.0
    ax = abs(x)
    k = 0
    hi = 0.0
    lo = 0.0
    if ax > _HALF_LN2:
        if ax < _THREE_HALVES_LN2:
            k = 1 if x > 0.0 else -1
        else:
            k = int(_INV_LN2 * x + (0.5 if x > 0.0 else -0.5))  # truncation, as C's (int)
        hi = x - k * _LN2_HI
        lo = k * _LN2_LO
        x = hi - lo
    elif ax < _TWO_M28:
        return 1.0 + x
    t = x * x
    c = x - t * (_P1 + t * (_P2 + t * (_P3 + t * (_P4 + t * _P5))))
    if k == 0:
        return 1.0 - ((x * c) / (c - 2.0) - x)
    y = 1.0 - ((lo - (x * c) / (2.0 - c)) - hi)
    if k >= -1021:
        return _scale_normal(y, k)  # exact: the result is normal
    # Subnormal result: scale exactly into the normal range, then one correctly rounded product.
    return _scale_normal(y, k + 1000) * _TWO_M1000


# --- log (e_log.c) -------------------------------------------------------------------------
_TWO54 = 1.80143985094819840000e+16
_LG1 = 6.666666666666735130e-01
_LG2 = 3.999999999940941908e-01
_LG3 = 2.857142874366239149e-01
_LG4 = 2.222219843214978396e-01
_LG5 = 1.818357216161805012e-01
_LG6 = 1.531383769920937332e-01
_LG7 = 1.479819860511658591e-01
_TWO20 = 1048576.0
_MIN_NORMAL = 2.2250738585072014e-308


@njit(cache=True)
def log(x):
    """Natural logarithm, float64 (fdlibm's algorithm: x = 2^k (1 + f), sqrt(2)/2 < 1 + f < sqrt(2))."""
    if x != x or x < 0.0:
        return np.nan
    if x == 0.0:
        return -np.inf
    if x == np.inf:
        return x
    k = 0
    if x < _MIN_NORMAL:  # subnormal: scale up exactly
        k = -54
        x *= _TWO54
    m, e = math.frexp(x)   # x = m 2^e, 0.5 <= m < 1
    m *= 2.0               # 1 <= m < 2, x = m 2^(e - 1): fdlibm's significand
    k += e - 1
    hx = int((m - 1.0) * _TWO20)  # the top 20 bits of the fraction (fdlibm's hx & 0x000fffff)
    if (hx + 0x95f64) & 0x100000:  # fraction >= sqrt(2) - 1: use m / 2 and k + 1
        m *= 0.5
        k += 1
    f = m - 1.0
    if (0x000fffff & (2 + hx)) < 3:  # -2^-20 <= f < 2^-20
        if f == 0.0:
            if k == 0:
                return 0.0
            dk = float(k)
            return dk * _LN2_HI + dk * _LN2_LO
        r = f * f * (0.5 - 0.33333333333333333 * f)
        if k == 0:
            return f - r
        dk = float(k)
        return dk * _LN2_HI - ((r - dk * _LN2_LO) - f)
    s = f / (2.0 + f)
    dk = float(k)
    z = s * s
    i = hx - 0x6147a
    w = z * z
    j = 0x6b851 - hx
    t1 = w * (_LG2 + w * (_LG4 + w * _LG6))
    t2 = z * (_LG1 + w * (_LG3 + w * (_LG5 + w * _LG7)))
    i |= j
    r = t2 + t1
    if i > 0:
        hfsq = 0.5 * f * f
        if k == 0:
            return f - (hfsq - s * (hfsq + r))
        return dk * _LN2_HI - ((hfsq - (s * (hfsq + r) + dk * _LN2_LO)) - f)
    if k == 0:
        return f - s * (f - r)
    return dk * _LN2_HI - ((s * (f - r) - dk * _LN2_LO) - f)


# --- sin, cos (k_sin.c, k_cos.c, s_sin.c, s_cos.c, e_rem_pio2.c medium case) ---------------
_S1 = -1.66666666666666324348e-01
_S2 = 8.33333333332248946124e-03
_S3 = -1.98412698298579493134e-04
_S4 = 2.75573137070700676789e-06
_S5 = -2.50507602534068634195e-08
_S6 = 1.58969099521155010221e-10
_C1 = 4.16666666666666019037e-02
_C2 = -1.38888888888741095749e-03
_C3 = 2.48015872894767294178e-05
_C4 = -2.75573143513906633035e-07
_C5 = 2.08757232129817482790e-09
_C6 = -1.13596475577881948265e-11
_TWO_M27 = 2.0 ** -27
_COS_SMALL = 0.2999999523162842     # high word 0x3fd33333
_COS_LARGE = 0.7812504768371582     # high word 0x3fe90001
_PI_4_HW = 0.7853984832763672       # high word 0x3fe921fc: |x| below needs no reduction
_INV_PIO2 = 6.36619772367581382433e-01
_PIO2_1 = 1.57079632673412561417e+00   # first 33 bits of pi/2
_PIO2_2 = 6.07710050630396597660e-11   # second 33 bits
_PIO2_2T = 2.02226624879595063154e-21
_PIO2_3 = 2.02226624871116645580e-21   # third 33 bits
_PIO2_3T = 8.47842766036889956997e-32
#: sin and cos are defined for |x| <= TRIG_DOMAIN (nan outside).
TRIG_DOMAIN = 1e6


@njit(cache=True)
def _kernel_sin(x, y):
    """sin(x + y) for |x + y| <= pi/4, y the tail of x."""
    if abs(x) < _TWO_M27:
        return x
    z = x * x
    v = z * x
    r = _S2 + z * (_S3 + z * (_S4 + z * (_S5 + z * _S6)))
    return x - ((z * (0.5 * y - v * r) - y) - v * _S1)


@njit(cache=True)
def _kernel_cos(x, y):
    """cos(x + y) for |x + y| <= pi/4, y the tail of x."""
    ax = abs(x)
    if ax < _TWO_M27:
        return 1.0
    z = x * x
    r = z * (_C1 + z * (_C2 + z * (_C3 + z * (_C4 + z * (_C5 + z * _C6)))))
    if ax < _COS_SMALL:
        return 1.0 - (0.5 * z - (z * r - x * y))
    if ax >= _COS_LARGE:
        qx = 0.28125
    else:
        m, e = math.frexp(0.25 * ax)  # x / 4 cut to its top 21 significant bits (fdlibm: low word 0)
        qx = _scale_normal(float(math.floor(m * 2097152.0)), e - 21)
    hz = 0.5 * z - qx
    a = 1.0 - qx
    return a - (hz - (z * r - x * y))


@njit(cache=True)
def _reduce(x):
    """(n, y0, y1) with x = n pi/2 + y0 + y1, |y0 + y1| <= pi/4, for pi/4 <= |x| <= TRIG_DOMAIN.

    fdlibm's medium case with its three iterations always taken (pi/2 to 151 bits).
    """
    t = abs(x)
    n = int(t * _INV_PIO2 + 0.5)
    fn = float(n)
    r = t - fn * _PIO2_1  # fn * _PIO2_1 is exact: n < 2^20
    u = r
    w = fn * _PIO2_2
    r = u - w
    w = fn * _PIO2_2T - ((u - r) - w)
    u = r
    w = fn * _PIO2_3
    r = u - w
    w = fn * _PIO2_3T - ((u - r) - w)
    y0 = r - w
    y1 = (r - y0) - w
    if x < 0.0:
        return -n, -y0, -y1
    return n, y0, y1


@njit(cache=True)
def sin(x):
    """Sine of ``x`` radians, float64, for |x| <= TRIG_DOMAIN (nan outside)."""
    if abs(x) < _PI_4_HW:
        return _kernel_sin(x, 0.0)
    if not abs(x) <= TRIG_DOMAIN:  # also inf and nan
        return np.nan
    n, y0, y1 = _reduce(x)
    q = n & 3
    if q == 0:
        return _kernel_sin(y0, y1)
    if q == 1:
        return _kernel_cos(y0, y1)
    if q == 2:
        return -_kernel_sin(y0, y1)
    return -_kernel_cos(y0, y1)


@njit(cache=True)
def cos(x):
    """Cosine of ``x`` radians, float64, for |x| <= TRIG_DOMAIN (nan outside)."""
    if abs(x) < _PI_4_HW:
        return _kernel_cos(x, 0.0)
    if not abs(x) <= TRIG_DOMAIN:
        return np.nan
    n, y0, y1 = _reduce(x)
    q = n & 3
    if q == 0:
        return _kernel_cos(y0, y1)
    if q == 1:
        return -_kernel_sin(y0, y1)
    if q == 2:
        return -_kernel_cos(y0, y1)
    return _kernel_sin(y0, y1)


@njit(cache=True)
def sincos(x):
    """``(sin(x), cos(x))``, bit for bit the two calls', with one argument reduction.

    For the per-move heading update, where the reduction is half the cost of each call.
    """
    if abs(x) < _PI_4_HW:
        return _kernel_sin(x, 0.0), _kernel_cos(x, 0.0)
    if not abs(x) <= TRIG_DOMAIN:
        return np.nan, np.nan
    n, y0, y1 = _reduce(x)
    ks = _kernel_sin(y0, y1)
    kc = _kernel_cos(y0, y1)
    q = n & 3
    if q == 0:
        return ks, kc
    if q == 1:
        return kc, -ks
    if q == 2:
        return -ks, -kc
    return -kc, ks

# --- atan2 (s_atan.c, e_atan2.c) -----------------------------------------------------------
_ATAN_HI = (4.63647609000806093515e-01, 7.85398163397448278999e-01,
            9.82793723247329054082e-01, 1.57079632679489655800e+00)
_ATAN_LO = (2.26987774529616870924e-17, 3.06161699786838301793e-17,
            1.39033110312309984516e-17, 6.12323399573676603587e-17)
_AT0 = 3.33333333333329318027e-01
_AT1 = -1.99999999998764832476e-01
_AT2 = 1.42857142725034663711e-01
_AT3 = -1.11111104054623557880e-01
_AT4 = 9.09088713343650656196e-02
_AT5 = -7.69187620504482999495e-02
_AT6 = 6.66107313738753120669e-02
_AT7 = -5.83357013379057348645e-02
_AT8 = 4.97687799461593236017e-02
_AT9 = -3.65315727442169155270e-02
_AT10 = 1.62858201153657823623e-02
_PI_O_4 = 7.8539816339744827900e-01
_PI_O_2 = 1.5707963267948965580e+00
_PI = 3.1415926535897931160e+00
_PI_LO = 1.2246467991473531772e-16
_TWO66 = 2.0 ** 66
_TWO_M29 = 2.0 ** -29


@njit(cache=True)
def _atan(x):
    """Arctangent of a float64 that is not nan, in [-pi/2, pi/2]."""
    negative = x < 0.0
    ax = abs(x)
    if ax >= _TWO66:
        return -(_ATAN_HI[3] + _ATAN_LO[3]) if negative else _ATAN_HI[3] + _ATAN_LO[3]
    if ax < 0.4375:
        if ax < _TWO_M29:
            return x
        index = -1
    elif ax < 1.1875:
        if ax < 0.6875:
            index = 0
            x = (2.0 * ax - 1.0) / (2.0 + ax)
        else:
            index = 1
            x = (ax - 1.0) / (ax + 1.0)
    elif ax < 2.4375:
        index = 2
        x = (ax - 1.5) / (1.0 + 1.5 * ax)
    else:
        index = 3
        x = -1.0 / ax
    z = x * x
    w = z * z
    s1 = z * (_AT0 + w * (_AT2 + w * (_AT4 + w * (_AT6 + w * (_AT8 + w * _AT10)))))
    s2 = w * (_AT1 + w * (_AT3 + w * (_AT5 + w * (_AT7 + w * _AT9))))
    if index < 0:
        return x - x * (s1 + s2)
    z = _ATAN_HI[index] - ((x * (s1 + s2) - _ATAN_LO[index]) - x)
    return -z if negative else z


@njit(cache=True)
def atan2(y, x):
    """The angle of the point (x, y) from the x axis, in [-pi, pi], float64 (C99's atan2)."""
    if x != x or y != y:
        return x + y
    if x == 1.0:
        return _atan(y)
    y_negative = math.copysign(1.0, y) < 0.0  # sign bits: atan2(-0, -1) = -pi
    x_negative = math.copysign(1.0, x) < 0.0
    if y == 0.0:
        if not x_negative:
            return y
        return -_PI if y_negative else _PI
    if x == 0.0:
        return -_PI_O_2 if y_negative else _PI_O_2
    if abs(x) == np.inf:
        if abs(y) == np.inf:
            angle = 3.0 * _PI_O_4 if x_negative else _PI_O_4
        else:
            angle = _PI if x_negative else 0.0
        return -angle if y_negative else angle
    if abs(y) == np.inf:
        return -_PI_O_2 if y_negative else _PI_O_2
    k = math.frexp(y)[1] - math.frexp(x)[1]  # difference of binary exponents
    if k > 60:  # |y / x| > 2^60
        z = _PI_O_2 + 0.5 * _PI_LO
    elif x_negative and k < -60:  # |y| / x < -2^60
        z = 0.0
    else:
        z = _atan(abs(y / x))
    if not x_negative:
        return -z if y_negative else z
    if not y_negative:
        return _PI - (z - _PI_LO)
    return (z - _PI_LO) - _PI
