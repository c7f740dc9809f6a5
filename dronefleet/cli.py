"""Command line: ``dronefleet run [CONFIG] [--set key=value ...] [--seed N] [--out DIR]
[--fleet FILE] [--save-fleet FILE]``."""

import argparse
import sys
import time
from pathlib import Path

from .config import SECONDS_PER_WEEK, ConfigError, load_config


class ProgressBar:
    """A one-line bar in simulated weeks on stderr, drawn only on a terminal."""

    def __init__(self, horizon_s, stream=sys.stderr, width=32):
        self.horizon_s, self.stream, self.width = horizon_s, stream, width
        self.enabled = stream.isatty()

    def __call__(self, t_s):
        if not self.enabled:
            return
        done = int(self.width * t_s / self.horizon_s)
        self.stream.write(f"\r  week {t_s / SECONDS_PER_WEEK:4.1f} of {self.horizon_s / SECONDS_PER_WEEK:g} "
                          f"[{'#' * done}{'.' * (self.width - done)}]")
        if t_s >= self.horizon_s:
            self.stream.write("\n")
        self.stream.flush()


def _duration(seconds):
    if seconds != seconds:  # nan
        return "n/a"
    hours, rest = divmod(seconds, 3600.0)
    return f"{int(hours)} h {rest / 60.0:04.1f} min"


def format_summary(m, wall_s):
    """The run's summary as printed by ``dronefleet run`` (``m`` from ``metrics.run_metrics``)."""
    delivered_pct = 100.0 * m["delivered"] / m["orders_arrived"] if m["orders_arrived"] else float("nan")
    lines = [
        ("orders arrived", f"{m['orders_arrived']}"),
        ("delivered", f"{m['delivered']} ({delivered_pct:.1f} %)"),
        ("median delivery time", f"{_duration(m['median_delivery_time_s'])} ({m['median_delivery_time_s']:.0f} s)"),
        ("aborted attempts", f"{m['aborted_pct']:.1f} % ({m['aborted_attempts']} of {m['attempts']})"),
        ("backlog age", f"{m['backlog_age_s'] / 86400.0:.1f} days over {m['pending']} pending orders"),
        ("lost UAVs", f"{m['lost_uavs']}"),
        ("decision accuracy", f"{100.0 * m['decision_accuracy']:.1f} % (fleet mean at the end)"),
    ]
    if m["reservations_won"]:
        lines.append(("reservations won", f"{m['reservations_won']}, median wait "
                      f"{_duration(m['median_reservation_wait_s'])}, forecast met {m['forecast_met_pct']:.1f} %"))
    lines.append(("wall time", f"{wall_s:.2f} s"))
    return "\n".join(f"  {label:<22}{value}" for label, value in lines)


def run(args):
    overrides = args.set + ([f"run.fleet_file={args.fleet}"] if args.fleet else [])
    config = load_config(args.config, overrides, args.seed)  # refuses bad input before any work
    name = Path(args.config).stem if args.config else "paper"
    out = Path(args.out) if args.out else Path("results") / "runs" / f"{name}-seed{config.seed}"

    from .fleet import load_fleet, save_fleet
    from .metrics import run_metrics
    from .records import write_run
    from .simulation import simulate

    fleet = load_fleet(config.fleet_file, config) if config.fleet_file else None  # refused before any work

    print(f"dronefleet run: {name}, seed {config.seed}, rule {config.rule}, tau {config.tau_minutes:g} min, "
          f"{config.n_uavs} UAVs, {config.horizon_weeks:g} weeks "
          "(the first run on a machine compiles the engine, ~15 s)", flush=True)
    start = time.perf_counter()
    result = simulate(config, progress=ProgressBar(config.horizon_s), fleet=fleet)
    wall = time.perf_counter() - start
    write_run(result, out)
    print(format_summary(run_metrics(result), wall))
    print(f"  {'tables':<22}{out}/{{orders,attempts,fleet,timeseries,summary}}.parquet")
    if args.save_fleet:
        print(f"  {'saved fleet':<22}{save_fleet(result, args.save_fleet)}")
    return 0


def build_parser():
    parser = argparse.ArgumentParser(prog="dronefleet", description=__doc__)
    commands = parser.add_subparsers(dest="command", required=True)
    p = commands.add_parser("run", help="simulate one run and write its tables as parquet")
    p.add_argument("config", nargs="?", help="TOML config file (default: the paper's scenario)")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="override a config key, e.g. --set tau_minutes=20 or --set auction.rule=random")
    p.add_argument("--seed", type=int, help="seed of the run (overrides run.seed)")
    p.add_argument("--out", help="output directory (default: results/runs/<config>-seed<N>)")
    p.add_argument("--fleet", metavar="FILE",
                   help="start from a saved fleet (parquet, '{seed}' is replaced by the seed); "
                        "same as --set run.fleet_file=FILE")
    p.add_argument("--save-fleet", metavar="FILE", help="save the fleet at the end of the run (parquet)")
    p.set_defaults(func=run)
    return parser


def main(argv=None):
    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except ConfigError as error:
        print(f"dronefleet: config error: {error}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
