"""The tables of what decides the E2 claims (spec LUNAR-FORAGING.md sections 19, 21; A36, A42): per-robot
totals (``robots``), ``deaths``, ``recharge_triggers`` and ``beacon_costs``, read against the tables a
run already had (summary, trips, snapshots) and recomputed from them where they can be. A small run with
a 0.5-Wh battery has deaths and row-2 triggers within seconds. The kernel's part of each record is pinned
in test_lunar_phases.py and test_lunar_tick.py."""

import math

import numpy as np
import pandas as pd
import pytest

from dronefleet.lunar.layout import build
from dronefleet.lunar.params import LunarParams
from dronefleet.lunar.simulate import simulate

PARAMS = LunarParams(n_robots=30, duration_s=300.0, runs=2, battery_wh=0.5)


@pytest.fixture(scope="module")
def tables():
    return {name: table.to_pandas() for name, table in simulate(PARAMS).items()}


def test_the_totals_of_the_robots_add_up_to_the_runs_counts(tables):
    robots, summary, trips = tables["robots"], tables["summary"].set_index("run"), tables["trips"]
    assert len(robots) == PARAMS.runs * PARAMS.n_robots
    per_run = robots.groupby("run")
    for column, total in (("unloads", "trips"), ("recharges", "sessions"), ("died", "deaths")):
        assert per_run[column].sum().tolist() == summary[total].tolist(), column
    by_robot = robots.set_index(["run", "robot"])
    made = trips.groupby(["run", "robot"]).size().reindex(by_robot.index, fill_value=0)
    assert by_robot["trips"].tolist() == made.tolist() and made.sum() == len(trips) > 0
    # a trip's length and energy are part of what its robot drove and used
    driven = trips.groupby(["run", "robot"])[["length_m", "energy_j"]].sum()
    mine = by_robot.loc[driven.index]
    assert (driven["length_m"] <= mine["distance_m"] + 1e-9).all() and (driven["energy_j"] <= mine["energy_j"]).all()


def test_each_robot_spends_its_time_alive_in_its_roles(tables):
    robots, deaths = tables["robots"], tables["deaths"].set_index(["run", "robot"])
    alive = robots[["time_f_out_s", "time_f_in_s", "time_r_s", "time_b_s"]].sum(axis=1)
    assert (alive <= PARAMS.duration_s + 1e-9).all() and (robots["distance_m"] <= alive * PARAMS.v0 + 1e-9).all()
    for i in robots.index[robots["robot"] == 0]:                    # robot 0 spawns at tick 1
        run, died = robots.loc[i, "run"], robots.loc[i, "died"]
        assert alive[i] == pytest.approx(deaths.loc[(run, 0), "t"] if died else PARAMS.ticks * PARAMS.tau)


def test_each_death_is_where_the_end_snapshot_has_the_dead_robot(tables):
    deaths, summary, snaps = tables["deaths"], tables["summary"], tables["snapshots"]
    assert len(deaths) == summary["deaths"].sum() > 0
    end = snaps[snaps["label"] == "end"].set_index(["run", "robot"])
    layout = build(PARAMS)
    for _, death in deaths.iterrows():
        there = end.loc[(death["run"], death["robot"])]
        assert there["status"] == "dead"
        assert (there["x"], there["y"], there["role"], there["mode"]) == (death["x"], death["y"], death["role"],
                                                                          death["mode"])
        inside = [name for name, (cx, cy) in layout.centres.items()
                  if math.dist((cx, cy), (death["x"], death["y"])) < layout.radii[name]]
        assert inside == ([] if pd.isna(death["region"]) else [death["region"]])
        assert 0 < death["t"] <= PARAMS.duration_s


def test_each_row_2_firing_is_a_trigger_below_one_of_the_costs_it_compared(tables):
    triggers, summary = tables["recharge_triggers"], tables["summary"].set_index("run")
    counted = triggers.groupby("run").size().reindex(summary.index, fill_value=0)
    assert counted.tolist() == summary["interruptions"].tolist() and len(triggers) > 0
    assert set(triggers["role"]) <= {"F_OUT", "F_IN"}
    assert (triggers["soc"] < np.maximum(triggers["s_hat_dest"], triggers["s_hat_R"])).all()
    rx, ry = build(PARAMS).centres["R"]
    assert np.allclose(triggers["dist_R_m"], np.hypot(triggers["x"] - rx, triggers["y"] - ry), rtol=0, atol=1e-12)


def test_the_beacon_costs_are_the_snapshots_beacons_near_t_and_r(tables):
    costs, snaps = tables["beacon_costs"], tables["snapshots"]
    layout = build(PARAMS)
    shots = snaps.groupby(["run", "label", "t"], sort=False)
    assert len(costs) == 2 * shots.ngroups and list(costs["near"][:2]) == ["T", "R"]
    expected = []
    for (run, label, t), shot in shots:
        for region in ("T", "R"):
            (cx, cy), reach = layout.centres[region], layout.radii[region] + PARAMS.comm_radius
            near = shot[(shot["status"] == "alive") & (shot["role"] == "B")
                        & (np.hypot(shot["x"] - cx, shot["y"] - cy) < reach)]
            expected.append((run, label, t, region, len(near), near["S_R"].mean(), near["S_T"].mean()))
    got = list(costs.itertuples(index=False, name=None))
    assert [row[:5] for row in got] == [row[:5] for row in expected]
    assert np.allclose([row[5:] for row in got], [row[5:] for row in expected], equal_nan=True, rtol=0, atol=1e-15)
    assert (costs["beacons"] > 0).any() and (costs["S_R_mean"] > 0).any()
