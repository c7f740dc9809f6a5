"""dronefleet.lunar.diagnosis on small synthetic tables (issue 28: stretches, heading-guidance cosines,
the three criteria)."""

import math

import numpy as np
import pandas as pd
import pytest

from dronefleet.lunar import diagnosis

REGIONS = ("T", "N", "R")


def robot(run=0, t=60.0, robot=0, status="alive", role="F_OUT", mode="normal", x=0.0, y=0.0, heading=0.0,
          label="frame", **memory):
    """One snapshot row; ``memory`` sets omega_T, vx_N, ... (0 otherwise)."""
    row = {"run": run, "label": label, "t": t, "robot": robot, "status": status, "role": role, "mode": mode,
           "x": x, "y": y, "heading": heading, "soc": 1.0, "load": 0}
    for q in ("omega", "vx", "vy", "S"):
        for r in REGIONS:
            row[f"{q}_{r}"] = memory.get(f"{q}_{r}", 0.0)
    return row


FIELD = (10.0, 10.0)


def test_stretches_measure_net_displacement_and_what_a_robot_ends_near():
    rows = [
        # robot 0 crosses the open field: 5 m
        robot(t=60, robot=0, x=2.0, y=5.0), robot(t=120, robot=0, x=5.0, y=9.0),
        # robot 1 moves 1 m and ends 0.5 m from beacon 2's centre (< 2 r_body + ir_range = 0.6)
        robot(t=60, robot=1, x=5.0, y=2.0), robot(t=120, robot=1, x=6.0, y=2.0),
        robot(t=60, robot=2, role="B", x=6.5, y=2.0), robot(t=120, robot=2, role="B", x=6.5, y=2.0),
        # robot 3 ends 0.3 m from the wall x = 0 (< r_body + ir_range = 0.45)
        robot(t=60, robot=3, x=0.5, y=8.0), robot(t=120, robot=3, x=0.3, y=8.0),
        # robot 4 charges in R, robot 5 becomes a beacon (no stretch), robot 6 is dead at the end
        robot(t=60, robot=4, role="R", mode="charging", x=8.0, y=8.0),
        robot(t=120, robot=4, role="R", mode="charging", x=8.0, y=8.0),
        robot(t=60, robot=5, x=3.0, y=3.0), robot(t=120, robot=5, role="B", x=3.0, y=3.0),
        robot(t=60, robot=6, x=4.0, y=4.0), robot(t=120, robot=6, status="dead", x=4.0, y=4.0),
        # a periodic snapshot is not a frame
        robot(t=90, robot=0, x=9.0, y=9.0, label="periodic"),
    ]
    table = diagnosis.stretches(pd.DataFrame(rows), FIELD, r_body=0.15, ir_range=0.3)
    by_robot = table.set_index("robot")
    assert sorted(by_robot.index) == [0, 1, 3, 4]
    assert by_robot.loc[0, "displacement_m"] == pytest.approx(5.0)
    assert by_robot.loc[1, "displacement_m"] == pytest.approx(1.0)
    assert (by_robot.loc[1, "near_beacon"], by_robot.loc[1, "near_wall"]) == (True, False)
    assert (by_robot.loc[3, "near_beacon"], by_robot.loc[3, "near_wall"]) == (False, True)
    assert by_robot.loc[4, "charging"] and not by_robot.loc[0, "charging"]
    assert (by_robot.loc[0, "t0"], by_robot.loc[0, "t1"]) == (60.0, 120.0)

    shares = diagnosis.stuck_shares(table, threshold_m=3.0)
    assert shares["stretches"] == 4
    assert shares["stuck"] == pytest.approx(3 / 4)
    assert (shares["stuck_charging"], shares["stuck_beacon"], shares["stuck_wall"], shares["stuck_free"]) == \
        pytest.approx((1 / 4, 1 / 4, 1 / 4, 0.0))


def test_stuck_shares_of_no_stretch_are_nan():
    empty = pd.DataFrame(columns=["displacement_m", "near_beacon", "near_wall", "charging"])
    assert math.isnan(diagnosis.stuck_shares(empty)["stuck"])


CENTRES = {"T": (5.0, 0.0), "N": (-5.0, 0.0), "R": (0.0, 5.0)}


def cosines(rows, **weights):
    return diagnosis.heading_cosines(pd.DataFrame(rows), CENTRES, comm_radius=2.0, rho_f=1.0, rho_c=3.0,
                                     **weights).set_index("robot")


def test_heading_cosine_uses_the_beacons_in_range_with_their_weights():
    rows = [
        # beacon 0 points east for T; beacon 1 points north for T but has learnt S_T = 1: weight 0
        robot(robot=0, role="B", x=0.0, y=0.0, omega_T=0.5, vx_T=1.0),
        robot(robot=1, role="B", x=0.0, y=1.0, omega_T=1.0, vy_T=1.0, S_T=1.0),
        robot(robot=2, role="F_OUT", x=1.0, y=0.0, heading=0.0),           # along G, G towards T
        robot(robot=3, role="F_OUT", x=1.0, y=0.0, heading=math.pi),       # against G
        robot(robot=4, role="F_OUT", x=1.0, y=0.0, heading=math.pi / 2),   # across G
        robot(robot=5, role="F_OUT", x=-1.9, y=0.0, heading=0.0),          # in range of beacon 0 only
        robot(robot=6, role="F_OUT", x=8.0, y=8.0),                        # no beacon in range
        robot(robot=7, role="F_OUT", mode="backtrack", x=1.0, y=0.0),      # not read
    ]
    table = cosines(rows)
    assert sorted(table.index) == [2, 3, 4, 5, 6]
    assert table.loc[2, "cos"] == pytest.approx(1.0)
    assert table.loc[3, "cos"] == pytest.approx(-1.0)
    assert table.loc[4, "cos"] == pytest.approx(0.0, abs=1e-12)
    assert table.loc[2, "cos_goal"] == pytest.approx(1.0)
    assert (table.loc[2, "in_range"], table.loc[5, "in_range"], table.loc[6, "in_range"]) == (2, 1, 0)
    assert math.isnan(table.loc[6, "cos"]) and math.isnan(table.loc[6, "cos_goal"])
    # with the literal weight omega (1 - S), beacon 1 still weighs 0; with "bracket" max(0, 1 - 3 S) too
    assert cosines(rows, weight_form="literal").loc[2, "cos"] == pytest.approx(1.0)


def test_the_cost_term_of_the_weight_turns_the_guidance():
    rows = [robot(robot=0, role="B", x=0.0, y=0.0, omega_T=1.0, vx_T=1.0, S_T=0.5),
            robot(robot=1, role="B", x=0.0, y=1.0, omega_T=1.0, vy_T=1.0),
            robot(robot=2, role="F_OUT", x=0.5, y=0.5, heading=0.0)]
    # G = (1 - 0.5)^3 (1, 0) + (0, 1) = (0.125, 1): heading east makes cos 0.125 / |G|
    assert cosines(rows).loc[2, "cos"] == pytest.approx(0.125 / math.hypot(0.125, 1.0))


def test_an_f_in_robot_without_n_guidance_falls_back_on_r_and_is_measured_against_r():
    rows = [robot(robot=0, role="B", x=0.0, y=0.0, omega_R=1.0, vy_R=-1.0),
            robot(robot=1, role="F_IN", x=0.0, y=1.0, heading=math.pi / 2),
            robot(robot=2, role="R", x=0.0, y=1.0, heading=math.pi / 2)]
    table = cosines(rows)
    assert table.loc[1, "cos"] == pytest.approx(-1.0)
    assert table.loc[1, "cos_goal"] == pytest.approx(-1.0)      # G points south, R lies north: a sink
    assert table.loc[2, "cos"] == pytest.approx(-1.0)


def test_cosine_shares_split_missing_guidance_from_its_direction():
    table = pd.DataFrame({"in_range": [0, 2, 1, 1, 1], "cos": [np.nan, np.nan, -0.9, 0.1, 0.8]})
    shares = diagnosis.cosine_shares(table)
    assert shares["rows"] == 5
    assert (shares["no_beacon"], shares["zero"], shares["below"], shares["across"], shares["along"]) == \
        pytest.approx((0.2, 0.2, 0.2, 0.2, 0.2))
    assert shares["mean"] == pytest.approx(0.0)


def series(run, beacons, mobile, unspawned=None, dt=300.0):
    n = len(beacons)
    return pd.DataFrame({"run": run, "t": dt * np.arange(1, n + 1), "n_beacons": beacons, "n_mobile": mobile,
                         "n_unspawned": unspawned if unspawned is not None else [0] * n})


def test_network_course_reads_t90_peak_decay_and_the_mobile_rise():
    ts = series(0, beacons=[2, 5, 9, 10, 8, 7], mobile=[10, 30, 20, 18, 25, 26], unspawned=[40, 5, 0, 0, 0, 0])
    course = diagnosis.network_course(ts).iloc[0]
    assert (course["t90"], course["t_peak"]) == (900.0, 1200.0)
    assert (course["peak"], course["final"], course["decay"]) == (10, 7, 3)
    assert course["mobile_rise"] == 26 - 18       # the minimum once all spawned, not the early 10


def summary(resources, deaths=0, depletions=0, runs=3):
    return pd.DataFrame({"run": range(runs), "resources": resources, "deaths": deaths, "depletions": depletions})


def test_criteria_hold_together_only_when_each_holds():
    ts = pd.concat([series(r, beacons=[2, 5, 9, 10, 8, 7 + r % 2], mobile=[10, 30, 20, 18, 25, 26])
                    for r in range(3)])
    good = diagnosis.criteria(ts, summary([700, 800, 900]))
    assert (good["timing"], good["survival"], good["foraging"], good["all"]) == (True, True, True, True)
    assert good["resources"] == pytest.approx(800.0)
    assert not diagnosis.criteria(ts, summary([100, 800, 900]))["foraging"]
    assert not diagnosis.criteria(ts, summary([700, 800, 900], depletions=[0, 1, 0]))["survival"]
    early = pd.concat([series(r, beacons=[9, 10, 10, 10, 8, 7], mobile=[10, 30, 20, 18, 25, 26], dt=60.0)
                       for r in range(3)])
    timing = diagnosis.criteria(early, summary([700, 800, 900]))
    assert timing["t90_s"] == 60.0 and not timing["timing"] and not timing["all"]
    flat = pd.concat([series(r, beacons=[2, 5, 9, 10, 10, 10], mobile=[10, 30, 20, 18, 18, 18]) for r in range(3)])
    assert not diagnosis.criteria(flat, summary([700, 800, 900]))["timing"]
