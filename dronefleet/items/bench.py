"""Benchmark of the items kernel: ``python -m dronefleet.items.bench``.

Times, after compilation, foraging configurations (20 random locations, 1000 steps) and
item-delivery ones (the 441-point grid, 1000 steps), each of ``trials`` trials in one kernel call,
and prints the milliseconds per run amortised over the trials (median of ``repeats`` calls) with
the goal where one is set: foraging GR with Bernoulli demand, 5 robots of capacity 10, 0.1 ms;
delivery GRIC with Poisson demand, 5 robots, 1.2 ms; and the older goals of GR with 10 robots
(0.3 ms foraging, 5 ms delivery). Speed is measured here, never in a test.
"""

import statistics
import time

from .params import Params
from .simulate import run_cell

__all__ = ["CONFIGS", "TARGETS_MS", "bench_items"]

CONFIGS = {
    "foraging GR Bernoulli": Params(truth="bernoulli", algorithm="GR", trials=200),
    "delivery GRIC 5 robots": Params(mode="delivery", algorithm="GRIC", trials=20),
    "foraging GR": Params(algorithm="GR", n_robots=10, trials=100),
    "delivery GR": Params(mode="delivery", algorithm="GR", n_robots=10, trials=20),
    "foraging R": Params(algorithm="R", n_robots=10, trials=100),
    "foraging CAS": Params(algorithm="CAS", n_robots=10, trials=100),
    "foraging logistic SF": Params(truth="logistic", algorithm="SF", n_robots=10, trials=100),
    "delivery GRIC": Params(mode="delivery", algorithm="GRIC", n_robots=10, trials=20),
    "delivery CAS": Params(mode="delivery", algorithm="CAS", n_robots=10, trials=20),
    "delivery R": Params(mode="delivery", algorithm="R", n_robots=10, trials=20),
}
TARGETS_MS = {"foraging GR Bernoulli": 0.1, "delivery GRIC 5 robots": 1.2, "foraging GR": 0.3, "delivery GR": 5.0}


def bench_items(repeats=5, configs=None, out=print):
    """Time each configuration ``repeats`` times; print and return ``{name: ms per run}`` and
    ``compile_s``, the seconds of the first calls (compiling the kernel or loading it from the cache)."""
    configs = CONFIGS if configs is None else configs
    start = time.perf_counter()
    for params in configs.values():
        run_cell(params.replace(trials=1, steps=1))
    result = {"compile_s": time.perf_counter() - start}
    out(f"compile (or load from cache): {result['compile_s']:.2f} s")
    for name, params in configs.items():
        seconds = []
        for _ in range(repeats):
            start = time.perf_counter()
            run_cell(params)
            seconds.append(time.perf_counter() - start)
        result[name] = 1e3 * statistics.median(seconds) / params.trials
        target = f" (target <= {TARGETS_MS[name]:g} ms)" if name in TARGETS_MS else ""
        out(f"{name}: {params.n_locations} locations, {params.n_robots} robots, {params.steps} steps: "
            f"{result[name]:.3f} ms per run over {params.trials} trials (median of {repeats}){target}")
    return result


if __name__ == "__main__":
    bench_items()
