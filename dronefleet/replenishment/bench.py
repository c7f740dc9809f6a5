"""Benchmark of the replenishment kernel: ``python -m dronefleet.replenishment.bench``.

Times one configuration of issue 11's size (50 trials x 6000 ticks, 6
workers) for the fixed strategy and for 6 mobile chargers (phi = 2), after
compilation, and prints compile time, seconds per configuration (median of
5), trials per second and the process's peak memory. Speed is measured here,
never in a test.
"""

import resource
import statistics
import time

from .params import Params
from .simulate import simulate

__all__ = ["CONFIGS", "bench_replenishment"]

CONFIGS = {
    "fixed": Params(strategy="fixed", n_workers=6, trials=50, ticks=6000),
    "mobile": Params(strategy="mobile", n_workers=6, n_chargers=6, charger_capacity_factor=2.0,
                     trials=50, ticks=6000),
}


def bench_replenishment(repeats=5, configs=None, out=print):
    """Time each configuration ``repeats`` times; print and return the numbers.

    Returns
    -------
    dict
        ``compile_s`` (first call of each strategy, including loading or
        compiling the kernel), ``{name}_s`` (median seconds per configuration),
        ``{name}_trials_per_s`` and ``peak_rss_mb`` (resource.getrusage).
    """
    configs = CONFIGS if configs is None else configs
    result = {}
    start = time.perf_counter()
    for params in configs.values():
        simulate(params.replace(ticks=1, trials=1))
    result["compile_s"] = time.perf_counter() - start
    out(f"compile (or load from cache): {result['compile_s']:.2f} s")
    for name, params in configs.items():
        seconds = []
        for _ in range(repeats):
            start = time.perf_counter()
            simulate(params)
            seconds.append(time.perf_counter() - start)
        median = statistics.median(seconds)
        result[f"{name}_s"] = median
        result[f"{name}_trials_per_s"] = params.trials / median
        out(f"{name}: {params.trials} trials x {params.ticks} ticks, {params.n_workers} workers, "
            f"{params.n_chargers} chargers: {median:.3f} s per configuration "
            f"(median of {repeats}), {params.trials / median:.0f} trials/s")
    # ru_maxrss is in KiB on Linux
    result["peak_rss_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    out(f"peak memory: {result['peak_rss_mb']:.0f} MB")
    return result


if __name__ == "__main__":
    bench_replenishment()
