"""One run: build the state from a config and a seed, drive the compiled engine, collect records.

Randomness comes from four separate streams spawned from the run's seed, in this
order: orders, SoH, learners (one child per UAV), random bids. Each stream is
consumed in a way that does not depend on the horizon, so a shorter run is exactly
the beginning of a longer one with the same seed.

A run can start from a saved fleet (``config.fleet_file``, see :mod:`dronefleet.delivery.fleet`)
instead of a new one: its operating period is then the saved fleet's plus one, and
its streams come from (seed, period), so a second period sees fresh orders even
with the seed of the first.
"""

import functools
import math
import os
import traceback
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from . import engine
from .. import interrupt
from .auction import BIDS_ON, PLUGIN, RULES, PluginError, plugin_name, resolve_rule
from .config import SECONDS_PER_WEEK, Config
from .energy import charge_rate, config_power, drain_per_watt
from .fleet import SavedFleet, load_fleet
from .orders import Orders, generate_orders
from .policy import initial_fit, optimal_init, standardise
from .result import RunResult
from ..supervisor import BUILTIN_CONTROLLER, SupervisorError, load_supervisor


@dataclass
class RunState:
    """Everything the engine reads and writes for one run (arrays, updated in place)."""

    book: engine.OrderBook
    fleet: engine.Fleet
    attempts: engine.Attempts
    series: engine.Series
    counters: np.ndarray
    params: engine.Params
    table: np.ndarray
    bid_rng: np.random.Generator
    mass_kg: np.ndarray
    period: int
    max_attempts: int       # rows the attempt table may grow to (attempt_limit)
    rule_kernel: object = None  # a plugin rule's compiled function; None for a built-in rule


class InvalidStateError(RuntimeError):
    """The engine met a state no event fits (non-finite input slipped through validation)."""


class RunTooLargeError(RuntimeError):
    """The run made far more delivery attempts than it has orders (see :func:`attempt_limit`)."""


def attempt_limit(config: Config) -> int:
    """Most delivery attempts a run of ``config`` may make: max(200000, 4 x expected orders).

    A sound run makes about 1.3 attempts per order (the paper's: ~7,000); only degenerate
    configs (UAVs that take off with an empty battery, abort at once and bid again at the next
    tick) come near the bound, and they would otherwise fill memory for minutes.
    """
    return max(200_000, 4 * math.ceil(config.horizon_s / config.tau_s))


#: First element of the spawn key of the streams of periods after the first (an unused child).
PERIOD_STREAMS = 1000


def run_seed_sequence(seed: int, period: int = 1) -> np.random.SeedSequence:
    """The root of a run's random streams: the seed's, or for a later period a child of it."""
    if period == 1:
        return np.random.SeedSequence(seed)
    return np.random.SeedSequence(seed, spawn_key=(PERIOD_STREAMS, period))


def _streams(seed, n_uavs, period):
    orders, soh, learners, bids = run_seed_sequence(seed, period).spawn(4)
    return (np.random.default_rng(orders), np.random.default_rng(soh),
            [np.random.default_rng(s) for s in learners.spawn(n_uavs)], np.random.default_rng(bids))


def initial_state(config: Config, supervisor: str | os.PathLike | None = None, orders: Orders | None = None,
                  soh: np.ndarray | Sequence[float] | None = None, fleet: SavedFleet | None = None) -> RunState:
    """The state at t = 0: an empty queue, orders to come, and the fleet at the FC.

    A new fleet has drawn SoH, fitted initial policies and full batteries. ``fleet`` (a
    :class:`~dronefleet.delivery.fleet.SavedFleet`; default: ``config.fleet_file`` if set) gives
    SoH, policies, step counters and SoC instead; its lost UAVs stay lost.
    ``supervisor`` is a path to a Nadzoru 2 file (default: the packaged UAV controller).
    ``orders`` (an :class:`~dronefleet.delivery.orders.Orders`) and ``soh`` ((n_uavs,) array) replace
    the drawn ones, for hand-made scenarios; the streams are split the same way regardless.
    """
    if fleet is None and config.fleet_file:
        fleet = load_fleet(config.fleet_file, config)
    period = 1 if fleet is None else fleet.period + 1
    order_rng, soh_rng, learner_rngs, bid_rng = _streams(config.seed, config.n_uavs, period)
    orders = generate_orders(config, order_rng) if orders is None else orders
    n, s = orders.arrival_s.shape[0], config.n_uavs
    mean, std = np.array(config.scaler_mean), np.array(config.scaler_std)
    if fleet is None:
        drawn_soh = soh_rng.uniform(config.soh_min, config.soh_max, config.n_uavs)
        coef, intercept, steps = initial_fit(
            s, mean, std, (config.distance_min_m, config.distance_max_m),
            (config.mass_min_kg, config.mass_max_kg), config.alpha, config.initial_epochs, learner_rngs)
        soc, lost = np.full(s, 100.0), np.zeros(s, np.bool_)
    else:
        drawn_soh, coef, intercept, steps = fleet.soh, fleet.coef.copy(), fleet.intercept.copy(), fleet.steps.copy()
        soc, lost = np.where(fleet.lost, 0.0, fleet.soc), fleet.lost
    soh = drawn_soh if soh is None else np.asarray(soh, dtype=np.float64)
    features = standardise(np.column_stack([orders.distance_m, orders.mass_kg, np.zeros(n)]), mean, std)

    rule = resolve_rule(config.rule)
    automaton = _packaged_supervisor(BUILTIN_CONTROLLER) if supervisor is None else load_supervisor(supervisor)
    table = automaton.transition_table(engine.EVENT_NAMES)
    bids_on = BIDS_ON[rule.bids_on]
    idle = automaton.init_state
    supervisors = np.arange(idle.shape[0])
    quiet = bool(np.all(table[supervisors, idle, engine.EV_NOT_CAPABLE] == idle))
    capable = table[supervisors, idle, engine.EV_CAPABLE]
    bidding = np.where(capable >= 0, table[supervisors, capable, engine.EV_BID], -1)
    bid_silent = bool(np.all((bidding >= 0) & (table[supervisors, bidding, engine.EV_LOST_BID] == idle)))
    if not quiet:
        # Skipped ticks do not step notCapableTask; that is exact only if it is a self-loop.
        bids_on = BIDS_ON["any"]

    book = engine.OrderBook(
        arrival_s=orders.arrival_s, distance_m=orders.distance_m,
        x_distance=np.ascontiguousarray(features[:, 0]), x_mass=np.ascontiguousarray(features[:, 1]),
        power_w=config_power(config, orders.mass_kg), attempts=np.zeros(n, np.int32),
        delivered_s=np.full(n, np.nan), queue_tree=np.zeros(n + 1, np.int64),
        queue_next=np.full(n, -1, np.int64), queued_x=np.zeros((2, n)), queued_ids=np.zeros(n, np.int64),
        queued_pos=np.zeros(n, np.int64))
    idle_ids = np.argsort(lost, kind="stable").astype(np.int64)  # the idle UAVs first (the lost ones after)
    fleet = engine.Fleet(
        soh=soh, drain=drain_per_watt(config.capacity_wh, soh), coef=coef, intercept=intercept, steps=steps,
        mode=np.where(lost, engine.LOST, engine.IDLE).astype(np.int8),
        sup=np.tile(automaton.init_state.astype(np.int64), (s, 1)), quiet=np.full(s, quiet),
        bid_silent=np.full(s, bid_silent),
        next_s=np.full(s, np.inf), event_heap=np.arange(s, dtype=np.int64),
        heap_pos=np.arange(s, dtype=np.int64), soc_ref=soc.astype(np.float64), t_ref=np.zeros(s),
        order=np.full(s, -1, np.int64), attempt=np.full(s, -1, np.int64),
        takeoff_s=np.zeros(s), takeoff_soc=np.zeros(s), rate_out=np.zeros(s), turn_s=np.zeros(s),
        turn_soc=np.zeros(s), rate_home=np.zeros(s), home_s=np.zeros(s), land_soc=np.zeros(s),
        delivers=np.zeros(s, np.bool_), lost=np.zeros(s, np.bool_), allocated_s=np.zeros(s),
        forecast_wait_s=np.full(s, np.nan), bidding=np.zeros(s, np.int8),
        reach=np.full(s, -np.inf), reach_stale=np.zeros(s, np.bool_), idle_ids=idle_ids,
        idle_pos=np.argsort(idle_ids).astype(np.int64), scan_terms=np.zeros((engine.N_SCAN_ROWS, s)),
        scan_epoch=np.full(2, np.nan),
        bid_ids=np.zeros(s, np.int64),
        # base time 0, where every UAV's t_ref is: e^0 = 1
        charge_a=100.0 - soc.astype(np.float64), charge_base=np.zeros(1))
    n_samples = int(math.floor(config.horizon_s / config.record_interval_s)) + 1
    series = engine.Series(*(np.zeros(n_samples, np.int64) for _ in engine.Series._fields))
    counters = np.zeros(engine.N_COUNTERS, np.int64)
    counters[engine.LAST_ADVERTISED] = -1
    counters[engine.N_IDLE] = s - int(lost.sum())
    counters[engine.N_LOST] = int(lost.sum())
    params = engine.Params(
        speed_m_s=config.speed_m_s, xi=config.xi,
        charge_rate=charge_rate(config.capacity_wh, config.charger_power_w, config.charger_efficiency),
        power_empty_w=float(config_power(config, 0.0)), alpha=config.alpha, t0=optimal_init(config.alpha),
        soc_mean=mean[2], soc_std=std[2], theta=config.theta,
        advert_interval_s=config.advert_interval_s, record_interval_s=config.record_interval_s,
        rule=RULES[config.base_rule].code if rule.reserves else rule.code, bids_on=bids_on,
        reserves=rule.reserves)
    return RunState(book, fleet, _attempt_table(max(64, n)), series, counters, params, table,
                    bid_rng, orders.mass_kg, period, max(attempt_limit(config), 64, n),
                    rule.kernel if rule.code == PLUGIN else None)


@functools.lru_cache(maxsize=1)
def _packaged_supervisor(path):
    """The packaged controller at ``path``, read and validated once per process, not once per run
    (3 ms of a sweep worker's every run); only read from, like any automaton."""
    return load_supervisor(path)


def _attempt_table(capacity, old=None):
    """An empty attempt table of ``capacity`` rows, holding the rows of ``old`` if given."""
    new = engine.Attempts(
        uav=np.zeros(capacity, np.int32), order=np.zeros(capacity, np.int64),
        takeoff_s=np.zeros(capacity), takeoff_soc=np.zeros(capacity), allocated_s=np.zeros(capacity),
        forecast_wait_s=np.full(capacity, np.nan), outcome=np.zeros(capacity, np.int8),
        turn_s=np.full(capacity, np.nan), return_s=np.full(capacity, np.nan), return_soc=np.full(capacity, np.nan),
        lost=np.zeros(capacity, np.bool_))
    if old is not None:
        for field, column in zip(new, old):
            field[:column.shape[0]] = column
    return new


def advance(state: RunState, t_stop: float) -> None:
    """Run the engine over every event at or before ``t_stop``, growing the attempt table as needed.

    Raises SupervisorError if the supervisor refuses an event, InvalidStateError if the state
    has no valid next event (non-finite inputs), PluginError if a plugin rule raises or scores
    a bid NaN or infinite, KeyboardInterrupt on Ctrl-C (the engine stops at its next event).
    """
    while True:
        args = (state.book, state.fleet, state.attempts, state.series, state.counters,
                state.params, state.table, state.bid_rng, t_stop)
        if state.rule_kernel is None:
            status = interrupt.call(engine.advance, *args, None)
        else:
            status = _advance_plugin(state, args)
        if status == engine.DONE:
            return
        if status == engine.ATTEMPTS_FULL:
            capacity = state.attempts.uav.shape[0]
            if capacity >= state.max_attempts:
                raise RunTooLargeError(
                    f"the run made more than {capacity} delivery attempts by t = {t_stop:.0f} s "
                    f"(at most max(200000, 4 x expected orders) = {state.max_attempts} allowed): a degenerate "
                    "config, e.g. a threshold so low that UAVs with an empty battery keep taking off")
            state.attempts = _attempt_table(min(2 * capacity, state.max_attempts), state.attempts)
            continue
        if status == engine.BAD_SCORE:
            t = state.counters[engine.NEXT_TICK] * state.params.advert_interval_s
            raise PluginError(f"the winner rule {plugin_name(state.rule_kernel)!r} scored the bid of UAV "
                              f"{state.counters[engine.REFUSED_UAV]} at t = {t:g} s NaN or infinite; "
                              "a rule's score must be a finite number")
        if status == engine.INVALID_STATE:
            bad = np.flatnonzero(np.isnan(state.fleet.next_s)).tolist()
            raise InvalidStateError(
                "the engine stopped in an invalid state before t = "
                f"{t_stop:g} s ({'NaN event times of UAV(s) ' + str(bad) if bad else 'no event fits the state'}); "
                "inputs must be finite (SoH in (0, 1], SoC in [0, 100], finite policies)")
        i = int(state.counters[engine.REFUSED_UAV])
        event = engine.EVENT_NAMES[state.counters[engine.REFUSED_EVENT]]
        raise SupervisorError(
            f"the supervisor does not allow event {event!r} for UAV {i} in local state(s) "
            f"{state.fleet.sup[i].tolist()}; the engine stopped before taking it")


def _advance_plugin(state, args):
    """``engine.advance`` with the plugin rule of ``state``; what the plugin raises is a PluginError.

    The engine itself reports its failures as statuses: an exception comes from the plugin.
    """
    name = plugin_name(state.rule_kernel)
    try:
        return interrupt.call(engine.advance, *args, state.rule_kernel, argtypes=engine.plugin_argtypes(args),
                              culprit=f"the winner rule {name!r}")
    except Exception as error:
        frame = traceback.extract_tb(error.__traceback__)[-1]
        message = " ".join(str(error).split())  # one line
        raise PluginError(f"the winner rule {name!r} raised {type(error).__name__}: {message} "
                          f"({Path(frame.filename).name}, line {frame.lineno})") from None


def snapshot(state: RunState, t: float) -> dict[str, Any]:
    """The fleet at time ``t``: SoH, policy, learner step counter, SoC, lost flag (arrays of shape (S,))."""
    fleet = state.fleet
    soc = np.array([engine.soc_at(fleet, i, t, state.params.charge_rate) for i in range(fleet.soh.shape[0])])
    return dict(t_s=t, soh=fleet.soh.copy(), coef=fleet.coef.copy(), intercept=fleet.intercept.copy(),
                steps=fleet.steps.copy(), soc=soc, lost=fleet.mode == engine.LOST)


def stops(horizon_s: float) -> list[float]:
    """Week ends up to the horizon, and the horizon itself: where a run pauses to take a snapshot."""
    weeks = np.arange(1, int(horizon_s // SECONDS_PER_WEEK) + 1) * SECONDS_PER_WEEK
    return [float(w) for w in weeks if w < horizon_s] + [float(horizon_s)]


def simulate(config: Config, supervisor: str | os.PathLike | None = None,
             progress: Callable[[float], object] | None = None, orders: Orders | None = None,
             soh: np.ndarray | Sequence[float] | None = None, fleet: SavedFleet | None = None) -> RunResult:
    """Run the model of ``config`` (seed included) and return its :class:`RunResult`.

    ``progress(t_s)`` is called at every week end if given; ``supervisor``, ``orders``,
    ``soh`` and ``fleet`` as in :func:`initial_state`.
    """
    state = initial_state(config, supervisor, orders, soh, fleet)
    snapshots = []
    for t in stops(config.horizon_s):
        advance(state, t)
        snapshots.append(snapshot(state, t))
        if progress is not None:
            progress(t)
    return collect(state, snapshots, config)


def collect(state: RunState, snapshots: list[dict[str, Any]], config: Config) -> RunResult:
    """Turn the final state into a :class:`RunResult` (copies of the valid rows)."""
    book, n_attempts = state.book, int(state.counters[engine.N_ATTEMPTS])
    attempts = {name: column[:n_attempts].copy() for name, column in zip(engine.Attempts._fields, state.attempts)}
    orders = dict(arrival_s=book.arrival_s, distance_m=book.distance_m, mass_kg=state.mass_kg,
                  attempts=book.attempts, delivered_s=book.delivered_s)
    series = {name: column for name, column in zip(engine.Series._fields, state.series)}
    series["t_s"] = np.arange(state.series.delivered.shape[0]) * config.record_interval_s
    return RunResult(config, orders, attempts, snapshots, series, int(state.counters[engine.N_AUCTIONS]),
                     int(state.counters[engine.N_RESERVATIONS]), state.period)
