"""Benchmark of the paper scenario: ``python -m dronefleet.delivery.bench [--runs N] [--warm]``.

Prints the compile time (a child process compiles the engine into a fresh, empty numba
cache; skipped with ``--warm``, which uses the existing cache), wall seconds per 8-week
run after compilation (median, min, max over ``--runs`` seeds), advertisements
(auctions) per second and the peak resident memory of the process doing the runs. It
asserts nothing: machines are noisy, read the figures.

``--sweep FILE [--jobs J]`` times a whole sweep instead (``configs/sweeps/rules.toml``:
the 360 runs of Figure 16), as ``dronefleet sweep run`` runs it on J local processes,
tables written (into a temporary directory): wall time and runs per minute.
"""

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def compile_engine():
    """Compile (or load from the cache) everything a paper run needs, with a short run."""
    from .config import default_config, replace
    from .simulation import simulate

    simulate(replace(default_config(), horizon_weeks=0.1))


def main(argv=None):
    parser = argparse.ArgumentParser(prog="python -m dronefleet.delivery.bench", description=__doc__)
    parser.add_argument("--runs", type=int, default=5, help="timed runs after compilation (default 5)")
    parser.add_argument("--warm", action="store_true", help="use the existing numba cache instead of compiling")
    parser.add_argument("--sweep", metavar="FILE", help="time this sweep instead, e.g. configs/sweeps/rules.toml")
    parser.add_argument("--jobs", type=int, help="local processes of --sweep (default: all CPUs)")
    args = parser.parse_args(argv)
    compile_s = float("nan")
    if not args.warm:
        # Set before numba is imported here and in the child, which fills the cache.
        os.environ["NUMBA_CACHE_DIR"] = tempfile.mkdtemp(prefix="dronefleet-bench-")
        start = time.perf_counter()
        subprocess.run([sys.executable, "-c", "import dronefleet.delivery.bench as b; b.compile_engine()"], check=True)
        compile_s = time.perf_counter() - start
    if args.sweep:
        return bench_sweep(args.sweep, args.jobs, compile_s)

    from .config import default_config, replace
    from .simulation import simulate

    config = default_config()  # 25 UAVs, 8 weeks, tau = 15 min, least_confident
    start = time.perf_counter()
    compile_engine()
    load_s = time.perf_counter() - start

    walls, auctions = [], []
    for seed in range(args.runs):
        start = time.perf_counter()
        result = simulate(replace(config, seed=seed))
        walls.append(time.perf_counter() - start)
        auctions.append(result.auctions)
    peak_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0  # KiB on Linux

    print(f"scenario: {config.n_uavs} UAVs, {config.horizon_weeks:g} weeks, tau = {config.tau_minutes:g} min, "
          f"{config.rule}; {args.runs} runs (seeds 0..{args.runs - 1}), Python {sys.version.split()[0]}")
    print(f"compile time (fresh process, empty cache): {compile_s:.1f} s; loading the compiled engine: {load_s:.2f} s")
    print(f"wall s per run: median {statistics.median(walls):.3f}, min {min(walls):.3f}, max {max(walls):.3f}")
    print(f"auctions per second: {statistics.median(a / w for a, w in zip(auctions, walls)):.3e} "
          f"({statistics.median(auctions):.0f} auctions per run)")
    print(f"peak memory (max RSS of the process doing the runs): {peak_mb:.0f} MB")


def bench_sweep(path, jobs, compile_s):
    """Run every run of the sweep file ``path`` on ``jobs`` processes into a temporary directory; print the times."""
    from ..sweep import available_cpus, load_sweep, run_sweep

    sweep = load_sweep(path)
    jobs = jobs or available_cpus()
    with tempfile.TemporaryDirectory(prefix="dronefleet-bench-") as results:
        start = time.perf_counter()
        _, failures = run_sweep(sweep, Path(results) / sweep.name, sweep.runs, jobs)
        wall = time.perf_counter() - start
    first = sweep.runs[0].config
    print(f"sweep {sweep.name}: {sweep.describe()} ({first.n_uavs} UAVs, {first.horizon_weeks:g}-week runs), "
          f"{jobs} processes, {len(failures)} failed; Python {sys.version.split()[0]}")
    print(f"compile time (fresh process, empty cache): {compile_s:.1f} s")
    print(f"wall time {wall:.1f} s ({wall / 60.0:.2f} min): {60.0 * len(sweep.runs) / wall:.0f} runs per minute, "
          f"{jobs * wall / len(sweep.runs):.3f} process-seconds per run (tables written)")


if __name__ == "__main__":
    main()
