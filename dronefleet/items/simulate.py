"""Run one configuration of the items model: all its trials in one kernel call.

The Python layer turns :class:`Params` into the kernel's option and parameter arrays, lays out
the IDP grid, computes the trials' root seeds and allocates the outputs;
:func:`dronefleet.items.kernel.run_trials` does the rest. An experiment runs many (n, c, s)
cells with :func:`run_cell`, one call each: every cell draws the same worlds and generation
for the same trial index (section 10), so nothing needs to be shared between calls.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .. import interrupt
from . import kernel as k
from .params import Params, grid_side

__all__ = ["trial_seeds", "grid_positions", "kernel_inputs", "run_cell", "simulate", "summary_columns",
           "robot_columns", "measures", "MEASURES"]

_MODES = {"foraging": k.MODE_FP, "delivery": k.MODE_IDP}
_TRUTHS = {"bernoulli": k.BERNOULLI, "poisson": k.POISSON, "logistic": k.LOGISTIC}
_CAS = {"max_expected": k.CAS_MAX_EXPECTED, "rate": k.CAS_RATE, "gr_no_earmark": k.CAS_GR_NO_EARMARK}
HOME = (0.5, 0.5)
#: A10/L591: lowest IDP Poisson mean.
IDP_LAMBDA_FLOOR = 0.01


def trial_seeds(params: Params) -> np.ndarray:
    """Root seeds (int64) of trials first_trial .. first_trial + trials - 1: seed * 2**32 + k."""
    trials = np.arange(params.first_trial, params.first_trial + params.trials, dtype=np.int64)
    return np.int64(params.seed) * np.int64(2**32) + trials


def grid_positions(params: Params) -> np.ndarray:
    """Node positions (m + 1, 2): home, then the IDP grid row-major (x fastest); FP: home and
    zeros (the kernel draws the locations per trial)."""
    m = params.n_locations
    pos = np.zeros((m + 1, 2))
    pos[0] = HOME
    if not params.foraging:
        side = grid_side(params.grid_spacing, params.grid_edge)
        ticks = np.arange(side) * params.grid_spacing       # k N_s: exact products, the same everywhere
        pos[1:, 0] = np.tile(ticks, side)
        pos[1:, 1] = np.repeat(ticks, side)
    return pos


def kernel_inputs(params: Params, world: tuple[np.ndarray, np.ndarray] | None = None) -> tuple:
    """(opts int64, pars float64, positions (m + 1, 2), true parameters (m + 1,)) for the kernel.

    ``world`` = (positions, true parameters), both indexed by node, replaces the drawn world
    (tests build a world by hand; stream (a) is then not read).
    """
    p = params
    opts = np.zeros(k.N_OPTS, dtype=np.int64)
    opts[k.O_MODE] = _MODES[p.mode]
    opts[k.O_TRUTH] = _TRUTHS[p.truth]
    opts[k.O_ALG] = ("R", "GR", "GRIC", "CAS", "AS", "ASTC", "SF").index(p.algorithm)
    opts[k.O_CAS] = _CAS[p.cas_variant]
    opts[k.O_GR_CAP_MAX] = p.gr_cap == "max"
    opts[k.O_TIES_LOWEST] = p.ties == "lowest_index"
    opts[k.O_PRIVATE] = p.sharing == "destinations"
    opts[k.O_OBS_REAL] = p.obs == "real"
    opts[k.O_COUNT_PICKUP] = p.count_at == "pickup"
    opts[k.O_RESAMPLE] = p.truncation == "resample"
    opts[k.O_CAS_SHARED] = p.cas_targets == "shared"
    opts[k.O_STEPS], opts[k.O_CAPACITY], opts[k.O_ROBOTS] = p.steps, p.capacity, p.n_robots
    opts[k.O_DRAW_POSITIONS] = p.foraging and world is None
    opts[k.O_DRAW_PARAMS] = world is None
    if p.truth == "bernoulli":
        mean, sd, low, high, assumed = p.p_mean, p.p_sd, 0.0, 1.0, p.p_hat
    elif p.foraging:
        mean, sd, low, high, assumed = p.lambda_mean, p.lambda_sd, 0.0, np.inf, p.lam_hat
    else:
        mean, sd, low, high, assumed = p.mu_l, p.sigma_l, IDP_LAMBDA_FLOOR, np.inf, p.lam_hat
    if p.lam_hat_source == "mu":
        assumed = mean
    pars = np.zeros(k.N_PARS)
    pars[k.P_SPEED], pars[k.P_PV], pars[k.P_KP], pars[k.P_RATE] = p.speed, p.p_v, p.K_p, assumed
    pars[k.P_K], pars[k.P_LG], pars[k.P_SE], pars[k.P_X0], pars[k.P_MMIN] = p.K, p.lambda_g, p.sigma_e, p.x0, p.m_min
    pars[k.P_MEAN], pars[k.P_SD], pars[k.P_LOW], pars[k.P_HIGH] = mean, sd, low, high
    pars[k.P_OBS_RANGE] = p.obs_range
    if world is None:
        positions, truth_par = grid_positions(p), np.zeros(p.n_locations + 1)
    else:
        positions, truth_par = (np.ascontiguousarray(a, dtype=np.float64) for a in world)
    return opts, pars, positions, truth_par


def run_cell(params: Params, *, world: tuple[np.ndarray, np.ndarray] | None = None,
             trace: bool = False) -> dict[str, Any]:
    """Every trial of ``params`` (one experiment cell) in one kernel call (Ctrl-C stops it).

    Returns ``totals`` (trials, N_TOTALS) and ``per_robot`` (trials, n, N_PER_ROBOT) int64 (the
    kernel's columns); with ``trace``, ``trace`` (T + 1, n, 4) and ``trace_counts`` (T + 1, m + 1)
    of the first trial (node, destination, steps left, payload; counts or populations).
    """
    opts, pars, positions, truth_par = kernel_inputs(params, world)
    trials, n, m1 = params.trials, params.n_robots, positions.shape[0]
    totals = np.zeros((trials, k.N_TOTALS), dtype=np.int64)
    per_robot = np.zeros((trials, n, k.N_PER_ROBOT), dtype=np.int64)
    rows = params.steps + 1 if trace else 0
    trace_robots = np.zeros((rows, n, 4), dtype=np.int64)
    trace_counts = np.zeros((rows, m1))
    interrupt.call(k.run_trials, opts, pars, trial_seeds(params), positions, truth_par, totals, per_robot,
                   trace_robots, trace_counts)
    out = {"totals": totals, "per_robot": per_robot}
    if trace:
        out["trace"], out["trace_counts"] = trace_robots, trace_counts
    return out


def summary_columns() -> tuple[str, ...]:
    """Columns of the per-trial summary (see :func:`simulate`)."""
    return ("trial", "seed", "generated", "served", "rate", "picked", "visits", "trips", "items_per_trip")


def robot_columns() -> tuple[str, ...]:
    """Columns of the per-robot table (see :func:`simulate`)."""
    return ("trial", "robot", "trips", "visits", "items")


def simulate(params: Params) -> dict[str, np.ndarray]:
    """The columns of the ``summary`` and ``robots`` tables of every trial of ``params``.

    Per trial: ``generated`` G (logistic: the stock's net growth, A19), ``served`` (FP: items
    unloaded at home, or picked up with ``count_at = "pickup"``, F; IDP: demands satisfied, S),
    ``rate`` (100 F/G or 100 S/G [%]; logistic foraging: F, A19), ``picked`` (items taken at
    locations, or handed out), ``visits`` (arrivals at locations), ``trips`` (arrivals home),
    ``items_per_trip`` (served / trips; NaN without a trip). Per robot: ``trips``, ``visits``,
    ``items`` (its share of ``served``).
    """
    params.validate()
    r = run_cell(params)
    totals, per_robot = r["totals"], r["per_robot"]
    generated, served, trips = (totals[:, c] for c in (k.T_GENERATED, k.T_SERVED, k.T_TRIPS))
    with np.errstate(divide="ignore", invalid="ignore"):
        if params.truth == "logistic":
            rate = served.astype(np.float64)
        else:
            rate = np.where(generated > 0, 100.0 * served / np.maximum(generated, 1), np.nan)
        per_trip = np.where(trips > 0, served / np.maximum(trips, 1), np.nan)
    trials, n = per_robot.shape[:2]
    trial = np.arange(params.first_trial, params.first_trial + trials, dtype=np.int64)
    summary = {"trial": trial, "seed": trial_seeds(params), "generated": generated, "served": served,
               "rate": rate, "picked": totals[:, k.T_PICKED], "visits": totals[:, k.T_VISITS], "trips": trips,
               "items_per_trip": per_trip}
    robots = {"trial": np.repeat(trial, n), "robot": np.tile(np.arange(1, n + 1, dtype=np.int64), trials),
              "trips": per_robot[:, :, k.R_TRIPS].reshape(-1), "visits": per_robot[:, :, k.R_VISITS].reshape(-1),
              "items": per_robot[:, :, k.R_ITEMS].reshape(-1)}
    return {"summary": summary, "robots": robots}


#: The per-trial measures beyond the summary (:func:`measures`) and their kernel columns.
MEASURES = {"departures": k.T_DEPARTURES, "shared_targets": k.T_SHARED,
            "sf_updates_early": k.T_SF_UPDATES_EARLY, "sf_change_early": k.T_SF_CHANGE_EARLY,
            "sf_updates_late": k.T_SF_UPDATES_LATE, "sf_change_late": k.T_SF_CHANGE_LATE}


def measures(params: Params) -> dict[str, np.ndarray]:
    """Per trial (int64 arrays, one value per trial): ``trial``, ``generated``, ``served``, ``trips``
    (as in :func:`simulate`), and
    the quantities the paper argues with but the summary does not hold:

    - ``departures``: robots leaving a node for a location; ``shared_targets``: those whose
      location another robot was heading to or standing at as they left (under ASTC, two robots
      foraging one unassigned location at once: Liemhetcharat et al. 2015, Section 5.1.5);
    - SF (Section 5.1.4: its sleep time "may fluctuate and not converge"): ``sf_updates_early``,
      ``sf_updates_late``, the sleep-time updates in steps 1..T/2 and T/2+1..T, and
      ``sf_change_early``, ``sf_change_late``, the sum of |change| of the sleep time [steps]
      over them (0 for the other algorithms).
    """
    params.validate()
    totals = run_cell(params)["totals"]
    trial = np.arange(params.first_trial, params.first_trial + params.trials, dtype=np.int64)
    return {"trial": trial, "generated": totals[:, k.T_GENERATED], "served": totals[:, k.T_SERVED],
            "trips": totals[:, k.T_TRIPS],
            **{name: totals[:, column] for name, column in MEASURES.items()}}
