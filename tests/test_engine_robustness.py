"""The compiled engine cannot hang, overflow its tick arithmetic or write out of bounds.

Inputs are validated at the entry points; these tests feed the kernels what validation must
refuse (NaN, absurd scales) and require a clean stop: a status and a Python exception.
"""

import math

import numpy as np
import pytest

from dronefleet.delivery import engine, simulation

from conftest import scenario, scenario_config


@pytest.mark.parametrize("t, interval", [
    (1e300, 1e-300), (1e20, 1e-6), (1.0, 1e-300), (np.inf, 1.0), (np.nan, 1.0),
    (engine.MAX_TICK, 1.0), (1e300, 5e-324)])
def test_tick_index_beyond_any_run_is_no_tick(t, interval):
    assert engine.first_tick_at_or_after(t, interval) == engine.NO_TICK


def test_tick_index_is_the_first_grid_instant_at_or_after():
    rng = np.random.default_rng(5)
    for t, interval in zip(np.exp(rng.uniform(-10, 40, 3000)), np.exp(rng.uniform(-10, 10, 3000))):
        if t / interval >= 2.0 ** 52:
            continue
        k = engine.first_tick_at_or_after(t, interval)
        assert k * interval >= t and (k == 0 or (k - 1) * interval < t), (t, interval)
    assert engine.first_tick_at_or_after(0.0, 2.0) == 0
    assert engine.first_tick_at_or_after(4.0, 2.0) == 2
    assert engine.first_tick_at_or_after(0.9, 0.3) == 4  # ceil(0.9 / 0.3) = 3, but 3 * 0.3 < 0.9 in float64


def test_a_vanishing_charger_ends():
    # --set charger_power_w=1e-300 hung for ever: the next bid lay 1e300 ticks away (int64 overflow).
    # The config now refuses such a charger; the kernel must end all the same, so the rate is set here.
    config = scenario_config(n_uavs=2, horizon_s=6 * 3600.0)
    state = scenario(config, arrival=np.arange(0.0, 3600.0 * 5, 600.0), distance=np.full(30, 3000.0),
                     mass=np.full(30, 2.0), soc=[30.0, 20.0])
    state.params = state.params._replace(charge_rate=1e-306)
    simulation.advance(state, config.horizon_s)
    # Nobody is keen enough to bid at 20-30 % and the charger needs 1e300 s to change that.
    assert state.counters[engine.NEXT_ORDER] == 30 and state.counters[engine.QUEUE_LEN] == 30
    assert state.counters[engine.NEXT_SAMPLE] == state.series.delivered.shape[0]


def test_nan_soh_stops_with_an_error_not_a_crash():
    # A NaN SoH makes every flight time NaN; the kernel used to write series[k] out of bounds.
    config = scenario_config(n_uavs=3, horizon_s=3600.0)
    state = scenario(config, arrival=[0.0, 10.0], distance=[2000.0, 2500.0], mass=[1.0, 2.0],
                     soh=[1.0, np.nan, 1.0], policies=((0.0, 0.0, 1.0), 1e3))
    series_before = [column.copy() for column in state.series]
    with pytest.raises(simulation.InvalidStateError, match="NaN event times of UAV"):
        simulation.advance(state, config.horizon_s)
    assert state.counters[engine.NEXT_SAMPLE] <= state.series.delivered.shape[0]
    # Only samples before the stop were written.
    written = state.counters[engine.NEXT_SAMPLE]
    for before, after in zip(series_before, state.series):
        assert np.array_equal(before[written:], after[written:])


def test_a_nan_event_time_returns_invalid_state_from_the_kernel():
    config = scenario_config(n_uavs=2, horizon_s=3600.0)
    state = scenario(config, arrival=[0.0], distance=[2000.0], mass=[1.0])
    state.counters[engine.NEXT_SAMPLE] = state.series.delivered.shape[0]  # every sample taken
    engine.schedule(state.fleet, 1, np.nan)  # next_s is kept in the event heap: set it through it
    status = engine.advance(state.book, state.fleet, state.attempts, state.series, state.counters,
                            state.params, state.table, state.bid_rng, math.inf, None, np.zeros(1, np.int8))
    assert status == engine.INVALID_STATE
