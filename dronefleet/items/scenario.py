"""The item-delivery / foraging scenario behind the :mod:`dronefleet.scenarios` contract.

Config files are TOML naming the scenario and grouping keys in five sections (run, world,
generation, robots, options; ``configs/items.toml`` spells out and documents every key)::

    scenario = "items"
    [run]
    trials = 20
    [world]
    mode = "foraging"
    [robots]
    algorithm = "GR"

:data:`SCHEMA` declares each key's section, unit, allowed values and meaning, :data:`DEFAULTS` its
default (from :data:`dronefleet.items.params.KEYS`). Types are strict as for the other scenarios
(``bool`` is not an ``int``, ``7.0`` is not an ``int``, an ``int`` is taken for a float); every
value and rule is checked in :meth:`dronefleet.items.params.Params.validate`. ``--set key=value``
takes ``section.key`` or the bare key; ``--seed`` sets ``run.seed``.

A run holds its trials ``first_trial .. first_trial + trials - 1``; ``seed`` is the root seed,
what ``--seed``, ``dronefleet.run(seed=...)`` and a sweep's ``seeds`` set. Trial k of root seed s
draws every stream from s * 2**32 + k, so the same trial index pairs runs across algorithms and
(n, c, s) cells.

Tables (:func:`simulate`): ``summary``, one row per trial (the columns of
:func:`dronefleet.items.simulate.summary_columns`); ``robots``, one row per trial and robot
(``trial``, ``robot``, ``trips``, ``visits``, ``items``). Both carry the config in their metadata.
"""

from __future__ import annotations

import json
import os
from collections.abc import Iterable, Mapping
from dataclasses import fields
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..config import SCENARIO_KEY, ConfigError, Sections, with_sources
from ..console import counted
from ..contract import Column, Field
from .params import KEYS, Params, allowed, check
from .simulate import robot_columns, summary_columns

if TYPE_CHECKING:
    import pyarrow

__all__ = ["NAME", "SCHEMA", "DEFAULTS", "TABLES", "FIGURES", "SEED_KEY", "SEEDS_REQUIRED", "REPLICATE_NOUN", "load",
           "resolve_key", "replace", "value", "replicates", "config_from_dict", "read_config", "table_schemas",
           "columns", "simulate", "format_summary", "describe", "label", "replay_data", "check_replayable", "study"]

NAME = "items"
TABLES = ("summary", "robots")
#: The study's figures in ``dronefleet reproduce`` (:mod:`dronefleet.items.study`).
FIGURES: tuple[str, ...] = (*(f"items-fig{k:02d}" for k in range(1, 13)), "items-ttests", "items-verdicts")
SEED_KEY = "seed"
SEEDS_REQUIRED = False
REPLICATE_NOUN = "trial"

SCHEMA: dict[str, Field] = {name: Field(key.section, key.unit, allowed(name), key.doc) for name, key in KEYS.items()}
DEFAULTS: dict = {name: key.default for name, key in KEYS.items()}
_SECTIONS = Sections(NAME, SCHEMA)
SECTIONS: dict[str, tuple[str, ...]] = _SECTIONS.keys


def _to_dict(params: Params) -> dict:
    return {SCENARIO_KEY: NAME, **{section: {key: getattr(params, key) for key in keys}
                                   for section, keys in SECTIONS.items()}}


class Config(Params):
    """A validated configuration: :class:`Params` with the contract's JSON forms."""

    def value(self, name: str) -> Any:
        return getattr(self, name)

    def to_dict(self) -> dict:
        """``{"scenario": "items", section: {key: value}}``, as a config file writes it."""
        return _to_dict(self)

    def to_json(self) -> str:
        """Deterministic JSON text of :meth:`to_dict` (sorted keys)."""
        return json.dumps(self.to_dict(), sort_keys=True)


def _build(values: Mapping[str, Any], origin: Mapping[str, str]) -> Config:
    """Defaults updated by ``values`` -> Config, validated once; errors say where a value came from."""
    try:
        return Config(**{name: check(name, v) for name, v in values.items()}).validate()
    except ConfigError as e:
        raise with_sources(e, origin) from None


resolve_key = _SECTIONS.resolve_key


def load(path: str | os.PathLike | None = None, overrides: Iterable[str] = (), seed: int | None = None) -> Config:
    """Read an items config: defaults < file < ``overrides`` (``"key=value"``, in order) < ``seed``.

    Raises
    ------
    ConfigError
        For any problem, before any work: the file (unreadable, not TOML, unknown section or
        key), a malformed ``--set``, a wrong type, a value out of range, a combination the
        model does not define or a run too large (:meth:`Params.validate`).
    """
    return _build(*_SECTIONS.read(DEFAULTS, path, overrides, seed))


def value(config: Config, name: str) -> Any:
    return config.value(name)


def replace(config: Config, changes: Mapping[str, Any]) -> Config:
    """A validated copy of ``config`` with ``changes`` (``{key: value}``) applied, typed as in :func:`load`."""
    return _build(_SECTIONS.changed({f.name: getattr(config, f.name) for f in fields(config)}, changes), {})


def replicates(config: Config) -> range:
    """The trials a run of ``config`` holds."""
    return range(config.first_trial, config.first_trial + config.trials)


def config_from_dict(document: Mapping[str, Any]) -> Config:
    """:meth:`Config.to_dict`'s form (any subset of keys) -> Config."""
    return _build({**DEFAULTS, **_SECTIONS.flatten(document)}, {})


def read_config(path: str | os.PathLike) -> Config:
    """The config embedded in an items parquet file; DataError naming the file if it holds no valid config."""
    from ..records import read_config as read

    return read(path, config_from_dict)


# ---------------------------------------------------------------- running

_FLOATS = {"rate", "items_per_trip"}


def table_schemas() -> dict[str, pyarrow.Schema]:
    """Columns and types of the tables :func:`simulate` writes (int64 counts, float64 rates)."""
    import pyarrow as pa

    return {table: pa.schema([(name, pa.float64() if name in _FLOATS else pa.int64()) for name in names])
            for table, names in (("summary", summary_columns()), ("robots", robot_columns()))}


_TRIAL = Column("index", "the trial; trial k of root seed s draws its streams from s x 2^32 + k")
#: What every column of :func:`table_schemas` holds, with its unit (the documentation site's table pages).
COLUMNS = {
    "summary": {
        "trial": _TRIAL,
        "seed": Column("", "the trial's own seed, root seed x 2^32 + trial"),
        "generated": Column("items", "items (foraging) or demands (delivery) that appeared during the trial; "
                                     "logistic foraging: the stock's net growth"),
        "served": Column("items", "foraging: items brought home (or picked up, with count_at = \"pickup\"); "
                                  "delivery: demands satisfied"),
        "rate": Column("% (logistic: items)", "100 served / generated; under logistic foraging, where the stock "
                                              "regrows, the items foraged"),
        "picked": Column("items", "items taken at locations (foraging) or handed out (delivery)"),
        "visits": Column("count", "arrivals of robots at locations"),
        "trips": Column("count", "arrivals of robots at home"),
        "items_per_trip": Column("items", "served / trips; NaN without a trip"),
    },
    "robots": {
        "trial": _TRIAL,
        "robot": Column("index", "the robot, from 0"),
        "trips": Column("count", "its arrivals at home"),
        "visits": Column("count", "its arrivals at locations"),
        "items": Column("items", "its share of served"),
    },
}


def columns() -> dict[str, dict[str, Column]]:
    return COLUMNS


def simulate(config: Config) -> dict[str, pyarrow.Table]:
    """Every trial of ``config`` in one kernel call -> ``{"summary", "robots"}`` pyarrow tables."""
    from ..records import CONFIG_KEY, arrow_table
    from .simulate import simulate as run

    columns = run(config)
    metadata = {CONFIG_KEY: config.to_json()}
    return {name: arrow_table({c: columns[name][c] for c in schema.names}, metadata)
            for name, schema in table_schemas().items()}


def describe(config: Config) -> str:
    """One line naming the configuration (the head of ``run``)."""
    p = config
    world = (counted(p.locations, "random location") if p.foraging
             else f"{counted(p.n_locations, 'grid location')} (N_s {p.grid_spacing:g}, {p.grid_edge})")
    return (f"{p.mode} ({p.truth}), {world}, {p.algorithm}: {counted(p.n_robots, 'robot')}, capacity {p.capacity}, "
            f"speed {p.speed:g}; {_trials(p.first_trial, p.trials)} (root seed {p.seed}) x {counted(p.steps, 'step')}")


def _trials(first: int, trials: int) -> str:
    """``trial 3`` or ``trials 1-20``."""
    return f"trial {first}" if trials == 1 else f"trials {first}-{first + trials - 1}"


def label(config: Config) -> str:
    """Short tag of the run's default folder."""
    return f"{config.algorithm}-n{config.n_robots}-c{config.capacity}-trials{config.first_trial}-" \
           f"{config.first_trial + config.trials - 1}"


def format_summary(tables: Mapping[str, pyarrow.Table]) -> str:
    """Mean, sd and min-max over the trials of each per-trial metric."""
    from ..records import CONFIG_KEY

    summary = tables["summary"]
    config = config_from_dict(json.loads(summary.schema.metadata[CONFIG_KEY]))
    served = ("foraged F [items]" if config.foraging else "served S [demands]")
    rate = ("foraging rate F [items]" if config.truth == "logistic" else
            "foraging rate [% of G]" if config.foraging else "serving rate [% of G]")
    rows = (("generated G", "generated", ",.1f"), (served, "served", ",.1f"), (rate, "rate", ",.2f"),
            ("visits", "visits", ",.1f"), ("trips", "trips", ",.1f"), ("items per trip", "items_per_trip", ".3f"))
    lines = [f"  {'over ' + counted(summary.num_rows, 'trial'):<26}{'mean':>11}{'sd':>10}{'min':>11}{'max':>11}"]
    for text, column, fmt in rows:
        x = np.array(summary.column(column).to_pylist(), dtype=np.float64)
        x = x[~np.isnan(x)]
        if x.size == 0:
            lines.append(f"  {text:<26}{'-':>11}")
            continue
        sd = f"{x.std(ddof=1):{fmt}}" if x.size > 1 else "-"
        lines.append(f"  {text:<26}{x.mean():>11{fmt}}{sd:>10}{x.min():>11{fmt}}{x.max():>11{fmt}}")
    return "\n".join(lines)


def replay_data(run_dir: Path, trial: int | None = None) -> dict[str, Any]:
    """The replay page's data of a run folder (its config read from ``summary.parquet``), of its
    trial ``trial`` (None: its first): :func:`dronefleet.items.replay.replay_data`."""
    from ..records import chosen_trial
    from .replay import replay_data as data

    config = read_config(run_dir / "summary.parquet")
    return data(run_dir, config, describe(config), chosen_trial(run_dir, replicates(config), trial))


def check_replayable(config: Config) -> None:
    """Refuse ``run --replay`` of a run whose page would be too large (:mod:`dronefleet.items.replay`)."""
    from .replay import check_replayable as check

    check(config)


def study() -> Any:
    """Figs 1-12 and the t-tests in ``dronefleet reproduce``: :mod:`dronefleet.items.study`."""
    from . import study as figures

    return figures
