"""Analytic upper bounds of work and efficiency (docs/replenishment-model.md section 9).

The paper's Eqs 1-3 in per-tick units: a fixed-charger bound (workers commute
1.0 m each way at full speed) and a constant-supply bound for the mobile
strategy (no commute; charging at (1 - lambda) v_charge). They are per worker
and do not depend on n_m or phi. Each function refuses parameters where its
bound does not exist (a worker that cannot gain energy while charging, or
cannot afford the commute) with :class:`BoundUndefinedError`.
"""

from __future__ import annotations

from dataclasses import dataclass

from ..config import ConfigError
from .params import V_MIN, V_MOVE, V_MAX_CM_S, Params

__all__ = ["BoundUndefinedError", "Bounds", "COMMUTE_TICKS", "fixed_bounds", "fixed_work_ceiling",
           "constant_supply_bounds", "bounds"]

# D_c: 1.0 m (x = -0.5 to 0.5) at v_max = 0.012 m/tick.
COMMUTE_TICKS = 1.0 / (V_MAX_CM_S / 100.0 * 0.1)


class BoundUndefinedError(ConfigError):
    """The analytic bound does not exist for these parameters."""


@dataclass(frozen=True)
class Bounds:
    """Upper bounds for one configuration (work in points, efficiency a ratio).

    ``duty`` is D_work / D_cycle (fixed) or D_work,cs / (D_work,cs + D_charge,cs);
    ``d_charge``, ``d_work`` and ``d_cycle`` are those durations [ticks] (for the
    constant supply, d_cycle = D_work,cs + D_charge,cs: no commute).
    """

    work: float
    efficiency: float
    duty: float
    d_charge: float
    d_work: float
    d_cycle: float


def fixed_bounds(params: Params) -> Bounds:
    """W_fix and E_fix (Eqs 1-3) for fixed chargers in the base.

    Raises
    ------
    BoundUndefinedError
        If v_charge <= v_min (charging never fills) or c_w <= 2 (v_min + v_move) D_c
        (a full battery cannot pay for the round trip).
    """
    c_w, v_charge, v_work = params.worker_capacity, params.v_charge, params.v_work
    if v_charge <= V_MIN:
        raise BoundUndefinedError(
            f"no fixed-charger bound for charge_rate = {params.charge_rate!r}: "
            f"v_charge = {v_charge:g} must exceed v_min = {V_MIN:g}", ("charge_rate",))
    commute_cost = 2.0 * (V_MIN + V_MOVE) * COMMUTE_TICKS
    if c_w <= commute_cost:
        raise BoundUndefinedError(
            f"no fixed-charger bound for worker_capacity = {c_w!r}: it must exceed the "
            f"round-trip cost 2 (v_min + v_move) D_c = {commute_cost:g}", ("worker_capacity",))
    d_charge = c_w / (v_charge - V_MIN)
    d_work = (c_w - commute_cost) / (V_MIN + v_work)
    d_cycle = d_work + 2.0 * COMMUTE_TICKS + d_charge
    duty = d_work / d_cycle
    work = params.n_workers * duty * params.ticks
    efficiency = 1.0 - d_cycle * V_MIN / c_w - 2.0 * COMMUTE_TICKS * V_MOVE / c_w
    return Bounds(work=work, efficiency=efficiency, duty=duty, d_charge=d_charge, d_work=d_work,
                  d_cycle=d_cycle)


def fixed_work_ceiling(params: Params) -> float:
    """A strict ceiling of a fixed-charger trial's work within its T ticks [points].

    W_fix is per cycle, exact only for a whole number of cycles in T: workers that start full
    and leave the charger before 100 % can fit a partial work period more (at k = 0.1, 2.99
    cycles in T, simulated means reach 100.2 % of W_fix). This ceiling holds for any behaviour:
    each worker starts full in the base, makes n work periods (2 n - 1 commutes of D_c, the last
    one not coming back), charges whenever it is home, and spends its time and energy on
    nothing else; for each n its work is capped by time and energy together and by the battery
    (D_work per period, the last one (c_w - (v_min + v_move) D_c) / (v_min + v_work)). The best
    n is where the battery cap (rising with n) meets the time-energy cap (falling with n).
    27,609 at the defaults, 16,600 at k = 0.1 (docs/replenishment-model.md section 9).

    Raises
    ------
    BoundUndefinedError
        Where :func:`fixed_bounds` does.
    """
    fixed = fixed_bounds(params)
    c_w, ticks = params.worker_capacity, params.ticks
    gain, spend = params.v_charge - V_MIN, V_MIN + params.v_work   # per tick charging, working
    commute_cost = (V_MIN + V_MOVE) * COMMUTE_TICKS
    last_period = (c_w - commute_cost) / spend

    def battery_cap(n: int) -> float:
        return (n - 1) * fixed.d_work + last_period

    def time_energy_cap(n: int) -> float:
        left = ticks - (2 * n - 1) * COMMUTE_TICKS          # ticks for working and charging
        spare = c_w - (2 * n - 1) * commute_cost            # energy for work without charging
        if left <= 0.0:
            return 0.0
        if spare >= spend * left:                           # time binds alone
            return left
        return max(0.0, (left + spare / gain) / (1.0 + spend / gain))

    low, high = 1, int(ticks / (2.0 * COMMUTE_TICKS)) + 2   # time_energy_cap(high) == 0
    while low < high:                                       # first n where the battery cap binds
        middle = (low + high) // 2
        if battery_cap(middle) >= time_energy_cap(middle):
            high = middle
        else:
            low = middle + 1
    best = max(min(battery_cap(n), time_energy_cap(n)) for n in (low - 1, low) if n >= 1)
    return params.n_workers * best


def constant_supply_bounds(params: Params) -> Bounds:
    """W_cs and E_cs: Eq 1 with D_c = 0 and charging at (1 - lambda) v_charge.

    E_cs = (c_w - v_min (D_work,cs + D_charge,cs)) / (c_w + lambda v_charge D_charge,cs): per
    cycle the charger hands over v_charge D_charge,cs, of which lambda v_charge D_charge,cs is
    lost, and the loss is counted in the denominator, as Fig 12's efficiency counts it (work
    energy / (total + lost)). Equal to (v_charge E* - v_min) / (v_charge - v_min), with E* =
    v_work / (v_min + v_work) (1 - lambda - v_min / v_charge) the strict long-run ceiling of
    the simulated ratio (the paper's form, a little below it; docs/replenishment-model.md
    section 9).

    Raises
    ------
    BoundUndefinedError
        If (1 - lambda) v_charge <= v_min (a worker never fills).
    """
    c_w, lam = params.worker_capacity, params.transfer_loss
    received = (1.0 - lam) * params.v_charge
    if received <= V_MIN:
        raise BoundUndefinedError(
            f"no constant-supply bound for charge_rate = {params.charge_rate!r}, "
            f"transfer_loss = {lam!r}: (1 - lambda) v_charge = {received:g} must exceed "
            f"v_min = {V_MIN:g}", ("charge_rate", "transfer_loss"))
    d_charge = c_w / (received - V_MIN)
    d_work = c_w / (V_MIN + params.v_work)
    duty = d_work / (d_work + d_charge)
    work = params.n_workers * params.ticks * duty
    efficiency = (c_w - V_MIN * (d_work + d_charge)) / (c_w + lam * params.v_charge * d_charge)
    return Bounds(work=work, efficiency=efficiency, duty=duty, d_charge=d_charge, d_work=d_work,
                  d_cycle=d_work + d_charge)


def bounds(params: Params) -> Bounds:
    """The bound that is the reference for ``params.strategy``."""
    return constant_supply_bounds(params) if params.mobile else fixed_bounds(params)
