"""Benchmarks: ``python -m dronefleet.bench [delivery|replenishment|sweep|reproduce] [options]``.

``delivery`` passes its options to :mod:`dronefleet.delivery.bench` (``--help`` lists
them: compile time, per-run phases, ``--scaling``, ``--big``, ``--process``);
``replenishment`` runs :mod:`dronefleet.replenishment.bench`; ``sweep FILE [--jobs J]``
times a whole sweep (``configs/sweeps/rules.toml``: the 360 runs of Figure 16) as
``dronefleet sweep run`` runs it on J local processes, tables written (into a temporary
directory), after compiling the engine into a fresh cache: wall time and runs per minute;
``reproduce [--jobs J]`` times a whole ``dronefleet reproduce all`` (warm caches) into a temporary
results folder: the deliverable's figures (delivery and replenishment) in one command, each other
study's after them in one of its own, listed separately. Without a target, delivery and replenishment run with
their defaults, delivery first. It prints; it asserts nothing.

``--table FILE [--quick] [--scaling] [--sweep FILE] [--reproduce] [--note TEXT]`` runs delivery,
replenishment and items in one fresh numba cache (so every compile time is a real compile),
optionally a sweep and ``reproduce all``, and writes every figure into one Markdown table with the
machine, the date and the options used: the one place the documentation takes its timings from
(``docs/guide/benchmarks-table.md``).
"""

import argparse
import datetime
import os
import platform
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

#: The table the documentation cites for every timing.
TABLE = "docs/guide/benchmarks-table.md"


#: The studies whose figures are the deliverable's: `reproduce` of their figures is timed together,
#: every other study's (items, ...) on its own after them.
DELIVERABLE_STUDIES = ("delivery", "replenishment")


def bench_reproduce(argv):
    """Wall time and peak memory of ``dronefleet reproduce all`` run from scratch into a temporary
    folder: the deliverable's figures (:data:`DELIVERABLE_STUDIES`) in one command, then each other
    study's figures in one command of their own, listed separately."""
    from .reproduce import studies
    from .sweeps import available_cpus

    parser = argparse.ArgumentParser(prog="python -m dronefleet.bench reproduce")
    parser.add_argument("--jobs", type=int, help="local processes (default: all CPUs)")
    jobs = parser.parse_args(argv).jobs or available_cpus()
    found = studies()
    parts = {"the deliverable's figures (" + ", ".join(DELIVERABLE_STUDIES) + ")":
             [figure for name in DELIVERABLE_STUDIES for figure in found[name].FIGURES],
             **{f"{name}'s figures": list(study.FIGURES) for name, study in found.items()
                if name not in DELIVERABLE_STUDIES}}
    walls = {}
    with tempfile.TemporaryDirectory(prefix="dronefleet-bench-") as results:
        for part, figures in parts.items():
            start = time.perf_counter()
            subprocess.run([sys.executable, "-m", "dronefleet.cli", "reproduce", *figures, "--out", results,
                            "--jobs", str(jobs)], check=True, stdout=subprocess.DEVNULL)
            walls[part] = time.perf_counter() - start
    peak_mb = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024.0  # KiB on Linux
    print(f"dronefleet reproduce all (warm caches), {jobs} processes; peak memory of the largest process "
          f"{peak_mb:.0f} MB")
    for part, wall in walls.items():
        print(f"  {part}: wall time {wall:.1f} s")
    print(f"  all: wall time {sum(walls.values()):.1f} s")
    return {"jobs": jobs, "wall_s": walls, "peak_mb": peak_mb}


def bench_sweep(argv):
    """Run every run of a sweep file on J processes into a temporary directory; print the times."""
    from .delivery.bench import fresh_cache
    from .config import named_file
    from .sweeps import available_cpus, load_sweep, run_sweep

    parser = argparse.ArgumentParser(prog="python -m dronefleet.bench sweep")
    parser.add_argument("file", help="the sweep file or a shipped one's name, e.g. configs/sweeps/rules.toml or rules")
    parser.add_argument("--jobs", type=int, help="local processes (default: all CPUs)")
    args = parser.parse_args(argv)
    sweep = load_sweep(named_file(args.file, "sweep"))
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
    return {"name": sweep.name, "runs": len(sweep.runs), "jobs": jobs, "compile_s": compile_s, "wall_s": wall}


def _span(seconds, unit="s", digits=2):
    """``median [min-max] unit`` of one or more measurements (just the value for one)."""
    if len(seconds) == 1:
        return f"{seconds[0]:.{digits}f} {unit}"
    return f"{statistics.median(seconds):.{digits}f} {unit} [{min(seconds):.{digits}f}-{max(seconds):.{digits}f}]"


def machine_line():
    """The machine a table was measured on: CPU model, CPUs usable, OS, Python."""
    model = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as cpuinfo:
            model = next((line.split(":", 1)[1].strip() for line in cpuinfo if line.startswith("model name")), model)
    except OSError:
        pass
    from .sweeps import available_cpus

    return (f"{model}, {available_cpus()} CPUs usable, {platform.system()} {platform.release()}, "
            f"Python {platform.python_version()}")


def bench_table(argv):
    """Measure the documented figures and write them as one Markdown table (see the module's docstring)."""
    from .delivery.bench import _bench, fresh_cache  # imports no numba: the cache is chosen below
    from .provenance import version_line

    parser = argparse.ArgumentParser(prog="python -m dronefleet.bench --table")
    parser.add_argument("--table", required=True, metavar="FILE", help=f"the Markdown file to write ({TABLE})")
    parser.add_argument("--quick", action="store_true", help="one timed run per figure, not 5; no whole-process times")
    parser.add_argument("--scaling", action="store_true", help="add the delivery fleet-size table (25-1600 UAVs)")
    parser.add_argument("--sweep", metavar="FILE", help="also time this sweep file, e.g. configs/sweeps/rules.toml")
    parser.add_argument("--reproduce", action="store_true", help="also time `dronefleet reproduce all`")
    parser.add_argument("--jobs", type=int, help="processes of --sweep and --reproduce (default: all CPUs)")
    parser.add_argument("--note", default="", help="a sentence for the header, e.g. how loaded the machine was")
    args = parser.parse_args(argv)
    table = Path(args.table)
    if table.is_dir() or not table.parent.is_dir():  # said before the minutes of measuring, not after
        print(f"dronefleet.bench: error: --table {table}: must be a file in an existing folder", file=sys.stderr)
        sys.exit(2)
    options = " ".join(["--quick"] * args.quick + ["--scaling"] * args.scaling
                       + [f"--sweep {args.sweep}"] * bool(args.sweep) + ["--reproduce"] * args.reproduce
                       + [f"--jobs {args.jobs}"] * bool(args.jobs))
    load_before = os.getloadavg()[0]
    started = datetime.datetime.now(datetime.UTC)
    repeats = 1 if args.quick else 5
    rows = []  # (figure, measured)
    with fresh_cache() as compile_s:
        # numba reads NUMBA_CACHE_DIR when first imported: these kernels compile into the fresh cache too
        from .items.bench import bench_items
        from .lunar.bench import bench_lunar
        from .replenishment.bench import bench_replenishment

        delivery = _bench(argparse.Namespace(runs=repeats, scaling=args.scaling, big=False, process=not args.quick),
                          compile_s)
        replenishment = bench_replenishment(repeats=repeats)
        items = bench_items(repeats=repeats)
        lunar = bench_lunar(repeats=repeats)
    rows += [("delivery: compiling the engine, a fresh process with an empty cache (a first run on a machine)",
              _span([delivery["compile_s"]], digits=1)),
             ("delivery: loading the compiled engine from the cache", _span([delivery["load_s"]])),
             (f"delivery: engine time per 8-week paper run ({len(delivery['engine_s'])} seeds)",
              _span(delivery["engine_s"], digits=3)),
             ("delivery: peak memory of the process doing paper runs", f"{delivery['peak_mb']:.0f} MB")]
    for command, seconds in delivery.get("process_s", {}).items():
        rows.append((f"whole process, warm caches: `{command}` (5 processes)", _span(seconds)))
    for uavs, seconds in delivery.get("loop_s_per_8_weeks", {}).items():
        rows.append((f"delivery scaling: event loop per 8 weeks, {uavs} UAVs (tau = 15 min x 25 / n)",
                     _span([seconds])))
    if "exponent" in delivery:
        rows.append(("delivery scaling: fitted exponent of loop time against UAVs (25-1600)",
                     f"{delivery['exponent']:.2f}"))
    rows += [("replenishment: compiling the kernel (both strategies, in-process)",
              _span([replenishment["compile_s"]], digits=1)),
             ("replenishment: one configuration, 50 trials x 6000 ticks, fixed chargers",
              _span([replenishment["fixed_s"]])),
             ("replenishment: one configuration, 50 trials x 6000 ticks, 6 mobile chargers (phi 2)",
              _span([replenishment["mobile_s"]])),
             ("items: compiling the kernel (every algorithm benchmarked, in-process)",
              _span([items.pop("compile_s")], digits=1))]
    rows += [(f"items: {name}, per run (amortised over a configuration's trials)", _span([ms], "ms", 3))
             for name, ms in items.items()]
    rows += [("lunar: compiling the kernel (in-process)", _span([lunar.pop("compile_s")], digits=1))]
    rows += [(f"lunar: {name}, one hour-long run of 50 robots (amortised over a configuration's runs)",
              _span([seconds], digits=3)) for name, seconds in lunar.items()]
    if args.sweep:
        sweep = bench_sweep([args.sweep, *(["--jobs", str(args.jobs)] if args.jobs else [])])
        rows += [(f"sweep {sweep['name']}: {sweep['runs']} runs on {sweep['jobs']} processes, tables written",
                  f"{sweep['wall_s']:.1f} s ({60.0 * sweep['runs'] / sweep['wall_s']:.0f} runs per minute)")]
    if args.reproduce:
        whole = bench_reproduce(["--jobs", str(args.jobs)] if args.jobs else [])
        rows += [(f"`dronefleet reproduce` of {part} (warm caches), {whole['jobs']} processes",
                  f"{wall:.1f} s, largest process {whole['peak_mb']:.0f} MB")
                 for part, wall in whole["wall_s"].items()]
    load_after = os.getloadavg()[0]
    note = f" {args.note.strip()}" if args.note.strip() else ""
    lines = ["# Benchmark figures", "",
             f"Measured {started:%Y-%m-%d %H:%M} UTC on {machine_line()}, {version_line()}; load average "
             f"{load_before:.1f} before and {load_after:.1f} after (the figures are wall times, slower on a loaded "
             f"machine).{note}", "",
             f"Generated by `python -m dronefleet.bench --table {args.table}{' ' + options if options else ''}`: "
             "edit nothing here by hand, run it again. Compile times are one measurement; a value with a range "
             f"is the median [min-max] of {repeats} runs, and the replenishment, items and lunar figures are "
             f"the median of {repeats}.", "",
             "| figure | measured |", "|---|---|", *(f"| {figure} | {value} |" for figure, value in rows), ""]
    temporary = table.with_name(f".{table.name}.{os.getpid()}.tmp")
    temporary.write_text("\n".join(lines), encoding="utf-8")
    temporary.replace(table)
    print(f"wrote {table}")


def main(argv=None):
    argv = sys.argv[1:] if argv is None else list(argv)
    if any(arg == "--table" or arg.startswith("--table=") for arg in argv):
        return bench_table(argv)
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
    from .config import ConfigError

    try:
        main()
    except ConfigError as error:  # a sweep file that cannot be read: one line, as the CLI says it
        print(f"python -m dronefleet.bench: error: {error}", file=sys.stderr)
        sys.exit(2)
