"""xoshiro256** random streams for the compiled kernels: the same bits on every CPU.

Integer operations and one division by 2**53 only, plus :func:`dronefleet.fpmath.log` in
:func:`normal_pair`, so a stream gives the same numbers everywhere. A kernel holds its
streams as a uint64 array ``rng[trial, stream, 4]`` and draws with ``(rng, trial, stream)``;
many streams stepped together (one per location, say) can be held as ``lanes[4, stream]``
(one state word per row) and drawn with ``(lanes, stream)``: a loop over them vectorises.

Two ways to seed them: :func:`spawn_states` (numpy's SeedSequence, one child per stream,
used by the replenishment scenario) and :func:`seed_stream` (splitmix64 of a seed and a
stream key, compiled: seeding costs nanoseconds, used by the items scenario, whose short
runs would otherwise spend most of their time in SeedSequence).
"""

import numpy as np

from .fpmath import log
from .jit import njit

__all__ = ["xoshiro_step", "next_u64", "lane_u64", "unit", "uniform", "normal_pair", "seed_stream", "spawn_states"]


# Compile time: the helpers on scalars (_rotl, xoshiro_step, unit) are plain compiled functions,
# compiled once and inlined by LLVM; inline='always' makes numba type a function's body again at
# every call site, with its own inline callees, so it is kept for the functions taking the state
# array (a call of one would cost reference counting per draw).


@njit(cache=True)
def _rotl(x, k):
    """x (uint64) rotated left by k (uint64, not a literal int: one specialisation for all k)."""
    return (x << k) | (x >> (np.uint64(64) - k))


@njit(cache=True)
def xoshiro_step(s0, s1, s2, s3):
    """One xoshiro256** step of the state words (uint64): (output, next s0, s1, s2, s3).

    The multiplications by 5 and 9 are written as shifts and adds (the same bits), so that a
    loop over independent streams vectorises on CPUs without a 64-bit vector multiply (AVX2).
    """
    r = _rotl((s1 << np.uint64(2)) + s1, np.uint64(7))
    result = (r << np.uint64(3)) + r
    s2 = s2 ^ s0
    s3 = s3 ^ s1
    return result, s0 ^ s3, s1 ^ s2, s2 ^ (s1 << np.uint64(17)), _rotl(s3, np.uint64(45))


@njit(cache=True, inline='always')
def next_u64(rng, trial, stream):
    """xoshiro256** step of ``rng[trial, stream]`` (uint64[4]); returns uint64."""
    result, rng[trial, stream, 0], rng[trial, stream, 1], rng[trial, stream, 2], rng[trial, stream, 3] = \
        xoshiro_step(rng[trial, stream, 0], rng[trial, stream, 1], rng[trial, stream, 2], rng[trial, stream, 3])
    return result


@njit(cache=True, inline='always')
def lane_u64(lanes, j):
    """xoshiro256** step of stream ``j`` of ``lanes`` (4, streams), uint64, one state word per
    row: a loop over j steps independent streams and vectorises; returns uint64."""
    result, lanes[0, j], lanes[1, j], lanes[2, j], lanes[3, j] = \
        xoshiro_step(lanes[0, j], lanes[1, j], lanes[2, j], lanes[3, j])
    return result


@njit(cache=True)
def unit(bits):
    """The uniform double in [0, 1) of a uint64's top 53 bits."""
    return np.float64(bits >> np.uint64(11)) * (1.0 / 9007199254740992.0)


@njit(cache=True, inline='always')
def uniform(rng, trial, stream):
    """Uniform double in [0, 1) with 53 random bits."""
    return unit(next_u64(rng, trial, stream))


@njit(cache=True, inline='always')
def normal_pair(rng, trial, stream):
    """Two independent N(0, 1) draws (Marsaglia's polar method: one log, no sin/cos)."""
    while True:
        u = 2.0 * uniform(rng, trial, stream) - 1.0
        v = 2.0 * uniform(rng, trial, stream) - 1.0
        r2 = u * u + v * v
        if 0.0 < r2 < 1.0:
            m = np.sqrt(-2.0 * log(r2) / r2)
            return u * m, v * m


@njit(cache=True)
def _splitmix64(x):
    """(next state, output) of splitmix64 from state ``x`` (uint64)."""
    x = x + np.uint64(0x9E3779B97F4A7C15)
    z = x
    z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    return x, z ^ (z >> np.uint64(31))


@njit(cache=True)
def seed_stream(rng, trial, stream, seed, key):
    """Seed ``rng[trial, stream]`` from ``seed`` and a stream ``key`` (both int64 >= 0).

    The seed is hashed by one splitmix64 step, mixed with the key (times an odd constant),
    and four splitmix64 outputs of that are the state, as xoshiro's authors recommend for
    seeding: distinct (seed, key) pairs give unrelated streams.
    """
    x = np.uint64(seed)
    x, h = _splitmix64(x)
    x = h ^ (np.uint64(key) * np.uint64(0xD1B54A32D192ED03))
    for w in range(4):
        x, out = _splitmix64(x)
        rng[trial, stream, w] = out


def spawn_states(seeds, n_streams: int) -> np.ndarray:
    """xoshiro256** states (len(seeds), n_streams, 4): one numpy SeedSequence child per stream."""
    states = np.empty((len(seeds), n_streams, 4), dtype=np.uint64)
    for row, seed in enumerate(seeds):
        for stream, child in enumerate(np.random.SeedSequence(int(seed)).spawn(n_streams)):
            states[row, stream] = child.generate_state(4, dtype=np.uint64)
    return states
