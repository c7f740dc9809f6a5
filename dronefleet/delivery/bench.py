"""Benchmark of the paper scenario: ``python -m dronefleet.delivery.bench [--runs N] [--warm] [--scaling] [--big]``.

Prints the compile time (a child process compiles the engine into a fresh, empty numba
cache; skipped with ``--warm``, which uses the existing cache), and for ``--runs`` seeds of
the 8-week paper run, after compilation: the engine's wall seconds per run (median, min,
max), split into set-up (orders, fleet, initial policies), the event loop and collecting
the result, with what the loop did (orders, attempts, advertisements); then the peak
resident memory of the process doing the runs. It asserts nothing: machines are noisy,
read the figures.

``--scaling`` adds the fleet-size table: 25, 100, 400 and 1600 UAVs (10,000 too with
``--big``) at constant load per UAV (tau = 15 min x 25 / n), fewer weeks for the larger
fleets (stated in the table; the loop time is also given per 8 weeks, scaled linearly),
and the fitted exponent of loop time against fleet size.

``--process`` adds whole-process times with warm caches (median of 5 subprocesses): a
``dronefleet run`` of the paper config, a bare ``python -c "import numpy, numba"`` and
``dronefleet --help``.

A whole sweep is timed by ``python -m dronefleet.bench sweep FILE`` (it runs the sweeps,
which sit above this package), in a fresh cache made here (:func:`fresh_cache`).
"""

import argparse
import contextlib
import math
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

#: Fleet sizes of the scaling table and the weeks each is run for (fewer for the big ones).
SCALING_WEEKS = {25: 8.0, 100: 8.0, 400: 2.0, 1600: 0.5}
BIG_WEEKS = {10000: 0.125}


def compile_engine():
    """Compile (or load from the cache) everything a paper run needs, with a short run."""
    from .config import default_config, replace
    from .simulation import simulate

    simulate(replace(default_config(), horizon_weeks=0.1))


def timed_run(config):
    """One run as ``simulate`` does it; (set-up s, loop s, collect s, counters) of its phases."""
    from . import engine
    from .simulation import advance, collect, initial_state, snapshot, stops

    start = time.perf_counter()
    state = initial_state(config)
    setup = time.perf_counter()
    snapshots = []
    loop = 0.0
    for t in stops(config.horizon_s):
        before = time.perf_counter()
        advance(state, t)
        loop += time.perf_counter() - before
        snapshots.append(snapshot(state, t))
    before = time.perf_counter()
    collect(state, snapshots, config)
    done = time.perf_counter()
    counters = state.counters
    counts = dict(orders=int(counters[engine.NEXT_ORDER]), attempts=int(counters[engine.N_ATTEMPTS]),
                  auctions=int(counters[engine.N_AUCTIONS]))
    return setup - start, loop, done - before, counts


def _span(values, digits=3):
    return f"{statistics.median(values):.{digits}f} [{min(values):.{digits}f}-{max(values):.{digits}f}]"


def bench_paper(runs):
    """The paper run (25 UAVs, 8 weeks, tau 15 min, least_confident) for seeds 0..runs-1; prints
    and returns the engine's seconds per run (``engine_s``: one per seed)."""
    from .config import default_config, replace

    config = default_config()
    phases = [timed_run(replace(config, seed=seed)) for seed in range(runs)]
    print(f"paper run: {config.n_uavs} UAVs, {config.horizon_weeks:g} weeks, tau = {config.tau_minutes:g} min, "
          f"{config.rule}; {runs} runs (seeds 0..{runs - 1}); median [min-max]")
    print(f"  engine s per run (set-up + loop + collect): {_span([sum(p[:3]) for p in phases])}")
    print(f"  set-up {_span([p[0] for p in phases])}, loop {_span([p[1] for p in phases])}, "
          f"collect {_span([p[2] for p in phases])}")
    counts = phases[0][3]
    print(f"  seed 0: {counts['orders']} orders, {counts['attempts']} attempts, "
          f"{counts['auctions']} advertisements (ticks advertised, evaluated or skipped)")
    return {"engine_s": [sum(p[:3]) for p in phases]}


def bench_scaling(weeks):
    """Loop time against fleet size at constant load per UAV; prints the table and the fitted exponent,
    returns ``{"loop_s_per_8_weeks": {UAVs: s}, "exponent": fitted over the goal's range 25-1600}``."""
    from .config import default_config, replace

    base = default_config()
    print(f"fleet-size scaling: tau = {base.tau_minutes:g} min x {base.n_uavs} / n, {base.rule}, seed 0")
    print(f"  {'UAVs':>6} {'weeks':>6} {'orders':>9} {'set-up s':>9} {'loop s':>9} {'loop s/8 wk':>12}")
    sizes, per8 = [], []
    for n, w in weeks.items():
        config = replace(base, n_uavs=n, horizon_weeks=w, tau_minutes=base.tau_minutes * base.n_uavs / n)
        setup, loop, _, counts = timed_run(config)
        sizes.append(n)
        per8.append(loop * 8.0 / w)
        print(f"  {n:>6} {w:>6g} {counts['orders']:>9} {setup:>9.3f} {loop:>9.3f} {per8[-1]:>12.3f}")
    for m in sorted({len(SCALING_WEEKS), len(sizes)}):  # the goal's range 25-1600, then with 10,000
        x = [math.log(n) for n in sizes[:m]]
        y = [math.log(s) for s in per8[:m]]
        mx, my = statistics.fmean(x), statistics.fmean(y)
        slope = sum((a - mx) * (b - my) for a, b in zip(x, y)) / sum((a - mx) ** 2 for a in x)
        print(f"  fitted exponent of loop time per 8 weeks against UAVs ({sizes[0]}-{sizes[m - 1]}): {slope:.2f}")
        if m == len(SCALING_WEEKS):
            exponent = slope
    return {"loop_s_per_8_weeks": dict(zip(sizes, per8)), "exponent": exponent}


def _median_process_s(command, repeats=5):
    walls = []
    for _ in range(repeats):
        start = time.perf_counter()
        # From a neutral folder: ``-m`` puts the working directory first on sys.path.
        subprocess.run(command, check=True, stdout=subprocess.DEVNULL, cwd=tempfile.gettempdir())
        walls.append(time.perf_counter() - start)
    return walls


def bench_process():
    """Whole-process times with warm caches: a paper ``dronefleet run``, bare imports, ``--help``;
    prints them and returns the seconds of each of the 5 processes per command."""
    python = sys.executable
    _median_process_s([python, "-m", "dronefleet.cli", "--help"], 1)  # warm the caches
    with tempfile.TemporaryDirectory(prefix="dronefleet-bench-") as out:
        run = [python, "-m", "dronefleet.cli", "run", "--out", str(Path(out) / "run"), "--overwrite"]
        _median_process_s(run, 1)
        walls = {"dronefleet run (paper config)": _median_process_s(run)}
    walls["python -c 'import numpy, numba'"] = _median_process_s([python, "-c", "import numpy, numba"])
    walls["dronefleet --help"] = _median_process_s([python, "-m", "dronefleet.cli", "--help"])
    print("whole processes, warm caches (median [min-max] of 5):")
    for command, seconds in walls.items():
        print(f"  {command}: {_span(seconds, 2)} s")
    return walls


def main(argv=None):
    parser = argparse.ArgumentParser(prog="python -m dronefleet.delivery.bench", description=__doc__)
    parser.add_argument("--runs", type=int, default=5, help="timed paper runs after compilation (default 5)")
    parser.add_argument("--warm", action="store_true", help="use the existing numba cache instead of compiling")
    parser.add_argument("--scaling", action="store_true", help="add the fleet-size table (25-1600 UAVs)")
    parser.add_argument("--big", action="store_true", help="add 10,000 UAVs to the fleet-size table")
    parser.add_argument("--process", action="store_true", help="add whole-process times (run, imports, --help)")
    args = parser.parse_args(argv)
    if args.warm:
        return _bench(args, float("nan"))
    with fresh_cache() as compile_s:
        return _bench(args, compile_s)


@contextlib.contextmanager
def fresh_cache() -> Iterator[float]:
    """A fresh, empty numba cache for this process and the processes it starts, filled by a child
    process that compiles the engine; yields that child's wall time [s] (the compile time)."""
    # set before numba is imported here and in the child that fills it
    with tempfile.TemporaryDirectory(prefix="dronefleet-bench-cache-") as cache:
        os.environ["NUMBA_CACHE_DIR"] = cache
        start = time.perf_counter()
        subprocess.run([sys.executable, "-c", "import dronefleet.delivery.bench as b; b.compile_engine()"], check=True)
        yield time.perf_counter() - start


def _bench(args, compile_s):
    """Print the figures that ``args`` ask for; return them (``compile_s``, ``load_s``, ``peak_mb``
    and what :func:`bench_paper`, :func:`bench_scaling` and :func:`bench_process` return)."""
    start = time.perf_counter()
    compile_engine()
    load_s = time.perf_counter() - start
    print(f"Python {sys.version.split()[0]}; compile time (fresh process, empty cache): {compile_s:.1f} s; "
          f"loading the compiled engine: {load_s:.2f} s")
    figures = {"compile_s": compile_s, "load_s": load_s, **bench_paper(args.runs)}
    if args.scaling or args.big:
        figures.update(bench_scaling({**SCALING_WEEKS, **(BIG_WEEKS if args.big else {})}))
    figures["peak_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0  # KiB on Linux
    print(f"peak memory (max RSS of the process doing the runs): {figures['peak_mb']:.0f} MB")
    if args.process:
        figures["process_s"] = bench_process()
    return figures


if __name__ == "__main__":
    main()
