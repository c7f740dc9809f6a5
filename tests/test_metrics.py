"""Section 11 metrics by hand: backlog and pending by arrival week, decision accuracy."""

import math

import numpy as np
import pytest

from conftest import WEEK, rate
from dronefleet.delivery import config as cfg
from dronefleet.delivery.metrics import accuracy_points, by_arrival_week, decision_accuracy

C = cfg.default_config()


def test_backlog_and_pending_by_arrival_week():
    arrival = [0.0, WEEK - 1.0, WEEK, 1.5 * WEEK, 1.9 * WEEK]
    delivered = [10.0, math.nan, math.nan, 1.6 * WEEK, math.nan]
    table = by_arrival_week(arrival, delivered, 2 * WEEK)
    assert table["arrival_week"].tolist() == [1, 2]
    assert table["arrived"].tolist() == [2, 3]
    assert table["pending"].tolist() == [1, 2]
    assert table["backlog_age_s"].tolist() == pytest.approx([WEEK + 1.0, 1.1 * WEEK], rel=1e-12)


def test_weeks_without_orders_are_listed_with_zeros():
    table = by_arrival_week([0.0], [math.nan], 3 * WEEK)
    assert table["pending"].tolist() == [1, 0, 0]
    assert table["backlog_age_s"].tolist() == [3 * WEEK, 0.0, 0.0]


def _standardised_soc_weight(soc_cut):
    """coef, intercept of a policy that bids iff SoC >= soc_cut."""
    return (0.0, 0.0, 1.0), -(soc_cut - C.scaler_mean[2]) / C.scaler_std[2]


def test_decision_accuracy_against_ground_truth_by_hand():
    # Ground truth by docs/delivery-model.md section 3 at SoH 1 and 0.5.
    points = np.array([[1000.0, 0.5, 100.0],   # easy: capable at both SoH
                       [6000.0, 5.0, 5.0],     # hopeless: capable at neither
                       [6000.0, 5.0, 100.0]])  # capable only at SoH 1
    leg = 600.0
    assert leg * rate(5.0, 1.0) < 0.5 * 100.0 and 100.0 - leg * (rate(5.0, 1.0) + rate(0.0, 1.0)) > 0
    assert not leg * rate(5.0, 0.5) < 0.5 * 100.0
    always, never, charged = ((0.0, 0.0, 1.0), 1e3), ((0.0, 0.0, 1.0), -1e3), _standardised_soc_weight(50.0)
    policies = [always, never, charged, charged]
    soh = [1.0, 1.0, 1.0, 0.5]
    coef = np.array([p[0] for p in policies])
    intercept = np.array([p[1] for p in policies])
    accuracy = decision_accuracy(coef, intercept, soh, C, points=points)
    # always: right on points 0 and 2; never: right on point 1; SoC >= 50: right on all at SoH 1,
    # wrong on point 2 at SoH 0.5.
    assert accuracy.tolist() == pytest.approx([2 / 3, 1 / 3, 1.0, 2 / 3])


def test_accuracy_points_are_the_documented_distribution_and_depend_on_the_seed_only():
    points = accuracy_points(C)
    assert points.shape == (1000, 3)
    assert points[:, 0].min() >= 1000.0 and points[:, 0].max() < 6000.0
    assert points[:, 1].min() >= 0.5 and points[:, 1].max() < 5.0
    assert points[:, 2].min() >= 0.0 and points[:, 2].max() < 100.0
    assert np.array_equal(points, accuracy_points(cfg.replace(C, tau_minutes=40.0)))
    assert not np.array_equal(points, accuracy_points(cfg.replace(C, seed=1)))
