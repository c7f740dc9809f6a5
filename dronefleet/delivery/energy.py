"""Closed-form energy of the fleet's multirotors (docs/delivery-model.md sections 2 and 3).

Every state of charge (SoC, percent) is an exact expression of time: it falls
linearly in flight and approaches 100 exponentially while charging at the
fulfilment centre. Nothing here steps time.
"""

import numpy as np

from ..fpmath import exp
from ..jit import njit

SECONDS_PER_HOUR = 3600.0

#: SoC (percent) below which a UAV counts as lost. With xi = 0.5 an aborted UAV
#: lands with exactly 0 % in exact arithmetic; rounding must not turn that into a loss.
LOSS_TOLERANCE = 1e-9


def flight_power(payload_kg, frame_mass_kg, battery_mass_kg, n_rotors, rotor_area_m2,
                 air_density_kg_m3, gravity_m_s2):
    """Hover/cruise power of a multirotor carrying ``payload_kg`` (Dorling et al. 2017), W.

    ``payload_kg`` may be a scalar or an array; the result has its shape.
    """
    weight = gravity_m_s2 * (frame_mass_kg + battery_mass_kg + np.asarray(payload_kg, dtype=np.float64))
    # w * sqrt(w), not w ** 1.5: pow takes CPU-specific code paths (see dronefleet.fpmath).
    return weight * np.sqrt(weight) / np.sqrt(2.0 * n_rotors * air_density_kg_m3 * rotor_area_m2)


def config_power(config, payload_kg):
    """:func:`flight_power` with the UAV parameters of a :class:`~dronefleet.delivery.config.Config`, W."""
    return flight_power(payload_kg, config.frame_mass_kg, config.battery_mass_kg, config.n_rotors,
                        config.rotor_area_m2, config.air_density_kg_m3, config.gravity_m_s2)


def drain_per_watt(capacity_wh, soh):
    """SoC lost per second per watt of flight power, %/(s W), for state(s) of health ``soh``."""
    return 100.0 / (SECONDS_PER_HOUR * capacity_wh * np.asarray(soh, dtype=np.float64))


def charge_rate(capacity_wh, charger_power_w, charger_efficiency):
    """Rate constant k of the charging curve dSoC/dt = (100 - SoC) k, 1/s (same for every SoH)."""
    return charger_efficiency * charger_power_w / (SECONDS_PER_HOUR * capacity_wh)


@njit(cache=True)
def soc_after_charging(soc0, seconds, k):
    """SoC (percent) after charging for ``seconds`` from ``soc0`` with rate constant ``k`` (1/s)."""
    return 100.0 - (100.0 - soc0) * exp(-k * seconds)


@njit(cache=True)
def plan_attempt(soc0, distance_m, speed_m_s, rate_loaded, rate_empty, xi):
    """The whole timeline of one delivery attempt, known at takeoff (docs/delivery-model.md section 3).

    Parameters
    ----------
    soc0 : float
        SoC at takeoff, percent.
    distance_m, speed_m_s : float
        Delivery distance and cruise speed.
    rate_loaded, rate_empty : float
        SoC drain with the parcel and without it, percent per second.
    xi : float
        Abort level as a fraction of ``soc0``.

    Returns
    -------
    delivered : bool
        True if the parcel reaches its destination.
    outbound_s : float
        Seconds from takeoff to the delivery or abort instant.
    soc_turn : float
        SoC at that instant.
    home_s : float
        Seconds from that instant to landing or, if ``lost``, to the instant SoC reaches 0.
    soc_land : float
        SoC at landing (clamped at 0 within ``LOSS_TOLERANCE``); negative if lost.
    lost : bool
        True if SoC would fall below 0 before the UAV is back.
    """
    leg_s = distance_m / speed_m_s
    if leg_s * rate_loaded < (1.0 - xi) * soc0:
        delivered = True
        outbound_s = leg_s
        soc_turn = soc0 - leg_s * rate_loaded
        rate_home = rate_empty
    else:
        # Abort as soon as SoC reaches xi * soc0; the parcel is flown back at the loaded rate.
        delivered = False
        outbound_s = (1.0 - xi) * soc0 / rate_loaded
        soc_turn = xi * soc0
        rate_home = rate_loaded
        leg_s = outbound_s
    soc_land = soc_turn - leg_s * rate_home
    lost = soc_land < -LOSS_TOLERANCE
    if lost:
        home_s = soc_turn / rate_home
    else:
        home_s = leg_s
        soc_land = max(soc_land, 0.0)
    return delivered, outbound_s, soc_turn, home_s, soc_land, lost


def capable(distance_m, mass_kg, soc, drain, power_loaded, power_empty, speed_m_s, xi):
    """Ground truth of docs/delivery-model.md section 3: can a UAV complete (d, m) from ``soc``?

    ``drain`` is the UAV's :func:`drain_per_watt`; ``power_loaded`` the flight power with
    the parcel. All arguments broadcast; returns a boolean array.
    """
    leg_s = np.asarray(distance_m) / speed_m_s
    out = leg_s * power_loaded * drain
    home = leg_s * power_empty * drain
    soc = np.asarray(soc)
    return (out < (1.0 - xi) * soc) & (soc - (out + home) > 0.0)
