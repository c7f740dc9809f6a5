"""Benchmarks: ``python -m dronefleet.bench [delivery|replenishment|reproduce] [options]``.

``delivery`` passes its options to :mod:`dronefleet.delivery.bench` (``--help`` lists
them: compile time, per-run phases, ``--scaling``, ``--big``, ``--process``, ``--sweep``);
``replenishment`` runs :mod:`dronefleet.replenishment.bench`; ``reproduce [--jobs J]``
times a whole ``dronefleet reproduce all`` (every figure of both scenarios, warm caches)
into a temporary results folder. Without a target, delivery and replenishment run with
their defaults, delivery first. It prints; it asserts nothing.
"""

import argparse
import resource
import subprocess
import sys
import tempfile
import time


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


def main(argv=None):
    argv = sys.argv[1:] if argv is None else list(argv)
    target = argv.pop(0) if argv and argv[0] in ("delivery", "replenishment", "reproduce") else None
    if target == "reproduce":
        return bench_reproduce(argv)
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
