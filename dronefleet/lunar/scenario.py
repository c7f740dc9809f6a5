"""The lunar foraging-with-recharging scenario behind the :mod:`dronefleet.scenarios` contract.

Config files are TOML naming the scenario and grouping keys in seven sections (run, world,
robots, guidance, energy, records, options; ``configs/lunar.toml`` spells out and documents
every key)::

    scenario = "lunar"
    [run]
    runs = 50
    [world]
    layout = "HARD-RT"
    [energy]
    battery_wh = 7.5

:data:`KEYS` (:mod:`dronefleet.lunar.keys`) declares each key's section, unit, kind, range and
meaning (the spec's A-number for the options of its section 17); the defaults are
:class:`dronefleet.lunar.params.LunarParams`'s fields (one source). Types are strict as for the
other scenarios (``bool`` is not an ``int`` and ``"true"`` is not a ``bool``, ``7.0`` is not an
``int``, an ``int`` is taken for a float); every value, every rule between values and the size of
the run (:data:`RUN_LIMITS`) are checked (:func:`dronefleet.lunar.keys.checked`) once, when a
config is built (:func:`load`, :func:`replace`, :func:`config_from_dict`): the kernel never
re-checks. ``--set key=value`` takes ``section.key`` or the bare key; ``--seed`` sets
``run.seed``.

A run holds all its runs ``first_run .. first_run + runs - 1`` (one kernel call); ``seed`` is the
root seed, what ``--seed``, ``dronefleet.run(seed=...)`` and a sweep's ``seeds`` set. Run j of every
layout and capacity draws the same per-robot streams (common random numbers).

Tables (:func:`simulate`, columns in :func:`table_schemas`): ``summary`` (one row per run),
``timeseries`` (one row per run and update interval), ``trips`` (one row per trip record),
``snapshots`` (network snapshots), ``robots`` (one row per run and robot: its totals), ``deaths``
(one row per death), ``recharge_triggers`` (one row per row-2 firing) and ``beacon_costs`` (per
snapshot, the stored costs of the beacons near T and R), as docs/guide/lunar.md lists them. Each
carries the config in its metadata.
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
from ..contract import Field
from .keys import KEYS, RUN_LIMITS, _allowed, checked, run_size
from .params import LunarParams

if TYPE_CHECKING:
    import pyarrow

__all__ = ["NAME", "KEYS", "SCHEMA", "DEFAULTS", "TABLES", "FIGURES", "SEED_KEY", "SEEDS_REQUIRED", "REPLICATE_NOUN",
           "RUN_LIMITS", "Config", "load", "resolve_key", "replace", "value", "replicates", "config_from_dict",
           "read_config", "run_size", "table_schemas", "columns", "simulate", "format_summary", "describe", "label",
           "replay_data", "check_replayable", "study"]

NAME = "lunar"
TABLES = ("summary", "timeseries", "trips", "snapshots", "robots", "deaths", "recharge_triggers", "beacon_costs")
#: The study's figures in ``dronefleet reproduce`` (:mod:`dronefleet.lunar.study`).
FIGURES: tuple[str, ...] = (*(f"lunar-fig{k:02d}" for k in (3, 4, 5, 6, 7, 8, 9, 11)), "lunar-control", "lunar-e4",
                            "lunar-e5", "lunar-verdicts")
SEED_KEY = "seed"
SEEDS_REQUIRED = False
REPLICATE_NOUN = "run"

SCHEMA: dict[str, Field] = {name: Field(key.section, key.unit, _allowed(key), key.doc) for name, key in KEYS.items()}
DEFAULTS: dict = {f.name: f.default for f in fields(LunarParams)}
_SECTIONS = Sections(NAME, SCHEMA)
SECTIONS: dict[str, tuple[str, ...]] = _SECTIONS.keys


class Config(LunarParams):
    """A validated configuration: :class:`LunarParams` with the contract's JSON forms."""

    def value(self, name: str) -> Any:
        return getattr(self, name)

    def to_dict(self) -> dict:
        """``{"scenario": "lunar", section: {key: value}}``, as a config file writes it."""
        return {SCENARIO_KEY: NAME, **{section: {key: getattr(self, key) for key in keys}
                                       for section, keys in SECTIONS.items()}}

    def to_json(self) -> str:
        """Deterministic JSON text of :meth:`to_dict` (sorted keys)."""
        return json.dumps(self.to_dict(), sort_keys=True)


def _build(values: Mapping[str, Any], origin: Mapping[str, str]) -> Config:
    """Defaults updated by ``values`` -> Config, validated once; errors say where a value came from."""
    try:
        config = checked(values, Config)
    except ConfigError as e:
        raise with_sources(e, origin) from None
    return config


resolve_key = _SECTIONS.resolve_key


def load(path: str | os.PathLike | None = None, overrides: Iterable[str] = (), seed: int | None = None) -> Config:
    """Read a lunar config: defaults < file < ``overrides`` (``"key=value"``, in order) < ``seed``.

    Raises
    ------
    ConfigError
        For any problem, before any work: the file (unreadable, not TOML, unknown section or
        key), a malformed ``--set``, a wrong type, a value out of range, a combination the model
        does not define or a run too large (:data:`RUN_LIMITS`).
    """
    return _build(*_SECTIONS.read(DEFAULTS, path, overrides, seed))


def value(config: Config, name: str) -> Any:
    return config.value(name)


def replace(config: Config, changes: Mapping[str, Any]) -> Config:
    """A validated copy of ``config`` with ``changes`` (``{key: value}``) applied, typed as in :func:`load`."""
    return _build(_SECTIONS.changed({name: getattr(config, name) for name in SCHEMA}, changes), {})


def replicates(config: Config) -> range:
    """The runs a run of ``config`` holds."""
    return range(config.first_run, config.first_run + config.runs)


def config_from_dict(document: Mapping[str, Any]) -> Config:
    """:meth:`Config.to_dict`'s form (any subset of keys) -> Config."""
    return _build({**DEFAULTS, **_SECTIONS.flatten(document)}, {})


def read_config(path: str | os.PathLike) -> Config:
    """The config embedded in a lunar parquet file; DataError naming the file if it holds no valid config."""
    from ..records import read_config as read

    return read(path, config_from_dict)


# ---------------------------------------------------------------- running


def table_schemas() -> dict[str, pyarrow.Schema]:
    """Columns and types of the tables :func:`simulate` writes (:mod:`dronefleet.lunar.simulate`)."""
    from .simulate import table_schemas as schemas

    return schemas()


def columns() -> dict:
    """What every column of the tables holds (:data:`dronefleet.lunar.columns.COLUMNS`)."""
    from .columns import COLUMNS

    return COLUMNS


def simulate(config: Config) -> dict[str, pyarrow.Table]:
    """Every run of ``config`` in one kernel call -> ``{table: pyarrow.Table}`` of :data:`TABLES`,
    each carrying the config in its metadata."""
    from ..records import CONFIG_KEY
    from .simulate import simulate as run

    tables = run(config)
    metadata = {CONFIG_KEY: config.to_json()}
    return {name: tables[name].replace_schema_metadata(metadata) for name in TABLES}


def _options(config: Config) -> str:
    """The section-17 options that differ from the defaults, ``", options: avoidance=turn"``; or ''."""
    changed = [f"{name}={getattr(config, name)}".lower() for name in SECTIONS["options"]
               if getattr(config, name) != DEFAULTS[name]]
    return f", options: {' '.join(changed)}" if changed else ""


def describe(config: Config) -> str:
    """One line naming the configuration (the head of ``run``)."""
    p = config
    runs = f"run {p.first_run}" if p.runs == 1 else f"runs {p.first_run}-{p.first_run + p.runs - 1}"
    return (f"{p.layout} (scale {p.layout_scale:g}), {counted(p.n_robots, 'robot')}, {p.battery_wh:g} Wh, "
            f"v0 {p.v0:g} m/s, eps {p.eps:g}{_options(p)}; {runs} (root seed {p.seed}) x {p.duration_s:g} s "
            f"({p.ticks:,} ticks)")


def label(config: Config) -> str:
    """Short tag of the run's default folder."""
    return f"{config.layout}-n{config.n_robots}-{config.battery_wh:g}Wh-runs{config.first_run}-" \
           f"{config.first_run + config.runs - 1}"


_SUMMARY_ROWS = (("resources returned [units]", "resources", ",.1f"), ("trips (unloads)", "trips", ",.1f"),
                 ("recharging interruptions", "interruptions", ",.1f"), ("charging sessions", "sessions", ",.1f"),
                 ("deaths [robots]", "deaths", ",.2f"), ("beacons at the end [robots]", "beacons", ",.1f"),
                 ("alignment T [cosine]", "alignment_T", ".3f"), ("alignment N [cosine]", "alignment_N", ".3f"),
                 ("alignment R [cosine]", "alignment_R", ".3f"))


def format_summary(tables: Mapping[str, pyarrow.Table]) -> str:
    """Mean, sd and min-max over the runs of each per-run metric (a run without a value, an
    alignment with no beacon holding a vector, is left out and counted)."""
    summary = tables["summary"]
    lines = [f"  {'over ' + counted(summary.num_rows, 'run'):<28}{'mean':>11}{'sd':>10}{'min':>11}{'max':>11}"]
    for text, column, fmt in _SUMMARY_ROWS:
        x = np.array(summary.column(column).to_pylist(), dtype=np.float64)  # to_numpy imports pandas
        x = x[~np.isnan(x)]
        missing = summary.num_rows - x.size
        note = f"   ({counted(missing, 'run')} without a value)" if missing else ""
        if x.size == 0:
            lines.append(f"  {text:<28}{'-':>11}{note}")
            continue
        sd = f"{x.std(ddof=1):{fmt}}" if x.size > 1 else "-"
        lines.append(f"  {text:<28}{x.mean():>11{fmt}}{sd:>10}{x.min():>11{fmt}}{x.max():>11{fmt}}{note}")
    return "\n".join(lines)


def replay_data(run_dir: Path, trial: int | None = None) -> dict[str, Any]:
    """The replay page's data of a run folder (its config read from ``summary.parquet``), of its
    run ``trial`` (None: its first): :func:`dronefleet.lunar.replay.replay_data`."""
    from .replay import chosen_run
    from .replay import replay_data as data

    config = read_config(run_dir / "summary.parquet")
    return data(run_dir, config, describe(config), chosen_run(run_dir, config, trial))


def check_replayable(config: Config) -> None:
    """Refuse ``run --replay`` of a run whose page would be too large (:mod:`dronefleet.lunar.replay`)."""
    from .replay import check_replayable as check

    check(config)


def study() -> Any:
    """Figs 6-3 to 6-11, the eps = 1 control, E4, E5 and the claims' verdicts in ``dronefleet reproduce``:
    :mod:`dronefleet.lunar.study`."""
    from . import study as figures

    return figures
