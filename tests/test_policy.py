"""The compiled policy learner must reproduce scikit-learn's SGDClassifier.partial_fit."""

import numpy as np
import pytest
from numpy.testing import assert_allclose
from sklearn.linear_model import SGDClassifier

from dronefleet.delivery.policy import (
    decision,
    initial_fit,
    optimal_init,
    sgd_step,
    standardise,
    to_sgdclassifier,
)

# docs/delivery-model.md sections 1 and 6.
MEAN = np.array([3500.0, 2.75, 50.0])
STD = np.array([1443.38, 1.298, 28.87])
DISTANCE_RANGE = (1000.0, 6000.0)
MASS_RANGE = (0.5, 5.0)
ALPHA = 0.01
RTOL = 1e-12


def _sklearn(alpha=ALPHA):
    return SGDClassifier(
        loss="modified_huber",
        penalty="l2",
        alpha=alpha,
        learning_rate="optimal",
        eta0=0.01,
        fit_intercept=True,
        random_state=0,
    )


def _samples(seed, n):
    """Standardised samples at three scales (large |x| reaches the linear loss branch)."""
    rng = np.random.default_rng(seed)
    scale = rng.choice([0.3, 1.0, 6.0], size=(n, 1))
    X = rng.standard_normal((n, 3)) * scale
    y = rng.integers(0, 2, size=n)
    return X, y


def _loss_branch(coef, intercept, i, x, y):
    """0: zero gradient (z >= 1), 1: quadratic, 2: linear (z < -1)."""
    z = decision(coef, intercept, i, x[0], x[1], x[2]) * (1.0 if y else -1.0)
    return 0 if z >= 1.0 else (1 if z >= -1.0 else 2)


def _run_both(clf, coef, intercept, t, i, X, y, alpha=ALPHA):
    """Feed X, y one sample at a time to clf and to sgd_step; compare after every step."""
    t0 = optimal_init(alpha)
    branches = np.zeros(3, dtype=int)
    for x, label in zip(X, y):
        branches[_loss_branch(coef, intercept, i, x, label)] += 1
        clf.partial_fit(x[None], [label], classes=[0, 1])
        sgd_step(coef, intercept, t, i, x[0], x[1], x[2], label, alpha, t0)
        assert_allclose(coef[i], clf.coef_[0], rtol=RTOL, atol=0)
        assert_allclose(intercept[i], clf.intercept_[0], rtol=RTOL, atol=0)
        assert t[i] == clf.t_
    return branches


@pytest.mark.parametrize("alpha", [1e-4, 0.01, 2.0])
def test_optimal_init_is_bottou_t0(alpha):
    # modified_huber's dloss(1, -typw) < 0, so initial_eta0 = typw.
    typw = np.sqrt(1.0 / np.sqrt(alpha))
    assert optimal_init(alpha) == pytest.approx(1.0 / (typw * alpha), rel=1e-15)


@pytest.mark.parametrize("alpha", [1e-4, 0.01, 2.0])
def test_first_step_rate_matches_sklearn(alpha):
    # From w = 0, p = 0: the intercept moves by exactly 2 * eta_1 = 2 / (alpha * t0).
    coef, intercept, t = np.zeros((1, 3)), np.zeros(1), np.ones(1)
    sgd_step(coef, intercept, t, 0, 0.5, -1.0, 2.0, 1, alpha, optimal_init(alpha))
    clf = _sklearn(alpha).partial_fit([[0.5, -1.0, 2.0]], [1], classes=[0, 1])
    assert intercept[0] == clf.intercept_[0]
    assert intercept[0] == pytest.approx(2.0 / (alpha * optimal_init(alpha)), rel=1e-15)


def test_decision_is_affine():
    rng = np.random.default_rng(7)
    coef, intercept = rng.standard_normal((5, 3)), rng.standard_normal(5)
    for i in range(5):
        x = rng.standard_normal(3) * 4
        expected = coef[i] @ x + intercept[i]
        assert decision(coef, intercept, i, x[0], x[1], x[2]) == pytest.approx(expected, rel=1e-14)


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_sgd_step_matches_partial_fit_from_zero(seed):
    X, y = _samples(seed, 1000)
    coef, intercept, t = np.zeros((3, 3)), np.zeros(3), np.ones(3)
    i = seed % 3
    branches = _run_both(_sklearn(), coef, intercept, t, i, X, y)
    # All three loss branches were exercised.
    assert (branches >= 20).all(), branches
    # Other rows untouched.
    others = [k for k in range(3) if k != i]
    assert (coef[others] == 0).all() and (intercept[others] == 0).all() and (t[others] == 1).all()


@pytest.mark.parametrize("seed", [10, 11, 12, 13])
def test_sgd_step_matches_partial_fit_after_initial_fit(seed):
    rngs = [np.random.default_rng([seed, k]) for k in range(2)]
    coef, intercept, t = initial_fit(2, MEAN, STD, DISTANCE_RANGE, MASS_RANGE, ALPHA, 7, rngs)
    clf = to_sgdclassifier(coef[1], intercept[1], t[1])
    X, y = _samples(seed, 1000)
    branches = _run_both(clf, coef, intercept, t, 1, X, y)
    assert (branches >= 20).all(), branches


@pytest.mark.parametrize("alpha", [1e-4, 2.0])
def test_sgd_step_matches_partial_fit_other_alpha(alpha):
    # alpha = 2 makes the first shrink factor 1 - eta * alpha negative: sklearn clamps
    # it to 0 and folds the zero scale into w before adding the gradient.
    rng = np.random.default_rng(5)
    coef, intercept, t = rng.standard_normal((1, 3)), rng.standard_normal(1), np.ones(1)
    clf = _sklearn(alpha)
    clf.partial_fit(np.zeros((1, 3)), [0], classes=[0, 1])
    clf.coef_, clf.intercept_, clf.t_ = coef.copy(), intercept.copy(), 1.0
    X, y = _samples(6, 300)
    _run_both(clf, coef, intercept, t, 0, X, y, alpha=alpha)


def _replica_orders(seed_parts, n_uavs, epochs):
    rngs = [np.random.default_rng([*seed_parts, k]) for k in range(n_uavs)]
    return [[rngs[i].permutation(2) for _ in range(epochs)] for i in range(n_uavs)]


def test_initial_fit_reference_values():
    n = 25
    rngs = [np.random.default_rng([42, k]) for k in range(n)]
    coef, intercept, t = initial_fit(n, MEAN, STD, DISTANCE_RANGE, MASS_RANGE, ALPHA, 7, rngs)
    orders = _replica_orders([42], n, 7)
    positive_first = np.array([orders[i][0][0] == 0 for i in range(n)])
    # Both orders occur, and the rng's first draw decides the intercept's sign.
    assert positive_first.any() and not positive_first.all()
    assert_allclose(t, 15.0, rtol=0)
    assert_allclose(coef, np.tile([-7.7631, -7.7693, 7.7624], (n, 1)), atol=5e-5, rtol=0)
    assert_allclose(intercept, np.where(positive_first, 6.3246, -6.3246), atol=5e-5, rtol=0)


@pytest.mark.parametrize("epochs", [1, 7])
def test_initial_fit_matches_partial_fit(epochs):
    n = 6
    rngs = [np.random.default_rng([3, k]) for k in range(n)]
    coef, intercept, t = initial_fit(n, MEAN, STD, DISTANCE_RANGE, MASS_RANGE, ALPHA, epochs, rngs)
    assert (t == 1 + 2 * epochs).all()
    orders = _replica_orders([3], n, epochs)
    X = standardise([[1000.0, 0.5, 100.0], [6000.0, 5.0, 0.0]], MEAN, STD)
    y = [1, 0]
    for i in range(n):
        clf = _sklearn()
        for order in orders[i]:
            for j in order:
                clf.partial_fit(X[j][None], [y[j]], classes=[0, 1])
        assert_allclose(coef[i], clf.coef_[0], rtol=RTOL, atol=0)
        assert_allclose(intercept[i], clf.intercept_[0], rtol=RTOL, atol=0)
        assert t[i] == clf.t_


def test_initial_fit_needs_one_rng_per_uav():
    with pytest.raises(ValueError, match="one rng per UAV"):
        initial_fit(3, MEAN, STD, DISTANCE_RANGE, MASS_RANGE, ALPHA, 7, [np.random.default_rng()])


def test_standardise():
    X = np.array([[1000.0, 0.5, 100.0], [3500.0, 2.75, 50.0], [6000.0, 5.0, 0.0]])
    Z = standardise(X, MEAN, STD)
    assert Z.dtype == np.float64 and Z.shape == (3, 3)
    assert_allclose(Z, (X - MEAN) / STD, rtol=0)
    assert_allclose(Z[1], 0.0, atol=0)
    assert_allclose(Z[0], [-1.73205, -1.73344, 1.73190], atol=1e-5)


def test_to_sgdclassifier_agrees_and_continues():
    rng = np.random.default_rng(9)
    coef, intercept, t = rng.standard_normal((2, 3)), rng.standard_normal(2), np.array([1.0, 37.0])
    clf = to_sgdclassifier(coef[1], intercept[1], t[1])
    X = rng.standard_normal((200, 3)) * 3
    f = np.array([decision(coef, intercept, 1, *x) for x in X])
    assert_allclose(clf.decision_function(X), f, rtol=1e-12, atol=1e-13)
    assert (np.sign(f) != 0).all()
    assert (clf.predict(X) == (f > 0)).all()
    assert set(clf.predict(X)) == {0, 1}
    # Continuing: also fails if clf.coef_ aliased coef[1] (partial_fit updates in place).
    X2, y2 = _samples(4, 50)
    _run_both(clf, coef, intercept, t, 1, X2, y2)
