"""Keys of the item-delivery / foraging model (docs/items-model.md, the spec's section 2 and 13).

:data:`KEYS` declares every key once: TOML section, unit, kind (``int``, ``float`` or the tuple of
allowed words), range, default and meaning; :class:`Params` holds one validated configuration and
:meth:`Params.validate` checks every value and every rule between values, so kernels never
re-check. Lengths are in world units (side N = 1), times in steps.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

from ..config import ConfigError, _show, _suggest

__all__ = ["Key", "KEYS", "Params", "ParamsError", "ALGORITHMS", "RUN_LIMITS", "run_size", "grid_side"]


@dataclass(frozen=True)
class Key:
    """One key: section, unit, kind (int, float, or allowed words), range [low, high], default, meaning."""

    section: str
    unit: str
    kind: Any
    low: float | None
    high: float | None
    default: Any
    doc: str


ALGORITHMS = ("R", "GR", "GRIC", "CAS", "AS", "ASTC", "SF")
#: Largest root seed of an experiment and largest trial index: trial k of seed s is seeded
#: from s * 2**32 + k (distinct for every (s, k), inside int64).
MAX_SEED, MAX_TRIAL = 2**31 - 1, 2**32 - 1

KEYS: dict[str, Key] = {
    # run
    "trials": Key("run", "trials", int, 1, 100_000, 20, "trials of the configuration, run in one kernel call"),
    "first_trial": Key("run", "index", int, 1, 1_000_000_000, 1, "index k of the first trial"),
    "seed": Key("run", "-", int, 0, MAX_SEED, 2015,
                "root seed of the experiment: trial k draws its streams from seed * 2**32 + k"),
    "steps": Key("run", "steps", int, 1, 1_000_000, 1000, "T, steps per run"),
    # world
    "mode": Key("world", "-", ("foraging", "delivery"), None, None, "foraging",
                "foraging (FP: random locations, resources carried home) or delivery (IDP: grid, items carried out)"),
    "locations": Key("world", "locations", int, 1, 1000, 20, "FP: locations drawn uniform in the world, per trial"),
    "grid_spacing": Key("world", "length", float, 0.02, 1.0, 0.05, "IDP: N_s, spacing of the grid of locations"),
    "grid_edge": Key("world", "-", ("inclusive", "exclusive"), None, None, "inclusive",
                     "IDP grid {0, N_s, ..., N} with the upper edge (A3), or without it"),
    "obs_range": Key("world", "length", float, 0.0, 1.5, 0.0,
                     "o: robots observe the location they stand at (0) or, at the end of each step, "
                     "every location within o of their position (A7)"),
    # truth
    "truth": Key("generation", "-", ("bernoulli", "poisson", "logistic"), None, None, "poisson",
                 "how resources or demands appear (section 4); logistic: FP only"),
    "p_mean": Key("generation", "probability", float, 0.0, 1.0, 0.3, "Bernoulli p_j ~ N(p_mean, p_sd^2), in [0, 1]"),
    "p_sd": Key("generation", "probability", float, 0.0, 1.0, 0.15, "Bernoulli spread of p_j"),
    "lambda_mean": Key("generation", "per step", float, 0.0, 10.0, 0.5,
                       "FP Poisson lambda_j ~ N(lambda_mean, lambda_sd^2), >= 0"),
    "lambda_sd": Key("generation", "per step", float, 0.0, 10.0, 0.4, "FP Poisson spread of lambda_j"),
    "mu_l": Key("generation", "per step", float, 0.0, 10.0, 0.10, "IDP Poisson lambda_j ~ N(mu_l, sigma_l^2), >= 0.01"),
    "sigma_l": Key("generation", "per step", float, 0.0, 10.0, 0.08, "IDP Poisson spread of lambda_j"),
    "truncation": Key("generation", "-", ("clip", "resample"), None, None, "clip",
                      "A10: a normal draw outside its range is clipped to it, or drawn again"),
    "lambda_g": Key("generation", "per step", float, 1e-6, 10.0, 0.04, "logistic growth rate"),
    "K": Key("generation", "resources", float, 1.0, 1e6, 100.0, "logistic carrying capacity"),
    "x0": Key("generation", "resources", float, 0.0, 1e6, 50.0,
              "logistic initial population (and the robots' first O_j)"),
    "sigma_e": Key("generation", "-", float, 0.0, 1.0, 0.08, "logistic noise (the robots assume 0)"),
    "m_min": Key("generation", "resources", int, 0, 1_000_000, 1, "resources always left at a logistic location (A12)"),
    # robots
    "algorithm": Key("robots", "-", ALGORITHMS, None, None, "GR",
                     "allocation strategy (section 7); GRIC: delivery only; AS, ASTC, SF: logistic foraging only"),
    "n_robots": Key("robots", "robots", int, 1, 100, 5, "n"),
    "capacity": Key("robots", "items", int, 1, 1_000_000, 10, "c, items a robot carries"),
    "speed": Key("robots", "length per step", float, 0.001, 10.0, 0.2, "s"),
    "p_v": Key("robots", "probability", float, 0.0, 1.0, 0.5,
               "R: probability of another location when 0 < y < c (A13)"),
    "K_p": Key("robots", "steps per resource", float, 0.0, 1000.0, 1.0, "SF proportional gain (A18)"),
    "p_hat": Key("robots", "probability", float, 0.0, 1.0, 0.3, "robots' assumed Bernoulli rate"),
    "lam_hat": Key("robots", "per step", float, 0.0, 1000.0, 0.5, "robots' assumed Poisson rate (A9)"),
    "lam_hat_source": Key("robots", "-", ("value", "mu"), None, None, "value",
                          "A9: robots assume lam_hat (p_hat), or know the truth's mean (mu_l, lambda_mean, p_mean)"),
    # options of section 13
    "gr_cap": Key("options", "-", ("min", "max"), None, None, "min",
                  "A1: GR caps y' with min(c, ...); max: the text's max(c, ...)"),
    "cas_variant": Key("options", "-", ("max_expected", "rate", "gr_no_earmark"), None, None, "max_expected",
                       "A2: CAS score: expected count, count per travel step, or GRIC without ear-marking"),
    "cas_targets": Key("options", "-", ("unseen", "shared"), None, None, "unseen",
                       "CAS ignores the others' destinations, or sees them in the shared world model and "
                       "discounts each location by the room of the robots heading there, as GR's ear-marks "
                       "(Liemhetcharat et al. 2015, Sections 6.2, 7.1.2)"),
    "ties": Key("options", "-", ("random", "lowest_index"), None, None, "random",
                "A25: equal values go to the shorter trip, then a random one; or the lowest index"),
    "sharing": Key("options", "-", ("full", "destinations"), None, None, "full",
                   "A26: one shared world model; destinations: FP robots keep private models"),
    "obs": Key("options", "-", ("floor", "real"), None, None, "floor",
               "A28: logistic observation floor(x_j) or x_j"),
    "count_at": Key("options", "-", ("unload", "pickup"), None, None, "unload",
                    "A15: FP items count when unloaded at home, or when picked up"),
}

#: What one trial costs besides its steps, in the units of ``steps`` (~5 ns each): seeding the
#: streams of each robot and each location (~0.1-0.3 us apiece) and, in foraging, the travel
#: table of the trial's drawn locations (locations^2 entries, ~1.3 ns each), measured rounded up.
SETUP_PER_NODE, SETUP_PER_TRAVEL_ENTRY = 50, 0.25
#: Limits on a run's work, checked before any work (see :func:`run_size`): ``steps`` counts
#: trials x ((steps + 1) x (robots + locations) + set-up) (generation, movement and each trial's
#: set-up; ~5 ns each), ``scans`` trials x steps x robots x locations (the most a run's decisions
#: can read; ~2 ns each, reached only by robots deciding every step). The paper's largest cell
#: (20 trials x 1000 steps x (10 robots + 441 locations)) is 9e6 and 9e7.
RUN_LIMITS = {"steps": 2e9, "scans": 2e11}


def grid_side(spacing: float, edge: str) -> int:
    """Grid points per axis: coordinates k N_s in [0, N] (inclusive) or [0, N) (exclusive), N = 1,
    with 1e-9 of slack so that N_s = 0.05 gives 21 (or 20)."""
    last = math.floor(1.0 / spacing + 1e-9)
    if edge == "exclusive" and abs(last * spacing - 1.0) <= 1e-9:
        return last
    return last + 1


class ParamsError(ConfigError):
    """An items parameter outside its allowed range or a combination the model does not define."""


@dataclass(frozen=True)
class Params:
    """One configuration of the items model: every key of :data:`KEYS`, with its default."""

    locals().update({name: dataclasses.field(default=key.default) for name, key in KEYS.items()})
    __annotations__ = {name: "Any" for name in KEYS}

    @property
    def foraging(self) -> bool:
        return self.mode == "foraging"

    @property
    def n_locations(self) -> int:
        """m: FP ``locations``; IDP the grid's points."""
        return self.locations if self.foraging else grid_side(self.grid_spacing, self.grid_edge) ** 2

    def replace(self, **changes: Any) -> Params:
        """A validated copy with ``changes`` applied."""
        return dataclasses.replace(self, **changes).validate()

    def validate(self) -> Params:
        """Check every value and the rules between values; return self.

        Raises
        ------
        ParamsError
            Naming the key, its value and what is allowed (one line).
        """
        for name in KEYS:
            check(name, getattr(self, name))
        mode, algorithm, truth = self.mode, self.algorithm, self.truth
        if truth == "logistic" and not self.foraging:
            raise ParamsError('generation.truth = "logistic" is defined for mode "foraging" only '
                              '(item delivery has Bernoulli or Poisson demands)', ("truth", "mode"))
        if algorithm == "GRIC" and self.foraging:
            raise ParamsError('robots.algorithm = "GRIC" is defined for mode "delivery" only (Algorithm 3)',
                              ("algorithm", "mode"))
        if algorithm in ("AS", "ASTC", "SF") and not (self.foraging and truth == "logistic"):
            raise ParamsError(f'robots.algorithm = "{algorithm}" is defined for mode "foraging" with truth '
                              f'"logistic" only, not {mode} with {truth}', ("algorithm", "mode", "truth"))
        if self.sharing == "destinations" and not self.foraging:
            raise ParamsError('options.sharing = "destinations" is defined for mode "foraging" only (A26)',
                              ("sharing", "mode"))
        if self.cas_targets == "shared" and self.cas_variant == "gr_no_earmark":
            raise ParamsError('options.cas_targets = "shared" is not defined with cas_variant = "gr_no_earmark" '
                              '(GRIC\'s rule with ear-marks is GRIC itself): use "max_expected" or "rate"',
                              ("cas_targets", "cas_variant"))
        if self.foraging and self.locations < 1:
            raise ParamsError("world.locations must be >= 1", ("locations",))
        size = run_size(self)
        for limit, most in RUN_LIMITS.items():
            if size[limit] > most:
                raise ParamsError(
                    f"the run would take ~{size[limit]:.3g} {limit} (trials {self.trials} x "
                    + (f"((steps {self.steps} + 1) x (robots + locations) + {trial_setup(self):,.0f} per trial's "
                       "set-up)" if limit == "steps" else f"steps {self.steps} x robots x locations")
                    + f", {self.n_robots} robots, {self.n_locations} locations); at most {most:g}: lower trials, "
                    "steps, robots or locations", ("trials", "steps"))
        return self


def trial_setup(params: Params) -> float:
    """One trial's set-up in the units of ``steps`` (see :data:`SETUP_PER_NODE`); an IDP grid's
    travel table is the same for every trial, built once per run."""
    m = params.n_locations
    travel = SETUP_PER_TRAVEL_ENTRY * m * m if params.foraging else 0.0
    return SETUP_PER_NODE * (params.n_robots + m) + travel


def run_size(params: Params) -> dict[str, float]:
    """The work of a run as :data:`RUN_LIMITS` counts it, each trial's set-up included."""
    trial_steps = params.trials * (params.steps + 1)
    m = params.n_locations
    return {"steps": trial_steps * (params.n_robots + m) + params.trials * trial_setup(params),
            "scans": trial_steps * params.n_robots * m}


def _allowed(key: Key) -> str:
    if isinstance(key.kind, tuple):
        return ", ".join(repr(word) for word in key.kind)
    low, high = (f"{v:g}" if key.kind is float else f"{v:,}" for v in (key.low, key.high))
    return f"[{low}, {high}]"


def check(name: str, value: Any) -> Any:
    """``value`` of key ``name``, typed as its kind (an int is taken for a float), or ParamsError."""
    key = KEYS[name]
    where = f"{key.section}.{name}"
    if isinstance(key.kind, tuple):
        if not isinstance(value, str):
            raise ParamsError(f"{where} must be a string, got {type(value).__name__} {_show(value)}", (name,))
        if value not in key.kind:
            raise ParamsError(f"{where} = {_show(value)} is not allowed{_suggest(value, key.kind)}. "
                              f"Allowed: {_allowed(key)}", (name,))
        return value
    if key.kind is int:
        if not isinstance(value, int) or isinstance(value, bool):
            hint = f" (write {int(value)})" if isinstance(value, float) and value.is_integer() else ""
            raise ParamsError(f"{where} must be an integer, got {type(value).__name__} {_show(value)}{hint}", (name,))
    elif not isinstance(value, (int, float)) or isinstance(value, bool):
        raise ParamsError(f"{where} must be a number, got {type(value).__name__} {_show(value)}", (name,))
    elif isinstance(value, int):
        value = float(value) if abs(value) < 2**1000 else math.inf
    if not (key.low <= value <= key.high):  # nan fails too
        raise ParamsError(f"{where} = {_show(value)} is out of range: allowed {_allowed(key)}", (name,))
    return value


def allowed(name: str) -> str:
    """What key ``name`` allows, as the schema shows it."""
    return _allowed(KEYS[name])
