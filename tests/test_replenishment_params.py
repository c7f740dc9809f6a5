"""Replenishment parameters and analytic bounds (docs/replenishment-model.md sections 2 and 9)."""

import pytest

from dronefleet.config import ConfigError
from dronefleet.replenishment import (BoundUndefinedError, Params, ParamsError,
                                      constant_supply_bounds, fixed_bounds, fixed_work_ceiling)
from dronefleet.replenishment.params import BASE_CAPACITY


# ------------------------------------------------------------------ bounds


def test_bounds_at_the_defaults_are_the_values_the_spec_states():
    fixed = fixed_bounds(Params())
    assert fixed.duty == pytest.approx(0.74625, abs=5e-6)
    assert fixed.work == pytest.approx(26865, abs=0.5)
    assert fixed.efficiency == pytest.approx(0.7807, abs=5e-5)
    supply = constant_supply_bounds(Params(strategy="mobile", n_chargers=6))
    assert supply.work == pytest.approx(32564, abs=0.5)
    assert supply.efficiency == pytest.approx(0.9474, abs=5e-5)


def test_bounds_follow_the_rates():
    # doubling the work rate halves D_work; by hand from section 9 (D_c = 1 / 0.012)
    d_c = 1.0 / 0.012
    d_charge = 100.0 / (1.0 - 0.005)
    d_work = (100.0 - 2.0 * 0.105 * d_c) / (0.005 + 0.2)
    duty = d_work / (d_work + 2.0 * d_c + d_charge)
    assert fixed_bounds(Params(work_ratio=2.0)).work == pytest.approx(6 * 6000 * duty, rel=1e-12)
    # the loss lowers what the worker receives and counts as spent energy
    lossy = constant_supply_bounds(Params(strategy="mobile", n_chargers=6, transfer_loss=0.5))
    d_charge_cs = 100.0 / (0.5 - 0.005)
    d_work_cs = 100.0 / 0.105
    assert lossy.work == pytest.approx(6 * 6000 * d_work_cs / (d_work_cs + d_charge_cs), rel=1e-12)
    # the loss counts in the denominator, as Fig 12's efficiency counts it
    assert lossy.efficiency == pytest.approx(
        (100.0 - 0.005 * (d_work_cs + d_charge_cs)) / (100.0 + 0.5 * 1.0 * d_charge_cs), rel=1e-12)


@pytest.mark.parametrize("transfer_loss, efficiency", [
    (0.0, 0.9474), (0.1, 0.852), (0.2, 0.756), (0.3, 0.660), (0.4, 0.565), (0.5, 0.469), (0.6, 0.373),
    (0.7, 0.277), (0.8, 0.182), (0.9, 0.086)])
def test_e_cs_is_the_check_value_of_the_spec_at_every_loss_of_fig12(transfer_loss, efficiency):
    supply = constant_supply_bounds(Params(strategy="mobile", n_chargers=6, transfer_loss=transfer_loss))
    # the spec rounds 4 decimals to 3 (0.5645 -> 0.565): half a unit of the third and a little
    assert supply.efficiency == pytest.approx(efficiency, abs=6e-4 if transfer_loss else 5e-5)
    # the paper's form, just below the strict long-run ceiling of the simulated ratio
    ceiling = 1.0 / (0.005 + 0.1) * 0.1 * (1.0 - transfer_loss - 0.005 / 1.0)
    assert 0.0 < supply.efficiency < ceiling <= supply.efficiency + 0.005


@pytest.mark.parametrize("charge_rate, ceiling", [(1.0, 27_609), (0.1, 16_600)])
def test_the_strict_work_ceiling_within_t_ticks_is_the_spec_value_and_above_w_fix(charge_rate, ceiling):
    params = Params(charge_rate=charge_rate)
    assert fixed_work_ceiling(params) == pytest.approx(ceiling, abs=0.5)
    assert fixed_work_ceiling(params) > fixed_bounds(params).work
    assert fixed_work_ceiling(Params(ticks=80)) == 0.0  # the first commute takes 83.3 ticks


def test_bounds_do_not_depend_on_the_chargers():
    a = constant_supply_bounds(Params(strategy="mobile", n_chargers=1, charger_capacity_factor=1))
    b = constant_supply_bounds(Params(strategy="mobile", n_chargers=12, charger_capacity_factor=6))
    assert a == b


def test_bounds_refuse_parameters_where_they_do_not_exist():
    # charging at or below the idle cost never fills a battery
    with pytest.raises(BoundUndefinedError, match="charge_rate"):
        fixed_bounds(Params(charge_rate=0.005))
    with pytest.raises(BoundUndefinedError, match="transfer_loss"):
        constant_supply_bounds(Params(strategy="mobile", n_chargers=6, charge_rate=0.01,
                                      transfer_loss=0.5))
    # a battery that cannot pay the round trip (2 x 0.105 x 83.33 = 17.5 units)
    with pytest.raises(BoundUndefinedError, match="worker_capacity"):
        fixed_bounds(Params(worker_capacity=17.5))
    fixed_bounds(Params(worker_capacity=17.6))          # just above: exists
    assert issubclass(BoundUndefinedError, ValueError)


# ------------------------------------------------------------------ validation


@pytest.mark.parametrize("changes, name", [
    (dict(strategy="mobile", n_chargers=6, transfer_loss=-0.1), "transfer_loss"),
    (dict(strategy="mobile", n_chargers=6, transfer_loss=1.0), "transfer_loss"),
    (dict(n_workers=0), "n_workers"),
    (dict(strategy="mobile", n_chargers=BASE_CAPACITY), "fit in the base"),
    (dict(strategy="mobile", n_chargers=0), "n_chargers"),
    (dict(strategy="fixed", n_chargers=2), "n_chargers"),
    (dict(strategy="solar"), "strategy"),
    (dict(charge_rate=0.0), "charge_rate"),
    (dict(work_ratio=-1.0), "work_ratio"),
    (dict(charger_capacity_factor=0.0), "charger_capacity_factor"),
    (dict(ticks=0), "ticks"),
    (dict(trials=0), "trials"),
    (dict(ticks=6000.0), "ticks"),
    (dict(work_ratio=float("nan")), "work_ratio"),
    (dict(ticks=10**9, trials=50), "ticks"),
    (dict(ticks=10**6, trials=50, sample_every=1), "time-series rows"),
    (dict(work_ratio=1e308), "work_ratio"),
])
def test_bad_parameters_are_refused_with_a_one_line_message(changes, name):
    with pytest.raises(ParamsError, match=name) as info:
        Params(**changes).validate()
    assert "\n" not in str(info.value)
    assert isinstance(info.value, ConfigError) and isinstance(info.value, ValueError)


def test_the_most_robots_that_fit_are_accepted():
    Params(strategy="mobile", n_workers=6, n_chargers=BASE_CAPACITY - 6).validate()
    Params(strategy="mobile", n_chargers=6, transfer_loss=0.9).validate()


def test_derived_rates():
    p = Params(work_ratio=2.5, charge_rate=0.5, charger_capacity_factor=1.5)
    assert (p.v_work, p.v_charge, p.charger_capacity) == (0.25, 0.5, 150.0)


def test_a_trace_too_large_for_memory_is_refused_before_running():
    from dronefleet.replenishment import simulate
    with pytest.raises(ValueError, match="GB"):
        simulate(Params(ticks=6000, trials=10_000), trace=True)


def test_simulate_validates_before_any_work():
    from dronefleet.replenishment import simulate
    with pytest.raises(ParamsError, match="transfer_loss"):
        simulate(Params(strategy="mobile", n_chargers=2, transfer_loss=1.5))
