"""The UAV delivery scenario behind the :mod:`dronefleet.scenarios` contract.

A thin adaptor over the delivery modules (this subpackage, the schema in
:mod:`dronefleet.delivery.config`, the summary in :mod:`dronefleet.cli`): it adds no behaviour
and changes no output byte. The schema is :data:`dronefleet.delivery.config.PARAMETERS` (units in
each doc), validation :func:`dronefleet.delivery.config.load_config`, the tables those of
:mod:`dronefleet.delivery.records`. ``dronefleet run`` keeps its own delivery path for
what only delivery has (fleet files, the progress bar in weeks); it prints and writes
exactly what this module does.
"""

import re

from .config import PARAMETERS, AnyText, Interval, Options, default_config, load_config
from ..scenarios import Field

__all__ = ["NAME", "SCHEMA", "DEFAULTS", "TABLES", "FIGURES", "load", "read_config", "simulate",
           "format_summary", "describe", "label"]

NAME = "delivery"
TABLES = ("orders", "attempts", "fleet", "timeseries", "summary")  # = dronefleet.delivery.records.TABLES
FIGURES = ("fig16", "fig17", "fig18", "fig19", "fig20")


def _allowed(constraint):
    if isinstance(constraint, Interval):
        return str(constraint)
    if isinstance(constraint, Options):
        return " | ".join(map(repr, constraint.values))
    if isinstance(constraint, AnyText):
        return "any text"
    return "a registered winner rule"  # RegisteredRule: listed by dronefleet.delivery.auction.RULES


def _field(p):
    unit = re.search(r"\[([^\]]+)\]", p.doc)
    return Field(p.section, unit[1] if unit else "-", _allowed(p.constraint), p.doc)


SCHEMA = {name: _field(p) for name, p in PARAMETERS.items()}
DEFAULTS = {name: getattr(default_config(), name) for name in PARAMETERS}


def load(path=None, overrides=(), seed=None):
    """:func:`dronefleet.delivery.config.load_config`: the one validation entry point of delivery."""
    return load_config(path, overrides, seed)


def read_config(path):
    from .records import read_config as read

    return read(path)


def simulate(config):
    """One run of ``config`` (its fleet file, if any, loaded first) -> its tables
    (:mod:`dronefleet.delivery.records`)."""
    from .fleet import load_fleet
    from .records import tables
    from .simulation import simulate as run

    fleet = load_fleet(config.fleet_file, config) if config.fleet_file else None
    return tables(run(config, fleet=fleet))


def format_summary(tables):
    """The run's metrics as ``dronefleet run`` prints them, from its summary table."""
    from ..cli import format_summary as lines

    return lines(tables["summary"].to_pylist()[0])


def describe(config):
    return (f"seed {config.seed}, rule {config.rule}, tau {config.tau_minutes:g} min, "
            f"{config.n_uavs} UAVs, {config.horizon_weeks:g} weeks")


def label(config):
    return f"seed{config.seed}"
