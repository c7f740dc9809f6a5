"""Shared helpers of the model tests: docs/delivery-model.md physics by hand, hand-made scenarios, forced policies.

Everything "expected" in the tests is computed from the formulas of docs/delivery-model.md here, in plain
Python, never with the engine's own functions.
"""

import math
from contextlib import contextmanager

import numpy as np
import pytest

from dronefleet.delivery import config as cfg
from dronefleet.delivery import auction, simulation
from dronefleet.delivery.orders import Orders

WEEK = 7 * 24 * 3600.0
DELTA = 2.0  # advertising period of docs/delivery-model.md section 4

# docs/delivery-model.md section 2, default parameters.
G, M_FRAME, M_BATTERY, N_ROTORS, ZETA, RHO = 9.81, 10.0, 10.0, 8, 0.27, 1.225
SPEED, CAPACITY, P_CHARGER, GAMMA = 10.0, 800.0, 100.0, 0.95
K = GAMMA * P_CHARGER / (3600.0 * CAPACITY)  # 1/s
MU = (3500.0, 2.75, 50.0)
SIGMA = (1443.38, 1.298, 28.87)


def power(payload_kg):
    """P(m_p) of docs/delivery-model.md section 2, W."""
    return (G * (M_FRAME + M_BATTERY + payload_kg)) ** 1.5 / math.sqrt(2.0 * N_ROTORS * RHO * ZETA)


def rate(payload_kg, soh=1.0):
    """SoC drain in flight, percent per second."""
    return 100.0 * power(payload_kg) / (3600.0 * CAPACITY * soh)


def charged(soc0, seconds):
    """Closed form of the charging curve."""
    return 100.0 - (100.0 - soc0) * math.exp(-K * seconds)


def next_grid(t):
    """First advertising instant at or after ``t``."""
    return math.ceil(t / DELTA) * DELTA


def x_std(d, m, soc):
    return ((d - MU[0]) / SIGMA[0], (m - MU[1]) / SIGMA[1], (soc - MU[2]) / SIGMA[2])


# Forced policies (coef on standardised [d, m, SoC], intercept). The weights are not zero so
# that ||w|| > 0; the intercept is large enough that a few learning steps cannot flip the sign.
ALWAYS = ((0.0, 0.0, 1.0), 1e3)     # bids on everything; f = 1000 + x_soc
NEVER = ((0.0, 0.0, 1.0), -1e3)     # never bids
SHORT_ONLY = ((-1.0, 0.0, 0.0), 0.0)  # bids iff d < 3500 m (f = -x_distance)


def scenario_config(n_uavs=1, horizon_s=3600.0, **changes):
    return cfg.replace(cfg.default_config(), n_uavs=n_uavs, horizon_weeks=horizon_s / WEEK, **changes)


def scenario(config, arrival, distance, mass, soh=None, policies=None, soc=None):
    """Initial state of a hand-made scenario.

    ``policies``: one (coef, intercept) per UAV (or one for all), ``soc``: SoC at t = 0 per UAV.
    """
    orders = Orders(np.asarray(arrival, dtype=np.float64), np.asarray(distance, dtype=np.float64),
                    np.asarray(mass, dtype=np.float64))
    n = config.n_uavs
    soh = np.ones(n) if soh is None else np.asarray(soh, dtype=np.float64)
    state = simulation.initial_state(config, orders=orders, soh=soh)
    if policies is not None:
        if isinstance(policies[1], (int, float)):
            policies = [policies] * n
        for i, (coef, intercept) in enumerate(policies):
            state.fleet.coef[i] = coef
            state.fleet.intercept[i] = intercept
    if soc is not None:
        state.fleet.soc_ref[:] = soc
    return state


def run_state(state, config, t_stop=None):
    """Advance to ``t_stop`` (default: the horizon, with weekly snapshots) and collect the result."""
    snapshots = []
    stops = simulation.stops(config.horizon_s) if t_stop is None else [t_stop]
    for t in stops:
        simulation.advance(state, t)
        snapshots.append(simulation.snapshot(state, t))
    return simulation.collect(state, snapshots, config)


def attempts_list(result):
    """Attempts as a list of dicts (plain Python values)."""
    a = result.attempts
    return [{k: a[k][r].item() for k in a} for r in range(a["uav"].shape[0])]


@pytest.fixture(scope="module")
def every_tick_rules():
    """A copy of every built-in rule registered with bids_on="any" (no tick skip), removed after."""
    names = {}
    for name in ("least_confident", "most_confident", "random", "threshold", "reservation"):
        copy = name + "_every_tick"
        # The same rule with bids_on = "any": the engine evaluates every tick.
        auction.RULES[copy] = auction.RULES[name]._replace(bids_on="any")
        names[name] = copy
    yield names
    for copy in names.values():
        auction.RULES.pop(copy, None)


# A tiny sweep of each registered scenario (a new scenario must add one): 4 runs, 2 per task.
TINY_SWEEPS = {
    "delivery": """
[sweep]
name = "tiny"
seeds = [0, 1]
runs_per_task = 2
[set]
horizon_weeks = 0.02
n_uavs = 3
[grid]
rule = ["least_confident", "random"]
""",
    "replenishment": """
[sweep]
name = "tiny"
scenario = "replenishment"
runs_per_task = 2
[set]
trials = 2
ticks = 200
[[grid]]
strategy = ["fixed"]
n_chargers = [0]
[[grid]]
strategy = ["mobile"]
n_chargers = [1, 2, 3]
""",
    "items": """
[sweep]
name = "tiny"
scenario = "items"
runs_per_task = 2
[set]
trials = 2
steps = 50
[grid]
algorithm = ["R", "GR"]
capacity = [2, 10]
""",
    "lunar": """
[sweep]
name = "tiny"
scenario = "lunar"
runs_per_task = 2
[set]
runs = 2
n_robots = 30
duration_s = 60.0
[grid]
layout = ["OPEN", "SOFT-RT"]
los_bodies = [false, true]
""",
}


@pytest.fixture
def drawn_figures(monkeypatch):
    """``keep(module)``: from then on, every figure drawn by ``module``'s functions (through its
    ``_figure``) is appended to the list ``keep`` returns."""
    def keep(module):
        kept = []
        original = module._figure

        @contextmanager
        def keeping(*args, **kwargs):
            with original(*args, **kwargs) as (mpl, fig, axes):
                kept.append(fig)
                yield mpl, fig, axes

        monkeypatch.setattr(module, "_figure", keeping)
        return kept
    return keep


class Counted:
    """A value that counts the comparisons made with it: all share few hashes, each equals only
    itself (how the repeat checks of grid values are shown to compare no pair needlessly)."""

    comparisons = 0

    def __init__(self, n):
        self.n = n

    def __hash__(self):
        return self.n

    def __eq__(self, other):
        Counted.comparisons += 1
        return self is other
