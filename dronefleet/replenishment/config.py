"""The replenishment scenario's configuration: its keys, defaults and validation (one place).

:data:`SCHEMA` declares each key's section, unit, allowed values and meaning; :data:`DEFAULTS`
its default; :func:`load` reads a config file and ``--set`` overrides into a :class:`Config`,
refusing bad input in one line; :func:`replace`, :func:`config_from_dict` and
:func:`read_config` make one from other sources, as strictly. :mod:`.scenario` exposes them
through the scenario contract (docs/scenario-contract.md); the study and the replay page use
them from here, below the contract's adaptor, so that neither imports it.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, fields
from typing import Any

from ..config import SCENARIO_KEY, ConfigError, Sections, _show, _suggest, seed_refusal, with_sources
from ..console import counted
from ..contract import Field
from .params import BASE_CAPACITY, UPPER_LIMITS, Params
from .simulate import TRIAL_SEED_FACTOR

__all__ = ["NAME", "SCHEMA", "SECTIONS", "DEFAULTS", "MAX_FIRST_TRIAL", "NO_SEED", "Config", "load", "resolve_key",
           "replace", "value", "replicates", "config_from_dict", "read_config", "describe", "label"]

NAME = "replenishment"

#: Largest first trial index: seeds 876 k stay far inside int64.
MAX_FIRST_TRIAL = 10**15


def _most(name: str) -> str:
    """The upper limit of ``name`` as the schema shows it: 1e6, 1000."""
    most = UPPER_LIMITS[name][0]
    return f"{most:.0e}".replace("e+0", "e") if most >= 1e4 else f"{most:g}"


SCHEMA: dict[str, Field] = {
    "trials": Field("run", "trials", f"[1, {_most('trials')}]", "trials of the configuration, advanced together"),
    "first_trial": Field("run", "index", f"[1, {MAX_FIRST_TRIAL:.0e}]",
                         f"index k of the first trial; trial k uses seed {TRIAL_SEED_FACTOR} k"),
    "ticks": Field("run", "ticks of 0.1 s", f"[1, {_most('ticks')}]", "T, length of a trial"),
    "sample_every": Field("run", "ticks", f"[1, {_most('sample_every')}]", "sampling period of the time series"),
    "strategy": Field("robots", "-", '"fixed" | "mobile"',
                      "fixed: workers charge in the base; mobile: chargers bring energy to the transfer area"),
    "n_workers": Field("robots", "robots", f">= 1, n_workers + n_chargers <= {BASE_CAPACITY}", "workers n_w"),
    "n_chargers": Field("robots", "robots", "0 if fixed, >= 1 if mobile", "mobile chargers n_m"),
    "worker_capacity": Field("robots", "energy units", f"(0, {_most('worker_capacity')}]",
                             "worker battery capacity c_w"),
    "charger_capacity_factor": Field("robots", "fraction of c_w", f"(0, {_most('charger_capacity_factor')}]",
                                     "phi: mobile charger capacity c_m = phi c_w (unused if fixed)"),
    "work_ratio": Field("energy", "-", f"(0, {_most('work_ratio')}]",
                        "r: working costs v_work = 0.1 r energy units per tick"),
    "charge_rate": Field("energy", "-", f"(0, {_most('charge_rate')}]",
                         "k: charging (base and charger to worker) at v_charge = 1.0 k energy units per tick"),
    "transfer_loss": Field("energy", "fraction", "[0, 1)",
                           "lambda: a worker receives (1 - lambda) of what a mobile charger gives"),
}
_SECTIONS = Sections(NAME, SCHEMA)
SECTIONS: dict[str, tuple[str, ...]] = _SECTIONS.keys

DEFAULTS: dict = {**{f.name: f.default for f in fields(Params)},
                  "strategy": "mobile", "n_chargers": 6, "first_trial": 1}
assert set(DEFAULTS) == set(SCHEMA), "every Params field is declared once"


@dataclass(frozen=True)
class Config:
    """One validated configuration: the model's :class:`Params` and the first trial index."""

    params: Params
    first_trial: int = 1

    @property
    def last_trial(self) -> int:
        return self.first_trial + self.params.trials - 1

    def value(self, name: str) -> Any:
        return self.first_trial if name == "first_trial" else getattr(self.params, name)

    def to_dict(self) -> dict:
        """``{"scenario": "replenishment", section: {key: value}}``, as a config file writes it."""
        return {SCENARIO_KEY: NAME, **{section: {key: self.value(key) for key in keys}
                                       for section, keys in SECTIONS.items()}}

    def to_json(self) -> str:
        """Deterministic JSON text of :meth:`to_dict` (sorted keys)."""
        return json.dumps(self.to_dict(), sort_keys=True)


# ---------------------------------------------------------------- loading


def _typed(name, value):
    """``value`` of key ``name`` with the type of its default (strict, as for delivery)."""
    default, q = DEFAULTS[name], f"{SCHEMA[name].section}.{name}"
    if isinstance(default, str):
        if not isinstance(value, str):
            raise ConfigError(f"{q} must be a string, got {type(value).__name__} {_show(value)}", [name])
        if name == "strategy" and value not in ("fixed", "mobile"):
            raise ConfigError(f"{q} = {_show(value)} is not a strategy"
                              f"{_suggest(value, ('fixed', 'mobile'))}. Allowed: 'fixed', 'mobile'", [name])
        return value
    if isinstance(default, int):
        if not isinstance(value, int) or isinstance(value, bool):
            hint = f" (write {int(value)})" if isinstance(value, float) and value.is_integer() else ""
            raise ConfigError(f"{q} must be an integer, got {type(value).__name__} {_show(value)}{hint}", [name])
        if abs(value) >= 2**63:
            raise ConfigError(f"{q} = {_show(value)} is out of range: allowed {SCHEMA[name].allowed} "
                              "(and below 2**63)", [name])
        return value
    if not isinstance(value, (int, float)) or isinstance(value, bool):
        raise ConfigError(f"{q} must be a number, got {type(value).__name__} {_show(value)}", [name])
    try:
        return float(value)
    except OverflowError:  # an int beyond any float: Params.validate refuses inf
        return math.inf


def _build(values, origin):
    """Defaults updated by ``values`` -> Config, validated once; errors say where a value came from."""
    try:
        typed = {name: _typed(name, value) for name, value in values.items()}
        first = typed.pop("first_trial")
        params = Params(**typed).validate()
        if not 1 <= first <= MAX_FIRST_TRIAL:
            raise ConfigError(f"run.first_trial = {first} is out of range: allowed {SCHEMA['first_trial'].allowed}",
                              ["first_trial"])
        return Config(params, first)
    except ConfigError as e:
        raise with_sources(e, origin) from None


resolve_key = _SECTIONS.resolve_key


#: Why a replenishment run takes no seed, and what chooses its trials (the end of :func:`no_seed`'s message).
NO_SEED = (f"trial k draws from its own seed {TRIAL_SEED_FACTOR} k, so the trials are the streams; choose them with "
           "first_trial (from 1) and trials")



def load(path: str | os.PathLike | None = None, overrides: Iterable[str] = (), seed: int | None = None) -> Config:
    """Read a replenishment config: defaults < file < ``overrides`` (``"key=value"``, in order).

    Raises
    ------
    ConfigError
        For any problem, before any work: the file (unreadable, not TOML, unknown
        section or key), a malformed ``--set``, a wrong type, a value out of range
        or a run too large (:meth:`Params.validate`), or a ``seed`` (trials have
        their own seeds: choose them with ``first_trial`` and ``trials``).
    """
    if seed is not None:
        raise seed_refusal("--seed", NAME, NO_SEED)
    values, origin = _SECTIONS.read(DEFAULTS, path, overrides)
    return _build(values, origin)


def value(config: Config, name: str) -> Any:
    return config.value(name)


def replace(config: Config, changes: Mapping[str, Any]) -> Config:
    """A validated copy of ``config`` with ``changes`` (``{key: value}``) applied, typed as in :func:`load`."""
    return _build(_SECTIONS.changed({name: config.value(name) for name in SCHEMA}, changes), {})


def replicates(config: Config) -> range:
    """The trials a run of ``config`` holds."""
    return range(config.first_trial, config.last_trial + 1)


def config_from_dict(document: Mapping[str, Any]) -> Config:
    """:meth:`Config.to_dict`'s form (any subset of keys) -> Config."""
    return _build({**DEFAULTS, **_SECTIONS.flatten(document)}, {})


def read_config(path: str | os.PathLike) -> Config:
    """The config embedded in a replenishment parquet file; DataError naming the file if it holds
    no valid config."""
    from ..records import read_config as read

    return read(path, config_from_dict)


def describe(config: Config) -> str:
    """One line naming the configuration (the head of ``run`` and ``bounds``)."""
    p = config.params
    chargers = (f"{counted(p.n_chargers, 'mobile charger')} (phi {p.charger_capacity_factor:g})" if p.mobile
                else "fixed chargers")
    first, last = config.first_trial, config.last_trial
    trials = (f"trial {first} (seed {TRIAL_SEED_FACTOR * first})" if first == last else
              f"trials {first}-{last} (trial k: seed {TRIAL_SEED_FACTOR} k)")
    return (f"{counted(p.n_workers, 'worker')}, {chargers}, r {p.work_ratio:g}, k {p.charge_rate:g}, "
            f"lambda {p.transfer_loss:g}, {trials} x {counted(p.ticks, 'tick')}")


def label(config: Config) -> str:
    """Short tag of the run's default folder: its trials."""
    return f"trials{config.first_trial}-{config.last_trial}"
