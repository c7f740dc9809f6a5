"""The delivery scenario's configuration: every parameter of the model, declared once, validated once.

Each parameter is one field of the frozen dataclass :class:`Config`, declared
with its TOML section, type, default (the ``docs/delivery-model.md`` value), allowed range and
a one-line doc with units (``PARAMETERS[name]`` holds that declaration). Rules
that involve several parameters are all in :data:`_ORDERED_PAIRS` and
:data:`RUN_LIMITS` (the size of the run: orders, samples, ticks, ...).

Validation happens in exactly one place, :func:`_validate`, run by
``Config.__post_init__``: every ``Config`` that exists is valid, whichever entry
point made it (:func:`default_config`, :func:`load_config`,
:func:`config_from_dict`, :func:`replace`, or ``Config(...)`` itself). Kernels
never re-check parameters.

Config files are TOML, keys grouped in the sections of :data:`SECTIONS`::

    [orders]
    tau_minutes = 20.0      # mean inter-arrival time of orders [min]

Decisions
---------
* A file (or nested dict) may give any subset of the keys; the rest keep their
  defaults. ``configs/paper.toml`` spells out every default.
* Keys must sit in their section. A key at the top level of a file, or in the
  wrong section, is an error whose message names the right section (one
  canonical form, the one :meth:`Config.to_dict` writes).
* Types are strict: ``bool`` is not an ``int``, a float (even ``7.0``) is not an
  ``int``; an ``int`` is accepted for a float and converted. Floats must be
  finite. ``scaler_*`` are lists (or tuples) of exactly 3 numbers.
* Precedence in :func:`load_config`: defaults < file < overrides (in order,
  the last one wins) < ``seed`` argument.
* Whatever drives memory or time is bounded before any work: by a parameter's
  range (``seed`` fits int64, ``n_uavs`` and weeks fit int16 columns, physical
  ranges for masses, distances, energy parameters and the feature scaling, so
  that no power, charging time or feature overflows; ``advert_interval_s >= 1 ms``; periods
  at most the longest horizon, 1000 weeks, so that none is infinite in seconds) or by the
  run's size (:func:`run_size`, limits in :data:`RUN_LIMITS`), whose message
  gives the figure, e.g. "the run would hold ~3.2e+10 orders (horizon 8 weeks /
  tau 1e-09 min); at most 1e+07 allowed".
* A config file must be UTF-8 TOML of at most :data:`dronefleet.config.MAX_CONFIG_BYTES`,
  read by the shared :func:`dronefleet.config.read_toml`; a top-level
  ``scenario = "delivery"`` is allowed (:mod:`dronefleet.scenarios` dispatches on it).
"""

from __future__ import annotations

import contextvars
import dataclasses
import json
import math
from dataclasses import dataclass, field
from os import PathLike
from typing import Any
from collections.abc import Iterable, Mapping

from ..config import SCENARIO_KEY, ConfigError, _name, _show, _suggest, parse_overrides, read_toml
from ..console import counted

__all__ = [
    "SECTIONS",
    "PARAMETERS",
    "Config",
    "RUN_LIMITS",
    "SECONDS_PER_WEEK",
    "config_from_dict",
    "default_config",
    "describe",
    "load_config",
    "replace",
    "resolve_key",
    "run_size",
]

SECONDS_PER_WEEK = 604_800.0
SECONDS_PER_MINUTE = 60.0


# --------------------------------------------------------------------------
# Constraints (cf. scikit-learn's sklearn.utils._param_validation)
# --------------------------------------------------------------------------


def _num(x: float) -> str:
    """A bound as a user would write it: 0, 1, 0.5, 100 (an int bound in full)."""
    return str(x) if isinstance(x, int) else f"{x:g}"


@dataclass(frozen=True)
class Interval:
    """Real interval; ``None`` bound = unbounded; ``closed`` in both/left/right/neither."""

    left: float | None
    right: float | None
    closed: str = "both"

    def __contains__(self, x: float) -> bool:
        if self.left is not None:
            if x < self.left or (x == self.left and self.closed not in ("both", "left")):
                return False
        if self.right is not None:
            if x > self.right or (x == self.right and self.closed not in ("both", "right")):
                return False
        return True

    def __str__(self) -> str:
        lo_closed = self.closed in ("both", "left")
        hi_closed = self.closed in ("both", "right")
        if self.right is None and self.left is None:
            return "any finite number"
        if self.right is None:
            return f"{'>=' if lo_closed else '>'} {_num(self.left)}"
        if self.left is None:
            return f"{'<=' if hi_closed else '<'} {_num(self.right)}"
        return (f"{'[' if lo_closed else '('}{_num(self.left)}, "
                f"{_num(self.right)}{']' if hi_closed else ')'}")


@dataclass(frozen=True)
class Options:
    """One of a fixed set of strings."""

    values: tuple[str, ...]

    def allowed(self) -> tuple[str, ...]:
        return self.values


#: True while a config read back from a file is validated (:func:`config_from_dict` with
#: ``trusted=False``): its rule is checked by name and never imported (files are data).
_FROM_DATA: contextvars.ContextVar[bool] = contextvars.ContextVar("dronefleet_config_from_data", default=False)


class RegisteredRule:
    """One of the winner rules registered in ``dronefleet.delivery.auction.RULES``, or a plugin rule.

    Imported lazily so that ``config`` imports nothing heavy (and no cycle).
    ``base`` restricts it to the built-in rules that can resolve reservation's immediate
    bids; otherwise a plugin (entry point or ``"module:function"``) is allowed too, and
    loaded and checked by :func:`dronefleet.delivery.auction.resolve_rule`, unless the
    config is read from a file: then only its name is checked
    (:func:`dronefleet.delivery.auction.rule_name_problem`).
    """

    def __init__(self, base: bool = False) -> None:
        self.base = base

    def problem(self, value: str) -> str | None:
        """Why ``value`` names no usable rule (the end of a one-line message), or None."""
        from .auction import BASE_RULES, RuleError, resolve_rule, rule_name_problem

        if self.base:
            return None if value in BASE_RULES else (f"is not a rule that bids on its policy"
                                                     f"{_suggest(value, BASE_RULES)}. "
                                                     f"Allowed: {', '.join(map(repr, BASE_RULES))}")
        if _FROM_DATA.get():
            return rule_name_problem(value)
        try:
            resolve_rule(value)
        except RuleError as e:
            return str(e)
        return None


class AnyText:
    """Any string (a file path, say); checked where it is used."""

    def allowed(self) -> None:
        return None

    def __repr__(self) -> str:  # pragma: no cover - cosmetic
        return "RegisteredRule()"


@dataclass(frozen=True)
class Param:
    """Declaration of one parameter: section, type, constraint, doc (with units)."""

    section: str
    type: type            # int, float, str, or tuple (tuple of `length` floats)
    constraint: Any       # Interval (numbers; for tuples: each element), Options, RegisteredRule, AnyText
    doc: str
    length: int = 0       # tuples only
    name: str = ""        # filled in from the field name

    @property
    def qualname(self) -> str:
        return f"{self.section}.{self.name}"


def _p(section, default, type_, constraint, doc, length=0):
    """Declare a Config field: its default plus its Param in the field metadata."""
    return field(default=default,
                 metadata={"param": Param(section, type_, constraint, doc, length)})


_FRACTION = Interval(0, 1, "right")        # (0, 1]
# Physical ranges, wide enough for any delivery UAV, so that no power, time or feature overflows.
_MASS_KG = Interval(0, 1e4)
_DISTANCE_M = Interval(0, 1e7, "right")
#: A period [s] at most the longest horizon (1000 weeks): a longer one acts as never.
_LONGEST_S = 1000 * 604_800.0
_PERIOD_S = Interval(0, _LONGEST_S, "right")


# --------------------------------------------------------------------------
# The configuration
# --------------------------------------------------------------------------


@dataclass(frozen=True)
class Config:
    """All parameters of one run, flat, validated on construction.

    Build one with :func:`default_config`, :func:`load_config`,
    :func:`config_from_dict` or :func:`replace`.
    """

    # [run]
    seed: int = _p("run", 0, int, Interval(0, 2**63 - 1),
                   "master seed from which every random stream is derived (an int64 column)")
    horizon_weeks: float = _p("run", 8.0, float, Interval(0, 1000, "right"),
                              "operating period T [weeks] (weeks are int16 columns)")
    record_interval_s: float = _p("run", 900.0, float, _PERIOD_S,
                                  "sampling period of the recorded time series [s]")
    fleet_file: str = _p("run", "", str, AnyText(),
                         "saved fleet to start from (parquet; '{seed}' is replaced by the seed); "
                         "'' = a new fleet")
    # [orders]
    tau_minutes: float = _p("orders", 15.0, float, Interval(0, _LONGEST_S / 60.0, "right"),
                            "mean inter-arrival time of orders, tau [min]")
    mass_min_kg: float = _p("orders", 0.5, float, _MASS_KG,
                            "lower bound of the uniform parcel mass [kg]")
    mass_max_kg: float = _p("orders", 5.0, float, _MASS_KG,
                            "upper bound of the uniform parcel mass [kg]")
    distance_min_m: float = _p("orders", 1000.0, float, _DISTANCE_M,
                               "lower bound of the delivery distance [m]")
    distance_max_m: float = _p("orders", 6000.0, float, _DISTANCE_M,
                               "upper bound of the delivery distance [m]")
    distance_sampling: str = _p("orders", "uniform", str, Options(("uniform", "annulus")),
                                "'uniform': d ~ U(dmin, dmax); "
                                "'annulus': d = sqrt(U(dmin^2, dmax^2)) (reference code)")
    # [fleet]
    n_uavs: int = _p("fleet", 25, int, Interval(1, 32767), "fleet size S [UAVs] (an int16 column)")
    soh_min: float = _p("fleet", 0.5, float, _FRACTION,
                        "lower bound of the uniform state of health [fraction of capacity]")
    soh_max: float = _p("fleet", 1.0, float, _FRACTION,
                        "upper bound of the uniform state of health [fraction of capacity]")
    # [energy]
    frame_mass_kg: float = _p("energy", 10.0, float, _MASS_KG, "frame mass m_f [kg]")
    battery_mass_kg: float = _p("energy", 10.0, float, _MASS_KG, "battery mass m_b [kg]")
    n_rotors: int = _p("energy", 8, int, Interval(1, 1000), "number of rotors n_r")
    rotor_area_m2: float = _p("energy", 0.27, float, Interval(1e-4, 1e4), "rotor disc area zeta [m^2]")
    air_density_kg_m3: float = _p("energy", 1.225, float, Interval(0.01, 100), "air density rho [kg/m^3]")
    gravity_m_s2: float = _p("energy", 9.81, float, Interval(0, 100, "right"),
                             "gravitational acceleration g [m/s^2]")
    speed_m_s: float = _p("energy", 10.0, float, Interval(0, 1e4, "right"), "cruise speed v [m/s]")
    # Physical ranges, wide enough for any UAV, keep charging times finite and bounded.
    capacity_wh: float = _p("energy", 800.0, float, Interval(1, 1e6),
                            "theoretical battery capacity C [Wh]")
    charger_power_w: float = _p("energy", 100.0, float, Interval(1, 1e6), "charger power P_c [W]")
    charger_efficiency: float = _p("energy", 0.95, float, Interval(0.01, 1),
                                   "charger efficiency gamma [fraction]")
    xi: float = _p("energy", 0.5, float, Interval(0, 1, "left"),
                   "abort threshold xi [fraction of take-off SoC]")
    # [auction]
    rule: str = _p("auction", "least_confident", str, RegisteredRule(),
                   "winner rule: a name registered in dronefleet.delivery.auction.RULES, an installed "
                   "plugin (entry point group dronefleet.winner_rules) or 'package.module:function'")
    base_rule: str = _p("auction", "least_confident", str, RegisteredRule(base=True),
                        "rule that resolves the immediate bids under 'reservation'")
    theta: float = _p("auction", 50.0, float, Interval(0, 100, "both"),
                      "SoC threshold of the 'threshold' rule [%]")
    advert_interval_s: float = _p("auction", 2.0, float, Interval(1e-3, _LONGEST_S),
                                  "advertising period Delta of the FC [s]")
    # [policy]
    alpha: float = _p("policy", 0.01, float, Interval(0, 100, "right"),
                      "L2 regularisation strength of the SGD learner")
    eta0: float = _p("policy", 0.01, float, Interval(0, 100, "right"),
                     "initial learning rate eta0 of the SGD learner (unused by its 'optimal' schedule)")
    initial_epochs: int = _p("policy", 7, int, Interval(1, 10_000_000),
                             "epochs of the initial fit on the two assumed points (at most the "
                             "initial-fit draws of RUN_LIMITS with one UAV)")
    scaler_mean: tuple[float, float, float] = _p(
        "policy", (3500.0, 2.75, 50.0), tuple, Interval(-1e9, 1e9),
        "standardisation mean of the features (distance [m], mass [kg], SoC [%])", length=3)
    scaler_std: tuple[float, float, float] = _p(
        "policy", (1443.38, 1.298, 28.87), tuple, Interval(1e-6, 1e9),
        "standardisation std of the features (distance [m], mass [kg], SoC [%])", length=3)

    def __post_init__(self):
        values = _validate({f.name: getattr(self, f.name) for f in dataclasses.fields(self)})
        for name, value in values.items():
            object.__setattr__(self, name, value)  # normalised (int -> float, list -> tuple)

    @property
    def horizon_s(self) -> float:
        """Operating period T [s]."""
        return self.horizon_weeks * SECONDS_PER_WEEK

    @property
    def tau_s(self) -> float:
        """Mean inter-arrival time of orders [s]."""
        return self.tau_minutes * SECONDS_PER_MINUTE

    def to_dict(self) -> dict[str, dict[str, Any]]:
        """Nested by section, JSON-serialisable (tuples as lists)."""
        return {section: {key: (list(v) if isinstance(v := getattr(self, key), tuple) else v)
                          for key in keys}
                for section, keys in SECTIONS.items()}

    def to_json(self) -> str:
        """Deterministic JSON text of :meth:`to_dict` (sorted keys)."""
        return json.dumps(self.to_dict(), sort_keys=True)


PARAMETERS: dict[str, Param] = {
    f.name: dataclasses.replace(f.metadata["param"], name=f.name)
    for f in dataclasses.fields(Config)
}

SECTIONS: dict[str, tuple[str, ...]] = {}
for _key, _param in PARAMETERS.items():
    SECTIONS.setdefault(_param.section, ())
    SECTIONS[_param.section] += (_key,)
del _key, _param

# Cross-parameter rules, all of them: (lower, upper) must satisfy lower <= upper, and
# the run's size must stay within RUN_LIMITS (below).
_ORDERED_PAIRS: tuple[tuple[str, str], ...] = (
    ("mass_min_kg", "mass_max_kg"),
    ("distance_min_m", "distance_max_m"),
    ("soh_min", "soh_max"),
)


#: Limits on the size of a run, checked with the other cross-parameter rules (see
#: :func:`run_size`): whatever drives memory or time is refused up front, never met as a
#: MemoryError or a hang. Each is far above the paper's runs (8 weeks, tau 15 min: ~5.4e3
#: orders, 2.4e6 ticks) and a 10,000-UAV fleet (tau 15 min x 25 / 10,000: ~2.2e6 orders).
RUN_LIMITS: dict[str, float] = {
    "orders": 1e7,        # expected orders; ~300 B each (order book, draws, table): ~3 GB
    "samples": 1e7,       # time-series samples; ~150 B each
    "advert_ticks": 3e7,  # each tick scans the fleet and may launch an attempt (~250 B)
    "fleet_rows": 1e7,    # UAVs x (week ends + 1) rows of fleet snapshots; ~200 B each
    "fit_draws": 1e7,     # initial fit: one permutation drawn per UAV and epoch (~2 us each)
}


def run_size(config: Any) -> dict[str, float]:
    """Expected size of a run of ``config`` (a Config or a flat mapping), as counted by RUN_LIMITS.

    ``orders`` = horizon / tau (expected), ``samples`` = horizon / record_interval + 1,
    ``advert_ticks`` = horizon / advert_interval (at most; ticks with nobody to bid are
    skipped), ``fleet_rows`` = n_uavs x (week ends + 1), ``fit_draws`` = n_uavs x initial_epochs.
    """
    v = config if isinstance(config, Mapping) else {name: getattr(config, name) for name in PARAMETERS}
    horizon_s = v["horizon_weeks"] * SECONDS_PER_WEEK
    return {
        "orders": horizon_s / (v["tau_minutes"] * SECONDS_PER_MINUTE),
        "samples": math.floor(horizon_s / v["record_interval_s"]) + 1.0,
        "advert_ticks": horizon_s / v["advert_interval_s"],
        "fleet_rows": v["n_uavs"] * (math.ceil(v["horizon_weeks"]) + 1.0),
        "fit_draws": float(v["n_uavs"] * v["initial_epochs"]),
    }


# What each size counts, for the message: (noun, the parameters it comes from, how).
_RUN_SIZE_TERMS: dict[str, tuple[str, tuple[str, str], str]] = {
    "orders": ("orders", ("horizon_weeks", "tau_minutes"), "horizon {} weeks / tau {} min"),
    "samples": ("time-series samples", ("horizon_weeks", "record_interval_s"),
                "horizon {} weeks / record_interval_s {} s"),
    "advert_ticks": ("advertisement ticks", ("horizon_weeks", "advert_interval_s"),
                     "horizon {} weeks / advert_interval_s {} s"),
    "fleet_rows": ("fleet snapshot rows", ("n_uavs", "horizon_weeks"), "n_uavs {} x (horizon {} weeks + 1)"),
    "fit_draws": ("initial-fit draws", ("n_uavs", "initial_epochs"), "n_uavs {} x initial_epochs {}"),
}


def _check_run_size(values: Mapping[str, Any]) -> None:
    for name, size in run_size(values).items():
        limit = RUN_LIMITS[name]
        if size > limit:
            noun, keys, how = _RUN_SIZE_TERMS[name]
            how = how.format(*(_num(values[k]) for k in keys))
            raise ConfigError(f"the run would hold ~{size:.3g} {noun} ({how}); at most {limit:g} allowed", keys)


# --------------------------------------------------------------------------
# Validation: the one function
# --------------------------------------------------------------------------


def _type_name(value: Any) -> str:
    return type(value).__name__


def _is_number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _check_float(qualname: str, name: str, value: Any, interval: Interval) -> float:
    if not _is_number(value):
        raise ConfigError(f"{qualname} must be a number, got {_type_name(value)} {_show(value)}",
                          [name])
    try:
        x = float(value)
    except OverflowError:  # an int beyond any float
        x = math.inf
    if not math.isfinite(x):
        raise ConfigError(f"{qualname} = {_show(value)} is not a finite number", [name])
    if x not in interval:
        raise ConfigError(f"{qualname} = {_show(value)} is out of range: allowed {interval}",
                          [name])
    return x


def _check_one(p: Param, value: Any) -> Any:
    """Type and range of one parameter; returns the normalised value."""
    q = p.qualname
    if p.type is int:
        if not isinstance(value, int) or isinstance(value, bool):
            hint = f" (write {int(value)})" if isinstance(value, float) and value.is_integer() else ""
            raise ConfigError(f"{q} must be an integer, got {_type_name(value)} "
                              f"{_show(value)}{hint}", [p.name])
        if value not in p.constraint:
            raise ConfigError(f"{q} = {_show(value)} is out of range: allowed {p.constraint}",
                              [p.name])
        return value
    if p.type is float:
        return _check_float(q, p.name, value, p.constraint)
    if p.type is str:
        if not isinstance(value, str):
            raise ConfigError(f"{q} must be a string, got {_type_name(value)} {_show(value)}",
                              [p.name])
        if isinstance(p.constraint, RegisteredRule):
            problem = p.constraint.problem(value)
            if problem:
                raise ConfigError(f"{q} = {_show(value)} {problem}", [p.name])
            return value
        allowed = p.constraint.allowed()
        if allowed is not None and value not in allowed:
            raise ConfigError(f"{q} = {_show(value)} is not allowed{_suggest(value, allowed)}. "
                              f"Allowed: {', '.join(map(repr, allowed))}", [p.name])
        return value
    if p.type is tuple:
        if not isinstance(value, (list, tuple)) or len(value) != p.length:
            got = (f"a {_type_name(value)} of length {len(value)}"
                   if isinstance(value, (list, tuple)) else f"{_type_name(value)} {_show(value)}")
            raise ConfigError(f"{q} must be a list of {p.length} numbers, got {got}", [p.name])
        return tuple(_check_float(f"{q}[{i}]", p.name, v, p.constraint) for i, v in enumerate(value))
    raise TypeError(f"bad declaration of {q}")  # pragma: no cover - programming error


def _validate(values: Mapping[str, Any]) -> dict[str, Any]:
    """Check a complete flat ``name -> value`` mapping; return it normalised.

    The only validation function: types and ranges of every parameter, in
    declaration order, then the cross-parameter rules: ordered pairs, then the
    size of the run (:data:`RUN_LIMITS`).
    """
    out = {name: _check_one(PARAMETERS[name], values[name]) for name in PARAMETERS}
    for lo, hi in _ORDERED_PAIRS:
        if out[lo] > out[hi]:
            plo, phi = PARAMETERS[lo], PARAMETERS[hi]
            raise ConfigError(f"{plo.qualname} = {_show(values[lo])} must be <= "
                              f"{phi.qualname} = {_show(values[hi])}", [lo, hi])
    _check_run_size(out)
    return out


# --------------------------------------------------------------------------
# Structure: sections and key names
# --------------------------------------------------------------------------


def _flatten(d: Any, where: str | None = None,
             origin: dict[str, str] | None = None) -> dict[str, Any]:
    """Nested ``{section: {key: value}}`` -> flat ``{key: value}``, checking names.

    ``where`` (a file name) prefixes messages and is recorded per key in ``origin``.
    """
    pre = f"{where}: " if where else ""
    if not isinstance(d, Mapping):
        raise ConfigError(f"{pre}expected a table of sections, got {_type_name(d)}")
    flat: dict[str, Any] = {}
    for section, table in d.items():
        if not isinstance(section, str):
            raise ConfigError(f"{pre}a section name must be a string, got {_type_name(section)} {_show(section)}")
        if section not in SECTIONS:
            if section in PARAMETERS:
                raise ConfigError(
                    f"{pre}key {section!r} is at the top level; put it in section "
                    f"[{PARAMETERS[section].section}]", [section])
            raise ConfigError(
                f"{pre}unknown section [{_name(section)}]{_suggest(section, SECTIONS)}. "
                f"Allowed sections: {', '.join(SECTIONS)}")
        if not isinstance(table, Mapping):
            raise ConfigError(f"{pre}[{section}] must be a table of key = value, "
                              f"got {_type_name(table)} {_show(table)}")
        for key, value in table.items():
            if not isinstance(key, str):
                raise ConfigError(f"{pre}a key of [{section}] must be a string, got {_type_name(key)} {_show(key)}")
            if key not in SECTIONS[section]:
                raise ConfigError(f"{pre}{_unknown_key_message(section, key)}")
            flat[key] = value
            if origin is not None and where:
                origin[key] = where
    return flat


def _unknown_key_message(section: str, key: str) -> str:
    if key in PARAMETERS:
        return (f"{section}.{key} is not a key of [{section}]; {key} belongs in "
                f"[{PARAMETERS[key].section}]")
    return (f"unknown key {section}.{_name(key)}{_suggest(key, SECTIONS[section])}. "
            f"Allowed keys in [{section}]: {', '.join(SECTIONS[section])}")


def _unknown_name_message(name: str) -> str:
    return f"unknown key {_show(name)}{_suggest(name, PARAMETERS)}. Allowed keys: {', '.join(PARAMETERS)}"


def resolve_key(key: str) -> str:
    """'section.key' or a bare unique key name -> the parameter name."""
    if "." in key:
        section, _, name = key.partition(".")
        if section not in SECTIONS:
            raise ConfigError(f"unknown section {_show(section)} in {_show(key)}"
                              f"{_suggest(section, SECTIONS)}. "
                              f"Allowed sections: {', '.join(SECTIONS)}")
        if name not in SECTIONS[section]:
            raise ConfigError(_unknown_key_message(section, name))
        return name
    if key not in PARAMETERS:
        raise ConfigError(f"{_unknown_name_message(key)} (or section.key, sections: {', '.join(SECTIONS)})")
    return key


def _build(flat: Mapping[str, Any], origin: Mapping[str, str]) -> Config:
    """Defaults updated by ``flat`` -> Config; errors say where a bad value came from."""
    try:
        return Config(**flat)
    except ConfigError as e:
        sources = list(dict.fromkeys(origin[k] for k in e.keys if k in origin))
        if not sources:
            raise
        raise ConfigError(f"{e} (set in {'; '.join(sources)})", e.keys) from None


# --------------------------------------------------------------------------
# Entry points
# --------------------------------------------------------------------------


def default_config() -> Config:
    """The ``docs/delivery-model.md`` defaults (= ``configs/paper.toml``)."""
    return Config()


def config_from_dict(d: Mapping[str, Any], trusted: bool = True) -> Config:
    """Nested ``{section: {key: value}}`` (as :meth:`Config.to_dict` gives) -> Config.

    Missing sections or keys keep their defaults. ``trusted=False`` for a config read back
    from a file (:func:`dronefleet.delivery.records.read_config`): a plugin rule it names
    (``"module:function"``) is checked as a name and never imported, so reading a file runs
    no code. Such a config describes a run; running it loads its rule then
    (:func:`dronefleet.delivery.simulation.simulate`), but dronefleet itself only ever runs
    the user's configs.
    """
    flat = _flatten(d)
    if trusted:
        return Config(**flat)
    token = _FROM_DATA.set(True)
    try:
        return Config(**flat)
    finally:
        _FROM_DATA.reset(token)


def load_config(path: str | PathLike | None = None,
                overrides: Iterable[str] = (),
                seed: int | None = None) -> Config:
    """Read a run configuration.

    Parameters
    ----------
    path : TOML file, keys in their sections (any subset; missing keys keep
        their defaults), or None for the defaults. A top-level
        ``scenario = "delivery"`` is allowed; another scenario is refused
        (:func:`dronefleet.scenarios.load` dispatches on it).
    overrides : ``"key=value"`` strings (the CLI's ``--set``), applied in
        order after the file. ``key`` is ``section.key`` or the bare key name
        (all key names are unique); ``value`` is read as a TOML value
        (``20``, ``0.4``, ``true``, ``[1, 2, 3]``, ``"x"``) or, if that fails,
        taken as a bare string (``rule=random``).
    seed : if not None, replaces ``run.seed`` (after the overrides).

    Raises
    ------
    ConfigError
        For any problem, before anything else happens: unreadable, too large
        or non-UTF-8 file or TOML syntax error (naming the file), unknown
        section or key, malformed override, wrong type, out-of-range value
        (``seed`` in [0, 2**63 - 1]), violated cross rule, a run larger than
        :data:`RUN_LIMITS`.
    """
    origin: dict[str, str] = {}
    # Overrides first: a malformed --set is reported even if the file is also bad.
    parsed = parse_overrides(overrides, resolve_key, seed)
    flat: dict[str, Any] = {}
    if path is not None:
        _, document = read_toml(path)
        # the other scenarios' configs name theirs (dronefleet.scenarios); delivery's may
        scenario = document.pop(SCENARIO_KEY, "delivery")
        if scenario != "delivery":
            raise ConfigError(f"config file {str(path)!r} is for scenario {_show(scenario)}; "
                              "only a delivery config is allowed here")
        flat.update(_flatten(document, str(path), origin))
    for name, value, how in parsed:
        flat[name], origin[name] = value, how
    return _build(flat, origin)


def replace(config: Config, **changes: Any) -> Config:
    """``dataclasses.replace`` with a helpful error for unknown names; validated."""
    for name in changes:
        if name not in PARAMETERS:
            raise ConfigError(_unknown_name_message(name))
    return dataclasses.replace(config, **changes)


def describe(config: Config) -> str:
    """One line naming the run (the head of ``dronefleet run``, the replay page's title)."""
    return (f"seed {config.seed}, rule {config.rule}, tau {config.tau_minutes:g} min, "
            f"{counted(config.n_uavs, 'UAV')}, {counted(config.horizon_weeks, 'week')}")
