"""The keys of a lunar config and their checks (spec LUNAR-FORAGING.md; ``configs/lunar.toml``).

:data:`KEYS` declares each key's section, unit, kind, range and meaning; :func:`check` checks
one value, :func:`validate` the rules between values and the size of a run (:data:`RUN_LIMITS`),
and :func:`checked` builds a configuration through both. :mod:`dronefleet.lunar.scenario` builds
its configs with them, and :mod:`dronefleet.lunar.study` holds the configurations it reads back
from its tables to them.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from ..config import ConfigError, _show, _suggest
from .layout import build
from .params import LAYOUTS, OPTIONS, LunarParams

__all__ = ["KEYS", "RUN_LIMITS", "MAX_SEED", "MAX_RUN", "Key", "check", "validate", "checked", "run_size",
           "region_gap", "snapshots_per_run", "trips_per_robot"]

#: Largest root seed and largest run index (run j's streams are drawn from (seed, j, robot)).
MAX_SEED, MAX_RUN = 2**31 - 1, 10**9


@dataclass(frozen=True)
class Key:
    """One key: section, unit, kind (``int``, ``float``, ``bool`` or the tuple of allowed words),
    range [low, high] (numbers only), meaning (with the spec's A-number where it is an option)."""

    section: str
    unit: str
    kind: Any
    low: float | None
    high: float | None
    doc: str


def _word(section: str, doc: str, name: str) -> Key:
    return Key(section, "-", OPTIONS[name], None, None, doc)


KEYS: dict[str, Key] = {
    # run
    "runs": Key("run", "runs", int, 1, 10_000, "runs of the configuration, all in one kernel call"),
    "first_run": Key("run", "index", int, 0, MAX_RUN, "index j of the first run (run j: the same streams in "
                     "every layout and capacity)"),
    "seed": Key("run", "-", int, 0, MAX_SEED, "root seed of the experiment (section 13)"),
    "duration_s": Key("run", "s", float, 1.0, 86_400.0, "T_run, run length (A10); K = floor(T_run / tau) ticks"),
    "tau": Key("run", "s", float, 0.001, 1.0, "control step, one tick"),
    # world
    "layout": Key("world", "-", LAYOUTS, None, None, "scenario: no obstacle, or a hard or soft obstacle between "
                  "R-T, N-T or N-R (section 2)"),
    "layout_scale": Key("world", "-", float, 0.5, 2.0, "scale of field, region centres and obstacle corners about "
                        "the origin (A5; 1.0 = the earlier 16.8 x 14.4 m draft)"),
    "kappa_soft": Key("world", "-", float, 1.0, 100.0, "locomotion power multiplier inside the soft obstacle (A7)"),
    # robots
    "n_robots": Key("robots", "robots", int, 1, 500, "N_a"),
    "v0": Key("robots", "m/s", float, 0.001, 20.0, "ground speed (A1); v0 * tau at most r_body"),
    "r_body": Key("robots", "m", float, 0.01, 1.0, "robot disc radius (A29)"),
    "ir_range": Key("robots", "m", float, 0.0, 5.0, "d_IR, reach of the 7 IR rays beyond the body (7.4)"),
    "blocked_ticks": Key("robots", "ticks", int, 1, 100_000, "consecutive blocked ticks before a random turn (7.5)"),
    "comm_radius": Key("robots", "m", float, 0.1, 20.0, "delta_comm, communication radius (strict <)"),
    "r_max": Key("robots", "units", int, 1, 1_000_000, "resource units loaded per visit to T (A11)"),
    # guidance
    "update_interval_s": Key("guidance", "s", float, 0.001, 3600.0, "T, heading-decision and beacon-window "
                             "interval; n_T = floor(T / tau) ticks, at least 1 (A2)"),
    "decision_step_m": Key("guidance", "m", float, 0.0, 20.0, "A1: 0 = heading decisions every T only; > 0 = also "
                           "each time a robot has driven this far since its last decision (below comm_radius)"),
    "rho_w": Key("guidance", "-", float, 0.0, 1.0, "potential-weight evaporation rate per window (Eq 5-11)"),
    "rho_v": Key("guidance", "-", float, 0.0, 1.0, "guidance-vector update weight (Eq 5-12)"),
    "rho_p": Key("guidance", "-", float, 0.0, 1.0, "SOC-cost learning weight (Eq 5-13)"),
    "rho_f": Key("guidance", "-", float, 0.0, 10.0, "exponent of omega in the guidance weight (Eq 5-14, A12)"),
    "rho_c": Key("guidance", "-", float, 0.0, 10.0, "exponent of (1 - SOC_b) in the guidance weight (Eq 5-14, A12)"),
    "eta_w": Key("guidance", "-", float, 0.0, 100.0, "beacon decay threshold on the summed potential weights"),
    "phi_soc": Key("guidance", "-", float, 0.0, 10.0, "phi_SOC, safety factor on the learned SOC cost"),
    "eps": Key("guidance", "probability", float, 0.0, 1.0, "exploration probability per heading decision "
               "(1: no guidance, the control of section 14)"),
    "reward": Key("guidance", "-", float, 0.0, 1000.0, "r, reward for being inside the region just completed"),
    "diffusion": Key("guidance", "-", float, 0.0, 1.0, "lambda, diffusion rate of the state potential"),
    # energy
    "battery_wh": Key("energy", "Wh", float, 0.01, 10_000.0, "E_cap, battery capacity (1 Wh = 3600 J)"),
    "soc0": Key("energy", "-", float, 0.001, 1.0, "initial state of charge (A39)"),
    "soc0_low": Key("energy", "-", float, 0.0, 1.0, "A39: if > 0, each robot starts at a SOC drawn from "
                    "U(soc0_low, soc0); 0: every robot starts at soc0"),
    "energy_scale": Key("energy", "-", float, 0.001, 1000.0, "A8: factor on every consumption term (p_move, p_comp, "
                        "p_comm, p_scan, p_avoid, e_exploit; not p_solar)"),
    "p_move": Key("energy", "W", float, 0.0, 100_000.0, "locomotion power on normal ground while translating (A8)"),
    "p_comp": Key("energy", "W", float, 0.0, 100_000.0, "computation power, every alive robot (A8)"),
    "p_comm": Key("energy", "W", float, 0.0, 100_000.0, "power per active communication link (A8)"),
    "p_scan": Key("energy", "W", float, 0.0, 100_000.0, "scanning power, mobile roles only (A8)"),
    "p_avoid": Key("energy", "W", float, 0.0, 100_000.0, "extra power while obstacle avoidance is active (A8)"),
    "e_exploit": Key("energy", "J", float, 0.0, 1e9, "energy per load at T (A8)"),
    "p_solar": Key("energy", "W", float, 0.0, 1e6, "solar input inside R, 0 outside (A9: 0.30 * 1361 * 0.25)"),
    # records
    "rate_window_s": Key("records", "s", float, 0.001, 86_400.0, "W_rate, window of the rate of return (A34)"),
    "snapshot_every_s": Key("records", "s", float, 0.001, 86_400.0, "interval of the periodic network snapshots "
                            "(section 19)"),
    "frames": Key("records", "-", bool, None, None, "also a snapshot (\"frame\") every n_T ticks, for the replay page"),
    "frame_every_s": Key("records", "s", float, 0.0, 86_400.0, "with frames: their interval, 0 = every n_T ticks "
                         "(shorter: smoother paths, Figs 6-5, 6-6)"),
    # options of section 17
    "avoidance": _word("options", "A28: offset from the plan while an obstacle is sensed, or the earlier "
                       "reading (the turn becomes the plan)", "avoidance"),
    "broadcast_velocity": _word("options", "A28: robots broadcast their planned velocity v_m, or this tick's "
                                "motion", "broadcast_velocity"),
    "broadcast": _word("options", "A4: mobile robots broadcast every tick, or once per update", "broadcast"),
    "weight_form": _word("options", "A12: w = omega^rho_f (1 - S)^rho_c; bracket: omega max(0, 1 - rho_c S); "
                         "literal: omega (1 - S)", "weight_form"),
    "fallback": _word("options", "A18: R -> nest fallback only once R was visited, or always (Eq 5-16 as printed)",
                      "fallback"),
    "turn_on": _word("options", "A26: turn around on role changes inside a region and at decay, or on every "
                     "change", "turn_on"),
    "los_bodies": Key("options", "-", bool, None, None, "A30: robot bodies occlude communication"),
    "redecide": _word("options", "A41: extra heading decisions: none, when avoidance clears, or when the nearest "
                      "beacon changes", "redecide"),
    "completion": _word("options", "A17: completion by role (and rows 9, 11), or by the last region visited",
                        "completion"),
    "depletion": _word("options", "A32: SOC 0 kills the robot, or is counted and the robot goes on towards R",
                       "depletion"),
    "experience": _word("options", "Sec 4-1-3: beacons take every robot's experience, or only that of robots "
                        "moving away from the region they last completed", "experience"),
    "model": _word("options", "E5: the Ch 5 model, or the Ch 4 baseline (no energy: roles F_OUT, F_IN, B only)",
                   "model"),
}

#: Limits on a run's work and memory, checked before any work (:func:`run_size`). ``robot_ticks``:
#: runs x ticks x robots (motion, energy, roles: the defaults make 1.4e8); ``pair_ticks``: runs x
#: ticks x robots^2 (sensing and communication between robots: 7e9 at the defaults);
#: ``occlusion_tests``: with ``los_bodies``, runs x ticks x robots^3 (each link's line of sight
#: tested against every other robot's body; 0 without): 500 robots all in range test ~8e9 a
#: second, so the limit is about a minute (E4's los_bodies runs make 3.5e11);
#: ``records``: rows of the time series (runs x (ticks / n_T + 1)); ``snapshot_rows``: rows of the
#: snapshots table (runs x robots x snapshots per run; the defaults with ``frames = true`` make
#: 9.4e5, about 250 MB while built); ``trip_rows``: the most trip records the runs can hold, each
#: robot driving the shortest gap between two regions for every trip (runs x robots x (v0 T_run /
#: gap + 1); 3.4e6 at the defaults, ~400 MB, where a run of 50 records a few hundred per run).
#: The ``robots`` and ``deaths`` tables hold at most runs x robots rows, a quarter of ``snapshot_rows``.
#: The ``recharge_triggers`` rows have no useful bound (one per robot every other tick): row 2 fires
#: again once rows 5-11 made the robot F_OUT or F_IN, inside a region, so a robot held in a region
#: fires it whenever its S_hat changes; runs record a few per robot and hour, and the table grows as needed.
RUN_LIMITS = {"robot_ticks": 2e9, "pair_ticks": 1e11, "occlusion_tests": 6e11, "records": 5e6, "snapshot_rows": 1e6,
              "trip_rows": 1e7}
#: Milestone snapshots of a run besides the periodic ones: first_T, first_R, first_row5, end.
MILESTONES = 4


def _allowed(key: Key) -> str:
    if key.kind is bool:
        return "true, false"
    if isinstance(key.kind, tuple):
        return ", ".join(repr(word) for word in key.kind)
    low, high = (f"{v:g}" if key.kind is float else f"{v:,}" for v in (key.low, key.high))
    return f"[{low}, {high}]"


def check(name: str, value: Any) -> Any:
    """``value`` of key ``name``, typed as its kind (an int is taken for a float), or ConfigError
    naming the key, the value and what is allowed."""
    key = KEYS[name]
    where = f"{key.section}.{name}"
    if key.kind is bool:
        if not isinstance(value, bool):
            raise ConfigError(f"{where} must be true or false (a TOML boolean, unquoted), got "
                              f"{type(value).__name__} {_show(value)}", (name,))
        return value
    if isinstance(key.kind, tuple):
        if not isinstance(value, str):
            raise ConfigError(f"{where} must be a string, got {type(value).__name__} {_show(value)}", (name,))
        if value not in key.kind:
            # the nearest word, also for a word in the wrong case ('soft-rt')
            near = _suggest(value.upper() if value.upper() in key.kind else value, key.kind)
            raise ConfigError(f"{where} = {_show(value)} is not allowed{near}. "
                              f"Allowed: {_allowed(key)}", (name,))
        return value
    if key.kind is int:
        if not isinstance(value, int) or isinstance(value, bool):
            hint = f" (write {int(value)})" if isinstance(value, float) and value.is_integer() else ""
            raise ConfigError(f"{where} must be an integer, got {type(value).__name__} {_show(value)}{hint}", (name,))
    elif not isinstance(value, (int, float)) or isinstance(value, bool):
        raise ConfigError(f"{where} must be a number, got {type(value).__name__} {_show(value)}", (name,))
    elif isinstance(value, int):
        value = float(value) if abs(value) < 2**1000 else math.inf
    if not (key.low <= value <= key.high):  # nan fails too
        raise ConfigError(f"{where} = {_show(value)} is out of range: allowed {_allowed(key)}", (name,))
    return value


def snapshots_per_run(params: LunarParams) -> int:
    """Most snapshots a run records: the milestones, one every ``snapshot_every_s`` and, with
    ``frames``, one every n_T ticks (or every ``frame_every_s``)."""
    count = MILESTONES + params.ticks // params.snapshot_every_ticks
    return count + (params.ticks // params.frame_every_ticks + 1 if params.frames else 0)


def region_gap(params: LunarParams) -> float:
    """The shortest distance between the edges of two regions [m]: what a trip's robot drives at least."""
    layout = build(params)
    centres, radii = layout.centres, layout.radii
    return min(math.dist(centres[a], centres[b]) - radii[a] - radii[b] for a in centres for b in centres if a < b)


def trips_per_robot(params: LunarParams) -> int:
    """Most trip records one robot of a run can make: one per shortest gap it can drive, and its first."""
    return math.floor(params.ticks * params.v0 * params.tau / region_gap(params)) + 1


def run_size(params: LunarParams) -> dict[str, float]:
    """The work and memory of a run as :data:`RUN_LIMITS` counts them."""
    run_ticks = params.runs * params.ticks
    return {"robot_ticks": run_ticks * params.n_robots, "pair_ticks": run_ticks * params.n_robots ** 2,
            "occlusion_tests": run_ticks * params.n_robots ** 3 if params.los_bodies else 0,
            "records": params.runs * (params.ticks // params.n_T + 1),
            "snapshot_rows": params.runs * params.n_robots * snapshots_per_run(params),
            "trip_rows": params.runs * params.n_robots * trips_per_robot(params)}


#: Each limit of :data:`RUN_LIMITS`: the keys it depends on, and what brings it down.
_LIMIT_FIXES = {"robot_ticks": (("runs", "duration_s", "tau", "n_robots"), "lower runs, duration_s or n_robots"),
                "pair_ticks": (("runs", "duration_s", "tau", "n_robots"), "lower runs, duration_s or n_robots"),
                "occlusion_tests": (("runs", "duration_s", "tau", "n_robots", "los_bodies"),
                                    "lower runs, duration_s or n_robots, or set los_bodies = false"),
                "records": (("runs", "duration_s", "tau", "update_interval_s"),
                            "lower runs or duration_s, or raise update_interval_s"),
                "snapshot_rows": (("runs", "n_robots", "snapshot_every_s", "frames", "frame_every_s"),
                                  "lower runs or n_robots, raise snapshot_every_s or frame_every_s, or set "
                                  "frames = false"),
                "trip_rows": (("runs", "n_robots", "duration_s", "v0", "layout_scale"),
                              "lower runs, n_robots, duration_s or v0")}


def _factors(p: LunarParams) -> dict[str, str]:
    """What each of :data:`RUN_LIMITS` counts, in ``p``'s numbers."""
    return {"robot_ticks": f"runs {p.runs} x {p.ticks:,} ticks x {p.n_robots} robots",
            "pair_ticks": f"runs {p.runs} x {p.ticks:,} ticks x {p.n_robots}^2 robot pairs",
            "occlusion_tests": f"runs {p.runs} x {p.ticks:,} ticks x {p.n_robots}^3 (links x bodies, los_bodies)",
            "records": f"runs {p.runs} x {p.ticks // p.n_T + 1:,} records per run",
            "snapshot_rows": f"runs {p.runs} x {p.n_robots} robots x {snapshots_per_run(p):,} snapshots per run",
            "trip_rows": f"runs {p.runs} x {p.n_robots} robots x {trips_per_robot(p):,} trips a robot can make, "
                         f"driving {p.v0:g} m/s for {p.duration_s:g} s with {region_gap(p):.3g} m between regions"}


def validate(params: LunarParams) -> None:
    """The rules between values and the size of the run; ConfigError (one line) naming the keys."""
    p = params
    for name, interval in (("duration_s", p.duration_s), ("update_interval_s", p.update_interval_s),
                           ("rate_window_s", p.rate_window_s), ("snapshot_every_s", p.snapshot_every_s),
                           ("frame_every_s", p.frame_every_s or p.tau)):  # 0: every n_T ticks
        if math.floor(interval / p.tau + 1e-9) < 1:
            raise ConfigError(f"{KEYS[name].section}.{name} = {interval:g} s is shorter than one tick "
                              f"(run.tau = {p.tau:g} s): it must hold at least one", (name, "tau"))
    if p.frame_every_s > 0 and not p.frames:
        raise ConfigError(f"records.frame_every_s = {p.frame_every_s:g} s sets the interval of the frames, but "
                          "records.frames = false records none: set frames = true or frame_every_s = 0",
                          ("frame_every_s", "frames"))
    if p.v0 * p.tau > p.r_body:
        raise ConfigError(f"a tick's step v0 * tau = {p.v0:g} * {p.tau:g} = {p.v0 * p.tau:g} m is longer than "
                          f"robots.r_body = {p.r_body:g} m: robots would jump through each other and obstacle "
                          "edges; lower v0 or tau", ("v0", "tau", "r_body"))
    if p.decision_step_m >= p.comm_radius:
        raise ConfigError(f"guidance.decision_step_m = {p.decision_step_m:g} m is not below robots.comm_radius = "
                          f"{p.comm_radius:g} m: decisions by distance are for steps within one beacon's range "
                          "(0 turns them off)", ("decision_step_m", "comm_radius"))
    if p.soc0_low > p.soc0:
        raise ConfigError(f"energy.soc0_low = {p.soc0_low:g} is above energy.soc0 = {p.soc0:g}: initial SOCs are "
                          "drawn from U(soc0_low, soc0); set 0 < soc0_low <= soc0 (0: every robot starts at soc0)",
                          ("soc0_low", "soc0"))
    if p.first_run + p.runs - 1 > MAX_RUN:
        raise ConfigError(f"runs {p.first_run}-{p.first_run + p.runs - 1} go beyond run index {MAX_RUN:,}",
                          ("first_run", "runs"))
    size = run_size(p)
    for limit, most in RUN_LIMITS.items():
        if size[limit] > most:
            keys, fix = _LIMIT_FIXES[limit]
            holds = "could hold up to" if limit == "trip_rows" else "would hold"  # a bound, not an estimate
            raise ConfigError(f"the run {holds} ~{size[limit]:.3g} {limit.replace('_', '-')} "
                              f"({_factors(p)[limit]}); at most {most:g}: {fix}", keys)


def checked(values: Mapping[str, Any], kind: type = LunarParams) -> Any:
    """``kind(**values)`` (a :class:`LunarParams` or a subclass), each value checked (:func:`check`)
    and then the rules between them (:func:`validate`); ConfigError (one line) naming the key."""
    params = kind(**{name: check(name, value) for name, value in values.items()})
    validate(params)
    return params
