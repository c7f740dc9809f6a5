#!/usr/bin/env python3
"""Lunar: a verdict for every claim of docs/lunar-thesis-checklist.md, at the defaults
(configs/lunar.toml) and under the thesis reading (configs/lunar-thesis.toml).

``python experiments/lunar-verdicts.py [--jobs N] [--out DIR]`` runs E1-E3 (nine conditions of 50
runs, 450 hour-long runs) for each of the two configurations (dronefleet.lunar.verdicts), writes
``DIR/verdicts.parquet`` (default ``results/lunar-verdicts/``; columns claim, verdict_defaults,
numbers_defaults, verdict_thesis, numbers_thesis) and prints the verdicts as a Markdown table
with the counts per configuration. About 80 CPU s per configuration after the kernel compiles.
"""

from __future__ import annotations

import argparse
import logging
import time
from pathlib import Path

import pyarrow as pa
import pyarrow.parquet as pq

from dronefleet import executors
from dronefleet.lunar import scenario, verdicts
from dronefleet.provenance import stamp
from dronefleet.records import write_atomic

ROOT = Path(__file__).resolve().parent.parent
CONFIGS = {"defaults": ROOT / "configs" / "lunar.toml", "thesis": ROOT / "configs" / "lunar-thesis.toml"}


def _runs(path: Path, jobs: int) -> verdicts.Runs:
    start = time.perf_counter()
    runs = verdicts.experiment_runs(scenario.load(path), lambda f, items: executors.local(f, items, jobs))
    logging.info("%s: E1-E3 run in %.0f s", path.name, time.perf_counter() - start)
    return runs


def markdown(table) -> str:
    """The verdicts as a Markdown table, then the counts of each verdict per configuration."""
    lines = ["| claim | defaults | numbers (defaults) | lunar-thesis.toml | numbers (lunar-thesis.toml) |",
             "|---|---|---|---|---|"]
    for row in table.itertuples(index=False):
        lines.append(f"| {row.claim} | {row.verdict_defaults} | {row.numbers_defaults.replace('|', '/')} "
                     f"| {row.verdict_thesis} | {row.numbers_thesis.replace('|', '/')} |")
    lines += ["", "| verdict | defaults | lunar-thesis.toml |", "|---|---|---|"]
    for verdict in verdicts.VERDICTS:
        lines.append(f"| {verdict} | {(table['verdict_defaults'] == verdict).sum()} "
                     f"| {(table['verdict_thesis'] == verdict).sum()} |")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--jobs", type=int, default=2, help="processes (default 2)")
    parser.add_argument("--out", type=Path, default=ROOT / "results" / "lunar-verdicts")
    args = parser.parse_args()
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    table = verdicts.verdict_table(*(_runs(path, args.jobs) for path in CONFIGS.values()))
    args.out.mkdir(parents=True, exist_ok=True)
    write_atomic(args.out / "verdicts.parquet",
                 lambda tmp: pq.write_table(stamp(pa.Table.from_pandas(table, preserve_index=False)), tmp))
    print(markdown(table))


if __name__ == "__main__":
    main()
