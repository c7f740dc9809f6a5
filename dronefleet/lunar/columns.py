"""What every column of the lunar tables holds, with its unit (:data:`COLUMNS`, the scenario's
``columns`` hook; the documentation site's table pages are made from it).

Regions: T the target (where resources are loaded), N the nest (where they are unloaded), R the
spot-lit recharging region. Roles: F_OUT (foraging, heading for T), F_IN (carrying back to N),
R (heading for R or charging there), B (beacon). SOC: state of charge, stored energy over the
battery capacity (0..1).
"""

from __future__ import annotations

from ..contract import Column

__all__ = ["COLUMNS", "TRANSITIONS"]

#: The role transitions of the robots' supervisor, each counted in the summary column of its name.
TRANSITIONS = {
    "row1": "a mobile robot with no beacon within reach stops and becomes a beacon",
    "row2": "recharging interruptions: a forager whose SOC falls below the learned cost (times phi_soc) of "
            "reaching its destination or R turns to recharge",
    "row3": "nest recharges: a robot reaching the nest without ever having charged goes to charge",
    "row4": "charging sessions: a robot in role R reaches R and starts charging",
    "row5": "a robot fully charged at R, with no guidance towards R around it, heads for the nest (F_IN)",
    "row6": "a robot fully charged at R, carrying nothing, heads for the target (F_OUT)",
    "row7": "a robot fully charged at R, carrying a load, heads for the nest (F_IN)",
    "row8": "a carrier reaches the nest, unloads and heads for the target again (F_IN -> F_OUT)",
    "row9": "a robot in role R, not charging, reaches the nest with charge enough to go out (-> F_OUT)",
    "row10": "a forager reaches the target, loads and heads for the nest (F_OUT -> F_IN)",
    "row11": "a robot in role R, not charging, reaches the target with charge enough to carry back "
             "(loads, -> F_IN)",
    "rowD": "a beacon whose summed potential weights decayed below eta_w moves again, in the role it had",
}

_RUN = Column("index", "the run (first_run .. first_run + runs - 1)")
_ROBOT = Column("index", "the robot, from 0")
_T = Column("s", "time from the start of the run")
_REGIONS = {"T": "the target T", "N": "the nest N", "R": "the recharging region R"}
_ROLE = Column("", "its role: F_OUT, F_IN, R or B")
_MODE = Column("", "its motion mode: normal, charging, reconnect or backtrack")
_SNAPSHOT_LABEL = Column("", "why the snapshot was taken: first_T, first_R, first_row5 (the first robot to reach T, "
                             "R, to leave R with no R guidance), periodic (every snapshot_every_s), end, or frame "
                             "(with frames = true)")


def _per_region(prefix: str, unit: str, doc: str) -> dict[str, Column]:
    """``{prefix_T, prefix_N, prefix_R}``, ``doc`` formatted with each region's words."""
    return {f"{prefix}_{q}": Column(unit, doc.format(region=words)) for q, words in _REGIONS.items()}


_ALIGNMENT = _per_region("alignment", "1", "mean over the beacons holding a vector for {region} of the cosine between "
                                           "that vector and the direction to {region} (1: pointing straight at it); "
                                           "NaN if no beacon holds one")

#: ``{table: {column: Column}}`` for every table of :func:`dronefleet.lunar.simulate.table_schemas`.
COLUMNS = {
    "summary": {
        "run": _RUN,
        "seed": Column("", "the root seed; run j draws its streams from seed x 2^32 + j"),
        "layout": Column("", "the field's layout: OPEN, or a hard or soft obstacle between two regions"),
        "battery_wh": Column("Wh", "battery capacity of every robot"),
        "resources": Column("units", "resource units unloaded at the nest by the end"),
        "trips": Column("count", "unloads at the nest"),
        "interruptions": Column("count", "recharging interruptions (" + TRANSITIONS["row2"].split(": ", 1)[1] + ")"),
        "nest_recharges": Column("count", "robots sent to charge on reaching the nest uncharged"),
        "sessions": Column("count", "charging sessions begun at R"),
        "deaths": Column("count", "robots that died (SOC 0 with depletion = \"fatal\")"),
        "depletions": Column("count", "times a robot's energy reached 0 from above (equal to deaths under "
                                      "depletion = \"fatal\")"),
        "beacons": Column("count", "beacons alive at the end"),
        "mobile": Column("count", "mobile robots alive at the end"),
        "units_beacons": Column("units", "resource units held by beacons at the end (loads they stopped with)"),
        **_ALIGNMENT,
        **_per_region("alignment_w", "1", "as alignment for {region}, each beacon weighted by its potential weight "
                                          "omega for {region}"),
        **_per_region("heading_alignment", "1", "mean over the mobile robots in normal mode heading for {region} "
                                                "of the cosine between their last motion and the direction to "
                                                "{region}; NaN if none"),
        "deaths_per_session": Column("1", "deaths / sessions; NaN without a session"),
        "t_first_T": Column("s", "when a robot first reached the target; NaN if none did"),
        "t_first_R": Column("s", "when a robot first reached the recharging region; NaN if none did"),
        "t_first_row5": Column("s", "when a robot first left R for the nest with no R guidance around it (row5); "
                                    "NaN if never"),
        "t_beacons_90": Column("s", "when the number of beacons first reached 90 % of its peak; NaN without beacons"),
        **{row: Column("count", f"role transitions: {doc}") for row, doc in TRANSITIONS.items()},
    },
    "timeseries": {
        "run": _RUN,
        "t": Column("s", "the end of the update interval (one row every update_interval_s)"),
        "resources": Column("units", "resource units unloaded at the nest so far"),
        "trips": Column("count", "unloads so far"),
        "interruptions": Column("count", "recharging interruptions so far"),
        "nest_recharges": Column("count", "nest recharges so far"),
        "sessions": Column("count", "charging sessions so far"),
        "rate": Column("units", "resource units unloaded in the last rate_window_s"),
        "n_mobile": Column("count", "mobile robots alive"),
        "n_beacons": Column("count", "beacons alive"),
        "n_dead": Column("count", "dead robots"),
        "n_unspawned": Column("count", "robots not yet released from the nest"),
        "n_f_out": Column("count", "mobile robots in role F_OUT"),
        "n_f_in": Column("count", "mobile robots in role F_IN"),
        "n_r": Column("count", "mobile robots in role R"),
        "soc_sum": Column("1", "summed SOC of all robots (the unspawned at their initial SOC)"),
        "soc_beacons": Column("1", "summed SOC of the beacons"),
        "soc_mobile": Column("1", "summed SOC of the mobile robots"),
        "soc_min_beacon": Column("1", "the lowest SOC of a beacon; NaN without beacons"),
        "units_beacons": Column("units", "resource units held by beacons"),
        **_ALIGNMENT,
    },
    "trips": {
        "run": _RUN,
        "origin": Column("", "the region left: T, N or R"),
        "dest": Column("", "the region entered next: T, N or R"),
        "tick_left": Column("tick", "the tick it left origin"),
        "tick_entered": Column("tick", "the tick it entered dest"),
        "length_m": Column("m", "distance driven on the way"),
        "energy_j": Column("J", "energy used on the way (gross, charging not subtracted)"),
        "energy_wh": Column("Wh", "energy_j in watt-hours"),
        "soc_cost": Column("1", "energy_wh over the battery capacity: the trip's cost in SOC"),
        "duration_s": Column("s", "(tick_entered - tick_left) x tau"),
        "soft_length_m": Column("m", "the part of length_m driven from inside the soft obstacle (0 in layouts "
                                     "without one)"),
        "role_left": Column("", "the robot's role when it left"),
        "role_entered": Column("", "its role when it entered"),
        "robot": _ROBOT,
    },
    "snapshots": {
        "run": _RUN,
        "label": _SNAPSHOT_LABEL,
        "t": _T,
        "robot": _ROBOT,
        "status": Column("", "unspawned, alive or dead"),
        "role": _ROLE,
        "mode": _MODE,
        "x": Column("m", "position, x"),
        "y": Column("m", "position, y"),
        "heading": Column("rad", "heading, counter-clockwise from the x axis"),
        "soc": Column("1", "state of charge"),
        "load": Column("units", "resource units carried"),
        **_per_region("omega", "1", "a beacon's potential weight for {region} (0 for a mobile robot)"),
        **_per_region("vx", "m/s", "x component of a beacon's guidance vector for {region}"),
        **_per_region("vy", "m/s", "y component of a beacon's guidance vector for {region}"),
        **_per_region("S", "1", "a beacon's learned SOC cost of the way to {region} (times phi_soc)"),
    },
    "robots": {
        "run": _RUN,
        "robot": _ROBOT,
        "trips": Column("count", "its trip records"),
        "distance_m": Column("m", "distance it drove (ticks it moved x v0 x tau)"),
        "energy_j": Column("J", "gross energy it used"),
        "energy_wh": Column("Wh", "energy_j in watt-hours"),
        "recharges": Column("count", "its charging sessions"),
        "loads": Column("count", "its loads at the target"),
        "unloads": Column("count", "its unloads at the nest"),
        "time_f_out_s": Column("s", "time alive in role F_OUT"),
        "time_f_in_s": Column("s", "time alive in role F_IN"),
        "time_r_s": Column("s", "time alive in role R"),
        "time_b_s": Column("s", "time alive as a beacon (the four times add up to its life from spawn to the end "
                                "or its death)"),
        "died": Column("", "whether it died"),
    },
    "deaths": {
        "run": _RUN,
        "robot": _ROBOT,
        "t": Column("s", "when it died"),
        "x": Column("m", "where it lies, x"),
        "y": Column("m", "where it lies, y"),
        "role": Column("", "its role when it died"),
        "mode": Column("", "its motion mode when it died"),
        "region": Column("", "the region it died in (T, N or R); null outside every region"),
    },
    "recharge_triggers": {
        "run": _RUN,
        "robot": _ROBOT,
        "t": Column("s", "when the robot turned to recharge"),
        "role": Column("", "its role then, F_OUT or F_IN"),
        "soc": Column("1", "its SOC then"),
        "s_hat_dest": Column("1", "the learned SOC cost of reaching its destination (times phi_soc)"),
        "s_hat_R": Column("1", "the learned SOC cost of reaching R (times phi_soc); it turns when soc is below "
                               "either"),
        "x": Column("m", "where it was, x"),
        "y": Column("m", "where it was, y"),
        "dist_R_m": Column("m", "its distance to the centre of R"),
    },
    "beacon_costs": {
        "run": _RUN,
        "label": _SNAPSHOT_LABEL,
        "t": _T,
        "near": Column("", "the region whose surroundings the row describes: T, then R"),
        "beacons": Column("count", "beacons alive within comm_radius of the region's edge"),
        "S_R_mean": Column("1", "their mean learned SOC cost of the way to R (a beacon holding none counts 0); "
                                "NaN without beacons"),
        "S_T_mean": Column("1", "their mean learned SOC cost of the way to T; NaN without beacons"),
    },
}
