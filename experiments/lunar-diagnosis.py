#!/usr/bin/env python3
"""Lunar: why the guidance field does not lead robots at 0.125 m/s, and which reading
gives the network timing, survival and foraging together (docs/lunar-readings.md).

``python experiments/lunar-diagnosis.py [--runs N] [--only diagnosis|readings]`` prints, as Markdown
tables: (1) the diagnosis at 1.25 and 0.125 m/s (p_move 5.8 W) in SOFT-RT and OPEN: the share of
60-s stretches in which a mobile robot moves under 3 m net (by cause) and the cosine between each
mobile robot's heading and its own guidance vector, and between that vector and the way to its
region; (2) every reading tried, with the three criteria (dronefleet.lunar.diagnosis.criteria);
(3) the reading chosen, configs/lunar-thesis.toml, in three layouts with 4 N runs each.
Runs j = 0 .. N-1 of seed 0 (default N = 10); a few minutes on one core after the kernel compiles.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import dronefleet
from dronefleet.lunar import diagnosis
from dronefleet.lunar.layout import build
from dronefleet.lunar.params import LunarParams

CONFIG = Path(__file__).resolve().parent.parent / "configs" / "lunar.toml"
THESIS = CONFIG.with_name("lunar-thesis.toml")        # the reading chosen
SLOW = {"v0": 0.125, "p_move": 5.8}          # A1 at the same energy per metre (E4)
#: The readings tried, in SOFT-RT at 10 Wh: a name and the keys changed from configs/lunar.toml.
READINGS = [
    ("defaults (1.25 m/s)", {}),
    ("depletion recorded", {"depletion": "recorded"}),
    ("decision_step_m 1.0", {"decision_step_m": 1.0}),
    ("decision_step_m 1.5", {"decision_step_m": 1.5}),
    ("decision_step_m 1.0, leaving", {"decision_step_m": 1.0, "experience": "leaving"}),
    ("decision_step_m 1.0, recorded, soc0_low 0.8", {"decision_step_m": 1.0, "depletion": "recorded",
                                                     "soc0_low": 0.8}),
    ("0.125 m/s, 5.8 W", SLOW),
    ("0.125 m/s, 5.8 W, leaving", {**SLOW, "experience": "leaving"}),
    ("0.125 m/s, 5.8 W, soc0_low 0.8", {**SLOW, "soc0_low": 0.8}),
    ("0.125 m/s, 5.8 W, kappa_soft 5", {**SLOW, "kappa_soft": 5.0}),
    ("0.125 m/s, 5.8 W, redecide beacon_change", {**SLOW, "redecide": "beacon_change"}),
    ("0.125 m/s, 5.8 W, redecide avoid_clear", {**SLOW, "redecide": "avoid_clear"}),
    ("0.125 m/s, 5.8 W, completion last_region", {**SLOW, "completion": "last_region"}),
    ("0.125 m/s, 5.8 W, turn_on any", {**SLOW, "turn_on": "any"}),
    ("0.125 m/s, 5.8 W, broadcast update", {**SLOW, "broadcast": "update"}),
    ("0.125 m/s, 5.8 W, broadcast_velocity motion", {**SLOW, "broadcast_velocity": "motion"}),
    ("0.125 m/s, 5.8 W, avoidance turn", {**SLOW, "avoidance": "turn"}),
    ("0.125 m/s, 5.8 W, weight_form bracket", {**SLOW, "weight_form": "bracket"}),
    ("0.125 m/s, 5.8 W, weight_form literal", {**SLOW, "weight_form": "literal"}),
    ("0.125 m/s, 5.8 W, fallback literal", {**SLOW, "fallback": "literal"}),
    ("0.125 m/s, 5.8 W, leaving, soc0_low 0.8", {**SLOW, "experience": "leaving", "soc0_low": 0.8}),
    ("0.125 m/s, 5.8 W, leaving, kappa_soft 5", {**SLOW, "experience": "leaving", "kappa_soft": 5.0}),
    ("0.125 m/s, 5.8 W, leaving, kappa_soft 10", {**SLOW, "experience": "leaving", "kappa_soft": 10.0}),
    ("0.125 m/s, 5.8 W, leaving, broadcast_velocity motion", {**SLOW, "experience": "leaving",
                                                              "broadcast_velocity": "motion"}),
    ("0.125 m/s, 5.8 W, leaving, redecide beacon_change", {**SLOW, "experience": "leaving",
                                                           "redecide": "beacon_change"}),
    ("0.125 m/s, 58 W", {"v0": 0.125}),
    ("0.125 m/s, 58 W, recorded", {"v0": 0.125, "depletion": "recorded"}),
    ("0.125 m/s, 5.8 W, energy_scale 7.5, recorded", {**SLOW, "energy_scale": 7.5, "depletion": "recorded"}),
]


def _run(runs: int, frames: bool = False, **changes):
    """One configuration's runs 0 .. runs-1 (frames every 60 s when ``frames``)."""
    if frames:
        changes = {**changes, "frames": True, "frame_every_s": 60.0}
    return dronefleet.run(CONFIG, runs=runs, **changes)


def _cell(value) -> str:
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, float):
        return "-" if math.isnan(value) else f"{value:.3g}" if abs(value) < 10 else f"{value:.0f}"
    return str(value)


def _table(header: list[str], rows: list[list]) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(_cell(v) for v in row) + " |" for row in rows]
    return "\n".join(lines)


def diagnose(runs: int) -> str:
    """The diagnosis tables: stretches under 3 m by cause, heading-guidance and guidance-goal cosines."""
    moves, cosines = [], []
    for layout in ("SOFT-RT", "OPEN"):
        params = LunarParams(layout=layout)
        geometry = build(params)
        for name, speed in (("1.25 m/s", {}), ("0.125 m/s", SLOW),
                            ("0.125 m/s, leaving", {**SLOW, "experience": "leaving"})):
            run = _run(runs, frames=True, layout=layout, **speed)
            shares = diagnosis.stuck_shares(diagnosis.stretches(run.snapshots, geometry.field, params.r_body,
                                                                params.ir_range))
            moves.append([layout, name, shares["stretches"], shares["median_m"], shares["stuck"],
                          shares["stuck_charging"], shares["stuck_beacon"], shares["stuck_wall"], shares["stuck_free"]])
            table = diagnosis.heading_cosines(run.snapshots, geometry.centres, params.comm_radius, params.rho_f,
                                              params.rho_c, params.weight_form)
            for role, rows in [("all", table), *table.groupby("role")]:
                heading = diagnosis.cosine_shares(rows)
                goal = diagnosis.cosine_shares(rows, "cos_goal")
                cosines.append([layout, name, role, heading["rows"], heading["zero"], heading["below"],
                                heading["along"], heading["mean"], goal["below"], goal["along"], goal["mean"]])
    return "\n\n".join([
        _table(["layout", "speed", "stretches", "median m", "< 3 m", "charging", "near beacon", "near wall",
                "in the open"], moves),
        _table(["layout", "speed", "role", "robot-frames", "G = 0", "heading cos < -0.5", "heading cos > 0.5",
                "mean heading cos", "goal cos < -0.5", "goal cos > 0.5", "mean goal cos"], cosines)])


def readings(runs: int) -> str:
    """The table of every reading tried, with the three criteria."""
    rows = []
    for name, changes in READINGS:
        run = _run(runs, **changes)
        c = diagnosis.criteria(run.timeseries, run.summary)
        rows.append([name, c["t90_s"], c["t_peak_s"], c["decay"], c["mobile_rise"], c["timing"], c["deaths"],
                     c["depletions"], c["survival"], c["resources"], c["foraging"],
                     c["timing"] + c["survival"] + c["foraging"]])
    return _table(["reading (SOFT-RT, 10 Wh)", "t90 s (median)", "t peak s", "decay", "mobile rise", "timing",
                   "deaths/run", "depletions/run", "survival", "resources/run", "foraging", "of 3"], rows)


def choice(runs: int) -> str:
    """configs/lunar-thesis.toml in SOFT-RT, OPEN and HARD-RT: the criteria, and the spread of resources."""
    rows = []
    for layout in ("SOFT-RT", "OPEN", "HARD-RT"):
        run = dronefleet.run(THESIS, runs=runs, layout=layout)
        c = diagnosis.criteria(run.timeseries, run.summary)
        resources = run.summary["resources"]
        rows.append([layout, runs, c["t90_s"], c["t_peak_s"], c["decay"], c["mobile_rise"], c["deaths"],
                     c["resources"], float(resources.median()), float((resources > 600).mean()),
                     float(resources.std() / math.sqrt(runs)), c["all"]])
    return _table(["configs/lunar-thesis.toml", "runs", "t90 s (median)", "t peak s", "decay", "mobile rise",
                   "deaths/run", "resources/run", "median", "share of runs > 600", "s.e.", "all three"], rows)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=10, help="runs per configuration (default 10)")
    parser.add_argument("--only", choices=("diagnosis", "readings", "choice"), help="print one part only")
    args = parser.parse_args(argv)
    if args.only in (None, "diagnosis"):
        print(diagnose(args.runs), end="\n\n")
    if args.only in (None, "readings"):
        print(readings(args.runs), end="\n\n")
    if args.only in (None, "choice"):
        print(choice(4 * args.runs))
    return 0


if __name__ == "__main__":
    sys.exit(main())
