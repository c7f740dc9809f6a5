"""Linear bidding policy of each UAV and its online learner (docs/delivery-model.md sections 6 and 8).

Every UAV owns a linear classifier identical to scikit-learn's
``SGDClassifier(loss="modified_huber", penalty="l2", alpha=0.01,
learning_rate="optimal", eta0=0.01, fit_intercept=True)``. The kernels here
re-implement one ``partial_fit`` step (scikit-learn's ``_plain_sgd`` with
``max_iter=1`` and ``WeightVector``) with the same floating-point operations in the
same order, so coefficients agree bit for bit with the installed scikit-learn.

State is a structure of arrays, one row per UAV:

- ``coef`` : (S, 3) float64, weights on standardised [distance, mass, SoC];
- ``intercept`` : (S,) float64;
- ``t`` : (S,) float64, scikit-learn's step counter ``t_`` (1.0 before any step).

scikit-learn is imported only by :func:`to_sgdclassifier`; the kernels never need it.
"""

import numpy as np

from ..jit import borrowing, njit

# WeightVector folds its scale into the weights when it falls below this (float64).
_WSCALE_RESET = 1e-9


@njit(cache=True)
def _modified_huber_dloss(y, p):
    """Derivative of the modified Huber loss w.r.t. the prediction ``p``, ``y`` in {-1, +1}.

    Its magnitude is at most 4, so scikit-learn's clipping at 1e12 never applies.
    """
    z = p * y
    if z >= 1.0:
        return 0.0
    elif z >= -1.0:
        return 2.0 * (1.0 - z) * -y
    else:
        return -4.0 * y


@njit(cache=True)
def optimal_init(alpha):
    """Bottou's ``t0`` for the "optimal" schedule, as scikit-learn computes it.

    Parameters
    ----------
    alpha : float
        L2 regularisation strength.

    Returns
    -------
    float
        ``t0`` such that the first step's rate ``1 / (alpha * t0)`` equals the
        heuristic initial rate for a typical weight ``sqrt(1 / sqrt(alpha))``.
    """
    typw = np.sqrt(1.0 / np.sqrt(alpha))
    initial_eta0 = typw / max(1.0, _modified_huber_dloss(1.0, -typw))
    return 1.0 / (initial_eta0 * alpha)


@borrowing
def decision(coef, intercept, i, x0, x1, x2):
    """Decision function ``f = w . x + b`` of UAV ``i``.

    Parameters
    ----------
    coef : ndarray of float64, shape (S, 3)
    intercept : ndarray of float64, shape (S,)
    i : int
        UAV id (row).
    x0, x1, x2 : float
        Standardised distance, mass and SoC (dimensionless).

    Returns
    -------
    float
        ``f``; the UAV bids iff ``f >= 0``.
    """
    # Summed left to right from 0.0 like WeightVector.dot, so sgd_step sees sklearn's p.
    p = 0.0
    p += coef[i, 0] * x0
    p += coef[i, 1] * x1
    p += coef[i, 2] * x2
    return p + intercept[i]


@borrowing
def sgd_step(coef, intercept, t, i, x0, x1, x2, y, alpha, t0):
    """One ``partial_fit`` step of UAV ``i``'s classifier, in place.

    Parameters
    ----------
    coef : ndarray of float64, shape (S, 3)
        Weights; row ``i`` is updated.
    intercept : ndarray of float64, shape (S,)
        Intercepts; entry ``i`` is updated.
    t : ndarray of float64, shape (S,)
        Step counters (scikit-learn's ``t_``); entry ``i`` is incremented by 1.
    i : int
        UAV id (row).
    x0, x1, x2 : float
        Standardised distance, mass and SoC of the sample.
    y : float
        Label: 1.0 delivered, 0.0 aborted.
    alpha : float
        L2 regularisation strength.
    t0 : float
        ``optimal_init(alpha)``.
    """
    ys = 1.0 if y > 0 else -1.0
    p = decision(coef, intercept, i, x0, x1, x2)
    eta = 1.0 / (alpha * (t0 + t[i] - 1.0))
    update = -eta * _modified_huber_dloss(ys, p)

    # L2 shrink, kept as a separate scale like WeightVector (w is stored / wscale).
    wscale = max(0.0, 1.0 - eta * alpha)
    if wscale < _WSCALE_RESET:
        coef[i, 0] *= wscale
        coef[i, 1] *= wscale
        coef[i, 2] *= wscale
        wscale = 1.0

    if update != 0.0:
        step = update / wscale
        coef[i, 0] += x0 * step
        coef[i, 1] += x1 * step
        coef[i, 2] += x2 * step
        intercept[i] += update

    # reset_wscale at the end of each _plain_sgd call.
    coef[i, 0] *= wscale
    coef[i, 1] *= wscale
    coef[i, 2] *= wscale
    t[i] += 1.0


@njit(cache=True)
def _fit_epochs(coef, intercept, t, X, y, orders, alpha, t0):
    """Run ``sgd_step`` over samples ``X[orders[i, e, k]]`` for every UAV ``i``.

    Parameters
    ----------
    coef, intercept, t : ndarrays of float64, shapes (S, 3), (S,), (S,)
        Learner state, updated in place.
    X : ndarray of float64, shape (n, 3)
        Standardised samples.
    y : ndarray of int64, shape (n,)
        Labels in {0, 1}.
    orders : ndarray of int64, shape (S, epochs, n)
        Presentation order of each UAV's epochs.
    alpha, t0 : float
        Regularisation strength and ``optimal_init(alpha)``.
    """
    for i in range(orders.shape[0]):
        for e in range(orders.shape[1]):
            for k in range(orders.shape[2]):
                j = orders[i, e, k]
                sgd_step(coef, intercept, t, i, X[j, 0], X[j, 1], X[j, 2], y[j], alpha, t0)


def standardise(X, mean, std):
    """Standardise raw features.

    Parameters
    ----------
    X : array_like, shape (n, 3)
        Raw [distance_m, mass_kg, soc_pct].
    mean, std : array_like, shape (3,)
        Per-feature mean and standard deviation, same units as ``X``.

    Returns
    -------
    ndarray of float64, shape (n, 3)
        ``(X - mean) / std``.
    """
    return (np.asarray(X, dtype=np.float64) - np.asarray(mean, dtype=np.float64)) / np.asarray(
        std, dtype=np.float64
    )


def initial_fit(n_uavs, mean, std, distance_range, mass_range, alpha, epochs, rngs):
    """Initial fit of every UAV on the two assumed points (docs/delivery-model.md section 8).

    From ``w = 0``, ``b = 0``, ``t = 1``, ``epochs`` epochs over the points
    ``([d_min, m_min, 100], 1)`` and ``([d_max, m_max, 0], 0)``, each epoch's order
    being ``rngs[i].permutation(2)`` (index 0 is the positive point).

    Parameters
    ----------
    n_uavs : int
        Fleet size S.
    mean, std : array_like, shape (3,)
        Standardisation of [distance_m, mass_kg, soc_pct].
    distance_range : (float, float)
        ``(d_min, d_max)`` in m.
    mass_range : (float, float)
        ``(m_min, m_max)`` in kg.
    alpha : float
        L2 regularisation strength.
    epochs : int
        Number of epochs (7 reproduces scikit-learn <= 1.7 ``fit``).
    rngs : sequence of numpy.random.Generator, length S
        Learner stream of each UAV; epochs' orders are drawn from it.

    Returns
    -------
    coef : ndarray of float64, shape (S, 3)
    intercept : ndarray of float64, shape (S,)
    t : ndarray of float64, shape (S,)
        Equal to ``1 + 2 * epochs``.
    """
    if len(rngs) != n_uavs:
        raise ValueError(f"need one rng per UAV: got {len(rngs)} for {n_uavs} UAVs")
    raw = np.array(
        [
            [distance_range[0], mass_range[0], 100.0],
            [distance_range[1], mass_range[1], 0.0],
        ]
    )
    X = standardise(raw, mean, std)
    y = np.array([1.0, 0.0])  # float, as the engine's labels: one compiled sgd_step
    orders = np.empty((n_uavs, epochs, 2), dtype=np.int64)
    for i in range(n_uavs):
        for e in range(epochs):
            orders[i, e] = rngs[i].permutation(2)
    coef = np.zeros((n_uavs, 3))
    intercept = np.zeros(n_uavs)
    t = np.ones(n_uavs)
    _fit_epochs(coef, intercept, t, X, y, orders, alpha, optimal_init(alpha))
    return coef, intercept, t


def to_sgdclassifier(coef_row, intercept, t, alpha=0.01, eta0=0.01):
    """A fitted scikit-learn ``SGDClassifier`` equal to one UAV's policy.

    Its ``decision_function`` and ``predict`` (on standardised features) agree with
    :func:`decision`, and further ``partial_fit`` calls continue as :func:`sgd_step`.

    Parameters
    ----------
    coef_row : array_like of float, shape (3,)
    intercept : float
    t : float
        Step counter (``t_``).
    alpha, eta0 : float
        Learner parameters (``eta0`` is unused by the "optimal" schedule).

    Returns
    -------
    sklearn.linear_model.SGDClassifier
    """
    from sklearn.linear_model import SGDClassifier

    # Fixed random_state: otherwise partial_fit draws from numpy's global RNG.
    clf = SGDClassifier(
        loss="modified_huber",
        penalty="l2",
        alpha=alpha,
        learning_rate="optimal",
        eta0=eta0,
        fit_intercept=True,
        random_state=0,
    )
    # One dummy step creates every fitted attribute; the state is then overwritten.
    clf.partial_fit(np.zeros((1, 3)), [0], classes=[0, 1])
    # Copies: partial_fit updates coef_ in place and must not touch the caller's arrays.
    clf.coef_ = np.array(coef_row, dtype=np.float64).reshape(1, 3)
    clf.intercept_ = np.array([intercept], dtype=np.float64)
    clf.t_ = float(t)
    return clf
