"""Parameters of the energy-replenishment model (docs/replenishment-model.md section 2).

A plain frozen dataclass with the spec's defaults and one :meth:`Params.validate`
that checks every field and every rule between fields; kernels never re-check.
Rates are per tick (1 tick = 0.1 s), energies in the spec's abstract units.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

from ..config import ConfigError, _show

__all__ = ["Params", "ParamsError", "STRATEGIES", "BASE_CAPACITY", "UPPER_LIMITS", "RUN_LIMITS", "run_size"]

STRATEGIES = ("fixed", "mobile")

# Robots that certainly fit in the base without overlap: placement centres lie in
# [-0.765, -0.5] x [-0.765, 0.765] (disc radius 0.035 m inside the walls), and a
# square grid of 7 cm cells holds 4 x 22 of them there. More robots than this
# would make the placement overlap by construction.
BASE_CAPACITY = 4 * 22

#: Highest value of each number, from its meaning (lowest values: see :meth:`Params.validate`;
#: n_workers + n_chargers <= BASE_CAPACITY, transfer_loss < 1): each keeps the bounds
#: (:mod:`dronefleet.replenishment.bounds`) and every energy, duration and sum of a run finite.
UPPER_LIMITS: dict[str, tuple[float, str]] = {
    "trials": (100_000, "trials of one run, each seeded and set up apart; a sweep's seeds add runs"),
    "ticks": (100_000_000, "1e7 s, about four months"),
    "sample_every": (100_000_000, "the longest trial; a longer period samples tick 0 only"),
    "worker_capacity": (1e6, "energy units: 10,000 times the spec's battery, 2e8 ticks of idling at v_min"),
    "charger_capacity_factor": (1e3, "a mobile charger holding 1,000 worker batteries"),
    "work_ratio": (1e3, "v_work = 100 per tick: the spec's battery spent working in one tick"),
    "charge_rate": (1e3, "v_charge = 1,000 per tick: the spec's battery filled in a tenth of a tick"),
}

#: What one trial costs besides its ticks, in robot-ticks of the kernel (~0.1-0.3 us each):
#: seeding its random streams (a SeedSequence spawn, ~150 us) and setting up its robots.
TRIAL_SETUP_ROBOT_TICKS = 1_000
#: Memory a run holds [bytes]: per trial (seeds, streams, summary row), per robot of a trial (the
#: kernel's ~35 per-robot arrays and the per-robot results) and per time-series row (the series
#: array and its table), from the peak memory of measured runs, rounded up.
TRIAL_BYTES, ROBOT_BYTES, SAMPLE_BYTES = 400, 320, 200

#: Limits on the size of a run (all its trials), checked by :meth:`Params.validate` before any
#: work (see :func:`run_size`), each counting all the work, per trial too: the paper's largest
#: grid point (50 trials x 6000 ticks x 18 robots) is 5.4e6 robot-ticks and 7 MB.
RUN_LIMITS: dict[str, float] = {
    "robot_ticks": 1e9,   # trials x (ticks x robots + TRIAL_SETUP_ROBOT_TICKS): minutes, never hours
    "bytes": 2e9,         # trials x (TRIAL_BYTES + robots x ROBOT_BYTES + samples x SAMPLE_BYTES)
}


def run_size(params: Params) -> dict[str, int]:
    """The size of a run of ``params`` as :data:`RUN_LIMITS` counts it: ``robot_ticks`` (the
    kernel's work, each trial's set-up counted as TRIAL_SETUP_ROBOT_TICKS) and ``bytes`` (memory)."""
    robots = params.n_workers + params.n_chargers
    samples = params.ticks // params.sample_every + 1
    return {"robot_ticks": params.trials * (params.ticks * robots + TRIAL_SETUP_ROBOT_TICKS),
            "bytes": params.trials * (TRIAL_BYTES + robots * ROBOT_BYTES + samples * SAMPLE_BYTES)}


# Fixed physical constants of the model (section 2), not parameters.
V_MIN = 0.005           # idle cost, every robot, every tick
V_MOVE = 0.1            # moving cost per tick
V_WORK_PER_R = 0.1      # v_work = 0.1 r
V_CHARGE_PER_K = 1.0    # v_charge = 1.0 k
V_MAX_CM_S = 12.0       # max wheel speed [cm/s]


class ParamsError(ConfigError):
    """A replenishment parameter outside its allowed range (one-line message)."""


@dataclass(frozen=True)
class Params:
    """One configuration of the replenishment model.

    Attributes
    ----------
    strategy : {"fixed", "mobile"}
        ``"fixed"``: chargers in the base (n_chargers must be 0); ``"mobile"``:
        mobile chargers carry energy to the transfer area (n_chargers >= 1).
    n_workers : int
        Workers n_w (>= 1).
    n_chargers : int
        Mobile chargers n_m (0 for fixed, >= 1 for mobile).
    charger_capacity_factor : float
        phi; MC capacity c_m = phi * c_w (> 0; unused when fixed).
    work_ratio : float
        r; v_work = 0.1 r energy units per tick (> 0).
    charge_rate : float
        k; v_charge = 1.0 k energy units per tick, base charging and MC->worker
        transfer rate (> 0).
    transfer_loss : float
        lambda in [0, 1); the worker receives (1 - lambda) of what the MC gives.
    worker_capacity : float
        c_w, energy units (> 0).
    ticks : int
        T, ticks per trial (1 tick = 0.1 s; >= 1).
    trials : int
        Trials; trial k (1-based) uses seed 876 k (>= 1).
    sample_every : int
        Time-series sampling period in ticks (>= 1).
    """

    strategy: str = "fixed"
    n_workers: int = 6
    n_chargers: int = 0
    charger_capacity_factor: float = 2.0
    work_ratio: float = 1.0
    charge_rate: float = 1.0
    transfer_loss: float = 0.0
    worker_capacity: float = 100.0
    ticks: int = 6000
    trials: int = 50
    sample_every: int = 10

    # derived rates (per tick)
    @property
    def v_work(self) -> float:
        return V_WORK_PER_R * self.work_ratio

    @property
    def v_charge(self) -> float:
        return V_CHARGE_PER_K * self.charge_rate

    @property
    def charger_capacity(self) -> float:
        """c_m = phi c_w (energy units)."""
        return self.charger_capacity_factor * self.worker_capacity

    @property
    def mobile(self) -> bool:
        return self.strategy == "mobile"

    def replace(self, **changes: Any) -> Params:
        """A validated copy with ``changes`` applied."""
        return dataclasses.replace(self, **changes).validate()

    def validate(self) -> Params:
        """Check every field and the rules between them; return self.

        Raises
        ------
        ParamsError
            Naming the parameter, its value and what is allowed.
        """
        def fail(name, value, allowed):
            raise ParamsError(f"{name} = {_show(value)} is not allowed: {allowed}", (name,))

        if self.strategy not in STRATEGIES:
            fail("strategy", self.strategy, 'use "fixed" or "mobile"')
        for name in ("n_workers", "n_chargers", "ticks", "trials", "sample_every"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int):
                fail(name, value, "must be an integer")
        for name in ("charger_capacity_factor", "work_ratio", "charge_rate",
                     "transfer_loss", "worker_capacity"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) \
                    or not math.isfinite(value):
                fail(name, value, "must be a finite number")
        if self.n_workers < 1:
            fail("n_workers", self.n_workers, "need at least 1 worker")
        if self.strategy == "fixed" and self.n_chargers != 0:
            fail("n_chargers", self.n_chargers, 'must be 0 with strategy "fixed" '
                 '(its chargers are the base)')
        if self.strategy == "mobile" and self.n_chargers < 1:
            fail("n_chargers", self.n_chargers, 'must be >= 1 with strategy "mobile"')
        if self.n_workers + self.n_chargers > BASE_CAPACITY:
            raise ParamsError(
                f"n_workers + n_chargers = {self.n_workers + self.n_chargers} robots do not "
                f"fit in the base: at most {BASE_CAPACITY} (4 x 22 discs of 7 cm)",
                ("n_workers", "n_chargers"))
        if self.charger_capacity_factor <= 0:
            fail("charger_capacity_factor", self.charger_capacity_factor, "must be > 0")
        if self.work_ratio <= 0:
            fail("work_ratio", self.work_ratio, "must be > 0")
        if self.charge_rate <= 0:
            fail("charge_rate", self.charge_rate, "must be > 0")
        if not 0.0 <= self.transfer_loss < 1.0:
            fail("transfer_loss", self.transfer_loss, "must be in [0, 1)")
        if self.worker_capacity <= 0:
            fail("worker_capacity", self.worker_capacity, "must be > 0")
        if self.ticks < 1:
            fail("ticks", self.ticks, "must be >= 1")
        if self.trials < 1:
            fail("trials", self.trials, "must be >= 1")
        if self.sample_every < 1:
            fail("sample_every", self.sample_every, "must be >= 1")
        for name, (highest, meaning) in UPPER_LIMITS.items():
            if getattr(self, name) > highest:
                fail(name, getattr(self, name), f"must be <= {highest:g} ({meaning})")
        size = run_size(self)
        robots = self.n_workers + self.n_chargers
        if size["robot_ticks"] > RUN_LIMITS["robot_ticks"]:
            raise ParamsError(
                f"the run would take ~{size['robot_ticks']:.3g} robot-ticks (trials {self.trials} x (ticks "
                f"{self.ticks} x {robots} robots + {TRIAL_SETUP_ROBOT_TICKS:,} per trial's set-up)); at most "
                f"{RUN_LIMITS['robot_ticks']:g}: lower trials or ticks", ("trials", "ticks"))
        if size["bytes"] > RUN_LIMITS["bytes"]:
            raise ParamsError(
                f"the run would hold ~{size['bytes'] / 1e9:.3g} GB (trials {self.trials} x ({TRIAL_BYTES} B + "
                f"{robots} robots x {ROBOT_BYTES} B + {self.ticks // self.sample_every + 1} time-series rows x "
                f"{SAMPLE_BYTES} B)); at most {RUN_LIMITS['bytes'] / 1e9:g} GB: raise sample_every or lower "
                "trials or ticks", ("trials", "ticks", "sample_every"))
        return self
