"""Benchmark of the lunar kernel: ``python -m dronefleet.lunar.bench``.

Times, after compilation, hour-long runs of 50 robots (56,250 ticks; the spec's section-3
defaults) in one kernel call per configuration, and prints the seconds per run amortised over the
runs (median of ``repeats`` calls; the target: 0.3 s per run on one core), and the
process's CPU seconds per run beside it (the wall time of a shared machine includes waiting for a
core). Speed is measured here, never in a test.
"""

import statistics
import time

from .params import LunarParams
from .simulate import run_kernel

__all__ = ["CONFIGS", "TARGET_S", "bench_lunar"]

CONFIGS = {
    "SOFT-RT": LunarParams(runs=4),
    "HARD-RT": LunarParams(layout="HARD-RT", runs=4),
    "OPEN": LunarParams(layout="OPEN", runs=4),
    # the readings of the thesis as options (each within the target too), the last one configs/lunar-thesis.toml's
    "decision_step_m=1": LunarParams(runs=4, decision_step_m=1.0),
    "energy_scale=7.5, depletion=recorded": LunarParams(runs=4, energy_scale=7.5, depletion="recorded"),
    "soc0_low=0.8": LunarParams(runs=4, soc0_low=0.8),
    "kappa_soft=5": LunarParams(runs=4, kappa_soft=5.0),
    "los_bodies": LunarParams(runs=4, los_bodies=True),
    "thesis reading": LunarParams(runs=4, v0=0.125, p_move=5.8, experience="leaving"),
}
#: Seconds per hour-long 50-robot run.
TARGET_S = 0.3


def bench_lunar(repeats=3, configs=None, out=print):
    """Time each configuration ``repeats`` times; print and return ``{name: seconds per run}`` and
    ``compile_s``, the seconds of the first call (compiling the kernel or loading it from the cache)."""
    configs = CONFIGS if configs is None else configs
    start = time.perf_counter()
    run_kernel(LunarParams(runs=1, n_robots=2, duration_s=1.0))
    result = {"compile_s": time.perf_counter() - start}
    out(f"compile (or load from cache): {result['compile_s']:.2f} s")
    for name, params in configs.items():
        seconds, cpu = [], []
        for _ in range(repeats):
            start, start_cpu = time.perf_counter(), time.process_time()
            run_kernel(params)
            seconds.append(time.perf_counter() - start)
            cpu.append(time.process_time() - start_cpu)
        result[name] = statistics.median(seconds) / params.runs
        out(f"{name}: {params.n_robots} robots, {params.ticks} ticks: {result[name]:.3f} s per run "
            f"({statistics.median(cpu) / params.runs:.3f} CPU s) over {params.runs} runs "
            f"(median of {repeats}; target <= {TARGET_S:g} s)")
    return result


if __name__ == "__main__":
    bench_lunar()
