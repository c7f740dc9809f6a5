"""Benchmarks: ``python -m dronefleet.bench [delivery|replenishment|sweep|reproduce] [options]``.

``delivery`` passes its options to :mod:`dronefleet.delivery.bench` (``--help`` lists
them: compile time, per-run phases, ``--scaling``, ``--big``, ``--process``);
``replenishment`` runs :mod:`dronefleet.replenishment.bench`; ``sweep FILE [--jobs J]``
times a whole sweep (``configs/sweeps/rules.toml``: the 360 runs of Figure 16) as
``dronefleet sweep run`` runs it on J local processes, tables written (into a temporary
directory), after compiling the engine into a fresh cache: wall time and runs per minute;
``reproduce [--jobs J]`` times a whole ``dronefleet reproduce all`` (every figure of both
scenarios, warm caches) into a temporary results folder. Without a target, delivery and replenishment run with
their defaults, delivery first. It prints; it asserts nothing.
"""

import argparse
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def bench_reproduce(argv):
    """Wall time and peak memory of ``dronefleet reproduce all`` run from scratch into a temporary folder."""
    from .sweeps import available_cpus

    parser = argparse.ArgumentParser(prog="python -m dronefleet.bench reproduce")
    parser.add_argument("--jobs", type=int, help="local processes (default: all CPUs)")
    jobs = parser.parse_args(argv).jobs or available_cpus()
    with tempfile.TemporaryDirectory(prefix="dronefleet-bench-") as results:
        start = time.perf_counter()
        subprocess.run([sys.executable, "-m", "dronefleet.cli", "reproduce", "all", "--out", results,
                        "--jobs", str(jobs)], check=True, stdout=subprocess.DEVNULL)
        wall = time.perf_counter() - start
    peak_mb = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024.0  # KiB on Linux
    print(f"dronefleet reproduce all (Figs 9-12 and 16-20, warm caches), {jobs} processes: "
          f"wall time {wall:.1f} s; peak memory of the largest process {peak_mb:.0f} MB")


def bench_sweep(argv):
    """Run every run of a sweep file on J processes into a temporary directory; print the times."""
    from .delivery.bench import fresh_cache
    from .sweeps import available_cpus, load_sweep, run_sweep

    parser = argparse.ArgumentParser(prog="python -m dronefleet.bench sweep")
    parser.add_argument("file", help="the sweep file, e.g. configs/sweeps/rules.toml")
    parser.add_argument("--jobs", type=int, help="local processes (default: all CPUs)")
    args = parser.parse_args(argv)
    sweep = load_sweep(args.file)
    jobs = args.jobs or available_cpus()
    with fresh_cache() as compile_s, tempfile.TemporaryDirectory(prefix="dronefleet-bench-") as results:
        start = time.perf_counter()
        _, failures = run_sweep(sweep, Path(results) / sweep.name, sweep.runs, jobs)
        wall = time.perf_counter() - start
    first = sweep.runs[0].config
    print(f"sweep {sweep.name}: {sweep.describe()} ({first.n_uavs} UAVs, {first.horizon_weeks:g}-week runs), "
          f"{jobs} processes, {len(failures)} failed; Python {sys.version.split()[0]}")
    print(f"compile time (fresh process, empty cache): {compile_s:.1f} s")
    print(f"wall time {wall:.1f} s ({wall / 60.0:.2f} min): {60.0 * len(sweep.runs) / wall:.0f} runs per minute, "
          f"{jobs * wall / len(sweep.runs):.3f} process-seconds per run (tables written)")


def main(argv=None):
    argv = sys.argv[1:] if argv is None else list(argv)
    target = argv.pop(0) if argv and argv[0] in ("delivery", "replenishment", "sweep", "reproduce") else None
    if target == "reproduce":
        return bench_reproduce(argv)
    if target == "sweep":
        return bench_sweep(argv)
    if target in (None, "delivery"):
        from .delivery.bench import main as delivery

        print("== delivery ==")
        delivery(argv)
    if target in (None, "replenishment"):
        from .replenishment.bench import bench_replenishment

        print("== replenishment ==")
        bench_replenishment()


if __name__ == "__main__":
    main()
