"""The UAV delivery scenario behind the :mod:`dronefleet.scenarios` contract.

A thin adaptor over the delivery modules (this subpackage, the schema in
:mod:`dronefleet.delivery.config`; the printed summary, :func:`format_metrics`, is here): it adds no
behaviour and changes no output byte. The schema is :data:`dronefleet.delivery.config.PARAMETERS` (units in
each doc), validation :func:`dronefleet.delivery.config.load_config`, the tables those of
:mod:`dronefleet.delivery.records`. ``dronefleet run`` keeps its own delivery path for
what only delivery has (fleet files, the progress bar in weeks); it prints and writes
exactly what this module does.
"""

from __future__ import annotations

import os
import re
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..console import counted
from ..contract import Field
from .config import (PARAMETERS, AnyText, Config, Interval, Options, default_config, describe, load_config,
                     resolve_key)
from .config import replace as replace_fields

if TYPE_CHECKING:
    import pyarrow

__all__ = ["NAME", "SCHEMA", "DEFAULTS", "TABLES", "FIGURES", "SEED_KEY", "SEEDS_REQUIRED", "load", "resolve_key",
           "replace", "value", "read_config", "table_schemas", "columns", "simulate", "outdated", "format_summary",
           "format_metrics", "describe", "label", "replay_data", "check_replayable"]

NAME = "delivery"
TABLES = ("orders", "attempts", "fleet", "timeseries", "summary")  # = dronefleet.delivery.records.TABLES
FIGURES = ("fig16", "fig17", "fig18", "fig19", "fig20")
#: A run is one replicate, named by its seed: a sweep lists its seeds (a sweep without them is
#: a forgotten line, not a wish for seed 0 alone).
SEED_KEY = "seed"
SEEDS_REQUIRED = True


def _allowed(constraint):
    if isinstance(constraint, Interval):
        return str(constraint)
    if isinstance(constraint, Options):
        return " | ".join(map(repr, constraint.values))
    if isinstance(constraint, AnyText):
        return "any text"
    # RegisteredRule: dronefleet.delivery.auction.RULES, and (not for base_rule) plugins
    return "a registered winner rule" if constraint.base else "a registered winner rule or a plugin rule"


def _field(p):
    unit = re.search(r"\[([^\]]+)\]", p.doc)
    return Field(p.section, unit[1] if unit else "-", _allowed(p.constraint), p.doc)


SCHEMA = {name: _field(p) for name, p in PARAMETERS.items()}
DEFAULTS = {name: getattr(default_config(), name) for name in PARAMETERS}


def load(path: str | os.PathLike | None = None, overrides: Iterable[str] = (), seed: int | None = None) -> Config:
    """:func:`dronefleet.delivery.config.load_config`: the one validation entry point of delivery."""
    return load_config(path, overrides, seed)


def replace(config: Config, changes: Mapping[str, Any]) -> Config:
    """:func:`dronefleet.delivery.config.replace`: a validated copy with ``changes`` applied."""
    return replace_fields(config, **changes)


def value(config: Config, name: str) -> Any:
    return getattr(config, name)


def read_config(path: str | os.PathLike) -> Config:
    from .records import read_config as read

    return read(path)


def table_schemas() -> dict[str, pyarrow.Schema]:
    from .records import SCHEMAS

    return SCHEMAS


def columns() -> dict:
    from .records import COLUMNS

    return COLUMNS


def simulate(config: Config) -> dict[str, pyarrow.Table]:
    """One run of ``config`` -> its tables (:mod:`dronefleet.delivery.records`); the simulation
    loads the run's fleet file, if any."""
    from .records import tables
    from .simulation import simulate as run

    return tables(run(config))


def outdated(config: Config, summary: Path) -> bool:
    """True if the run starts from a saved fleet (``fleet_file``, ``{seed}`` replaced) written
    after the run's ``summary``: the fleet was written again since (the sweep that made it
    rerun after a fix, say), so the run's results come from a fleet that is gone, and a rerun
    replaces them rather than leave old and new fleets mixed in one sweep. A fleet file that
    no longer exists leaves the run as it is: nothing says it is stale."""
    from .fleet import seeded_path

    if not config.fleet_file:
        return False
    fleet = seeded_path(config.fleet_file, config.seed)
    return fleet.exists() and fleet.stat().st_mtime_ns > summary.stat().st_mtime_ns


def _duration(seconds):
    if seconds != seconds:  # nan
        return "n/a"
    hours, rest = divmod(seconds, 3600.0)
    return f"{int(hours)} h {rest / 60.0:04.1f} min"


def _backlog(age_s: float, pending: int) -> str:
    """The cumulative backlog age (the study's metric: the ages of the pending orders at the horizon,
    summed) in days, and their mean age."""
    if not pending:
        return "0.0 days (no order pending)"
    return (f"{age_s / 86400.0:,.1f} days over {counted(pending, 'pending order')}, "
            f"{age_s / 86400.0 / pending:.1f} days each on average")


def format_metrics(m: dict, wall_s: float | None = None) -> str:
    """The run's summary as printed by ``dronefleet run`` (``m`` from :func:`~dronefleet.delivery.metrics.run_metrics`;
    the wall time line only if ``wall_s`` is given)."""
    delivered_pct = 100.0 * m["delivered"] / m["orders_arrived"] if m["orders_arrived"] else float("nan")
    lines = [
        ("orders arrived", f"{m['orders_arrived']}"),
        ("delivered", f"{m['delivered']} ({delivered_pct:.1f} %)"),
        ("median delivery time", f"{_duration(m['median_delivery_time_s'])} ({m['median_delivery_time_s']:.0f} s)"),
        ("aborted attempts", f"{m['aborted_pct']:.1f} % ({m['aborted_attempts']} of {m['attempts']})"),
        ("backlog age (summed)", _backlog(m['backlog_age_s'], m['pending'])),
        ("lost UAVs", f"{m['lost_uavs']}"),
        ("decision accuracy", f"{100.0 * m['decision_accuracy']:.1f} % (fleet mean at the end)"),
    ]
    if m["reservations_won"]:
        lines.append(("reservations won", f"{m['reservations_won']}, median wait "
                      f"{_duration(m['median_reservation_wait_s'])}, forecast met {m['forecast_met_pct']:.1f} %"))
    if wall_s is not None:
        lines.append(("wall time", f"{wall_s:.2f} s"))
    return "\n".join(f"  {label:<22}{value}" for label, value in lines)


def format_summary(tables: Mapping[str, pyarrow.Table]) -> str:
    """The run's metrics as ``dronefleet run`` prints them, from its summary table."""
    return format_metrics(tables["summary"].to_pylist()[0])


def label(config: Config) -> str:
    return f"seed{config.seed}"


def replay_data(run_dir: Path) -> dict[str, Any]:
    """The replay page's data of a run folder: :func:`dronefleet.delivery.replay.replay_data`."""
    from .replay import replay_data as data

    return data(run_dir)


def check_replayable(config: Config) -> None:
    """Refuse ``run --replay`` of a run whose page would be too large (:mod:`dronefleet.delivery.replay`)."""
    from .replay import check_replayable as check

    check(config)
