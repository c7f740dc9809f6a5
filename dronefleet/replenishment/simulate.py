"""Run one configuration of the replenishment model: all its trials in one kernel call.

The Python layer loads the supervisors, maps their events by name onto the
kernel's event codes, seeds the random streams and allocates nothing inside
the tick loop; :func:`dronefleet.replenishment.kernel.run_trials` does the rest.
"""

from __future__ import annotations

import functools
from pathlib import Path
from typing import Any

import numpy as np

from .. import interrupt
from ..rng import spawn_states
from ..supervisor import Automaton, load_supervisor
from . import kernel
from .params import V_MIN, V_MOVE, Params

__all__ = ["SUPERVISOR_FILES", "TRIAL_SEED_FACTOR", "trial_seeds", "simulate", "summary_columns"]

_DATA = Path(__file__).resolve().parent.parent / "data"
SUPERVISOR_FILES = {
    "worker": _DATA / "replenishment-2024-worker.yaml",
    "worker-with-mobile-charger": _DATA / "replenishment-2024-worker-with-mobile-charger.yaml",
    "charger": _DATA / "replenishment-2024-charger.yaml",
}
TRIAL_SEED_FACTOR = 876     # trial k (1-based) uses seed 876 k

TRACE_MAX_BYTES = 2e9      # the trace is for tests and inspection, not for sweeps
TRACE_NAMES = ("x", "y", "energy", "consumed", "flags", "event", "sup_states", "provider",
               "served", "msg_requesting", "msg_from", "msg_to", "received", "source")


@functools.cache
def _default_supervisor(name):
    """The 2024 supervisor file ``name`` of SUPERVISOR_FILES, parsed once per process.

    Parsing the YAML takes longer than a short simulation; the automaton is only read.
    """
    return load_supervisor(SUPERVISOR_FILES[name])


def trial_seeds(trials: int, first: int = 1) -> np.ndarray:
    """Seeds 876 k of trials k = first .. first + trials - 1 (int64 array)."""
    return TRIAL_SEED_FACTOR * np.arange(first, first + trials, dtype=np.int64)


def _role_tables(automata):
    """Kernel tables for (worker automaton, charger automaton or None).

    Returns tables (2, K, S, N_EVENTS), n_sup (2,), init (2, K), unc_order and
    ctrl_order (2, N_EVENTS) in each file's own event order, n_unc, n_ctrl (2,).
    Events are mapped by name; kernel events absent from a file get -1 columns
    (never enabled, never applied).
    """
    present = [a for a in automata if a is not None]
    kmax = max(a.n_supervisors for a in present)
    smax = max(max(a.n_states) for a in present)
    tables = np.full((2, kmax, smax, kernel.N_EVENTS), -1, dtype=np.int64)
    n_sup = np.zeros(2, dtype=np.int64)
    init = np.zeros((2, kmax), dtype=np.int64)
    unc = np.full((2, kernel.N_EVENTS), -1, dtype=np.int64)
    ctrl = np.full((2, kernel.N_EVENTS), -1, dtype=np.int64)
    n_unc = np.zeros(2, dtype=np.int64)
    n_ctrl = np.zeros(2, dtype=np.int64)
    for role, automaton in enumerate(automata):
        if automaton is None:
            continue
        unknown = [e for e in automaton.events if e not in kernel.EVENT_NAMES]
        if unknown:
            raise ValueError(f"supervisor event(s) {', '.join(unknown)} have no meaning in the "
                             f"replenishment model; known: {', '.join(kernel.EVENT_NAMES)}")
        codes = [kernel.EVENT_NAMES.index(e) for e in automaton.events]
        dense = automaton.transition_table(automaton.events)
        k, s, _ = dense.shape
        tables[role, :k, :s, codes] = np.moveaxis(dense, 2, 0)
        n_sup[role] = k
        init[role, :k] = automaton.init_state
        for e, code in enumerate(codes):
            if automaton.controllable[e]:
                ctrl[role, n_ctrl[role]] = code
                n_ctrl[role] += 1
            else:
                unc[role, n_unc[role]] = code
                n_unc[role] += 1
    return tables, n_sup, init, unc, ctrl, n_unc, n_ctrl


def _mc_rank(n_chargers):
    """Rank of each MC (C1..Cn) in id-string order "C1" < "C10" < "C11" < ... < "C2"."""
    order = sorted(range(n_chargers), key=lambda j: f"C{j + 1}")
    rank = np.empty(n_chargers, dtype=np.int64)
    rank[order] = np.arange(n_chargers)
    return rank


def simulate(params: Params, trials: int | None = None, *, first_trial: int = 1,
             supervisors: dict[str, Automaton] | None = None, wheel_noise: bool = True, trace: bool = False,
             track: bool = False) -> dict[str, Any]:
    """Simulate every trial of ``params`` in one compiled call.

    Parameters
    ----------
    params : Params
        Validated here.
    trials : int, optional
        Number of trials (default ``params.trials``); trials are
        ``first_trial .. first_trial + trials - 1`` with seeds 876 k.
    first_trial : int
        1-based index of the first trial (so any trial can be run alone).
    supervisors : dict, optional
        ``{"worker": Automaton, "charger": Automaton}`` replacing the 2024 files
        (the worker file is the fixed or with-MC one by strategy).
    wheel_noise : bool
        False switches the N(1, 0.1^2) wheel factors off (tests only).
    trace : bool
        Also return per-tick, per-robot arrays (memory ~ trials x ticks x robots).
    track : bool
        Also return the first trial's robots at every sample of the time series (memory ~
        samples x robots; for the replay page). Changes no other output.

    Returns
    -------
    dict
        Per trial (shape (trials,)): ``trial``, ``seed``, ``work`` (points W),
        ``energy`` (total consumed), ``work_energy``, ``efficiency``
        (work energy / total), ``efficiency_with_loss`` (work energy /
        (total + lost), Fig 12), ``depleted_workers``, ``depleted_chargers``,
        ``shared``, ``lost``. Per robot (trials, n): ``consumed``,
        ``robot_work_energy``, ``battery`` (final), ``drawn`` (from the base),
        ``paid`` (actually removed by activities), ``given``, ``received``
        (transfers), ``depleted``. Time series: ``series_tick`` (samples,) and
        ``series`` (trials, samples, 10): robots in phases P0..P3 (workers,
        columns 0-3; chargers, 4-7), stored energy (8), cumulative work (9).
        With ``trace``: ``trace`` is a dict of (trials, ticks, n) arrays
        (``sup_states`` is (trials, ticks, n, K): states after the
        uncontrollable events, before the controllable one).
        With ``track``: ``track`` is a dict of (samples, n) arrays of the first trial at the
        ticks ``series_tick``: ``x``, ``y`` (centre [m]), ``energy`` (battery [energy units])
        and ``phase`` (controller phase 0..3, as in ``series``).
    """
    params.validate()
    trials = params.trials if trials is None else int(trials)
    if trials < 1 or first_trial < 1:
        raise ValueError(f"trials = {trials}, first_trial = {first_trial}: both must be >= 1")
    n_robots = params.n_workers + params.n_chargers
    trace_bytes = trials * params.ticks * n_robots * 8 * (len(TRACE_NAMES) + 4)
    if trace and trace_bytes > TRACE_MAX_BYTES:
        raise ValueError(f"trace of {trials} trials x {params.ticks} ticks x {n_robots} robots "
                         f"needs {trace_bytes / 1e9:.1f} GB; at most {TRACE_MAX_BYTES / 1e9:g} GB "
                         f"is allowed: trace fewer trials or ticks")
    supervisors = dict(supervisors or {})
    worker_file = "worker-with-mobile-charger" if params.mobile else "worker"
    worker = supervisors.get("worker") or _default_supervisor(worker_file)
    charger = None
    if params.mobile:
        charger = supervisors.get("charger") or _default_supervisor("charger")
    for automaton in (worker, charger):
        if automaton is not None and not isinstance(automaton, Automaton):
            raise TypeError(f"supervisors must be Automaton objects, got {type(automaton)!r}")
    tables, n_sup, init, unc, ctrl, n_unc, n_ctrl = _role_tables((worker, charger))

    seeds = trial_seeds(trials, first_trial)
    rates = np.array([V_MIN, V_MOVE, params.v_work, params.v_charge, params.transfer_loss,
                      params.worker_capacity, params.charger_capacity], dtype=np.float64)
    (points, consumed, work_energy, shared, lost, depleted, battery, drawn, paid, given,
     received, series, trace_arrays, track_arrays) = interrupt.call(
        kernel.run_trials, rates, params.n_workers, params.n_chargers, params.ticks, params.sample_every,
        params.mobile, wheel_noise, tables, n_sup, init, unc, n_unc, ctrl, n_ctrl,
        _mc_rank(params.n_chargers), spawn_states(seeds, kernel.N_STREAMS), trace, track)

    nw = params.n_workers
    total = consumed.sum(axis=1)
    work_total = work_energy.sum(axis=1)
    out = {
        "trial": np.arange(first_trial, first_trial + trials, dtype=np.int64),
        "seed": seeds,
        "work": points,
        "energy": total,
        "work_energy": work_total,
        "efficiency": work_total / total,
        "efficiency_with_loss": work_total / (total + lost),
        "depleted_workers": depleted[:, :nw].sum(axis=1),
        "depleted_chargers": depleted[:, nw:].sum(axis=1),
        "shared": shared,
        "lost": lost,
        "consumed": consumed,
        "robot_work_energy": work_energy,
        "battery": battery,
        "drawn": drawn,
        "paid": paid,
        "given": given,
        "received": received,
        "depleted": depleted,
        "series_tick": np.arange(series.shape[1], dtype=np.int64) * params.sample_every,
        "series": series,
    }
    if trace:
        out["trace"] = dict(zip(TRACE_NAMES, trace_arrays))
    if track:
        out["track"] = dict(zip(("x", "y", "energy", "phase"), track_arrays))
    return out


def summary_columns() -> tuple[str, ...]:
    """Names of the per-trial (one row per trial) entries of :func:`simulate`'s result."""
    return ("trial", "seed", "work", "energy", "work_energy", "efficiency",
            "efficiency_with_loss", "depleted_workers", "depleted_chargers", "shared", "lost")
