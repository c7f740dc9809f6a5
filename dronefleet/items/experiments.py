"""The items study's experiments E0-E5 (spec ITEM-DELIVERY.md section 11) and running them.

E1-E5 are ordinary sweep files, ``configs/sweeps/items-<experiment>.toml`` (the one source of
truth; ``dronefleet sweep run`` runs them too): each configuration is one (n, c, s) cell of one
algorithm under one option, a run holding all its trials. :func:`run_configs` runs a list of
configurations (each one's trials in one :func:`~dronefleet.items.simulate.simulate` call, the
configurations spread over processes by the executor the caller passes: this package sits below
the sweeps and their executors) into a tidy per-trial table. Trial k of every configuration
draws the same world and generation (section 10), so rows with the same trial index pair up
across algorithms and cells.

E0 (Figs 1-2) has no robots: :func:`logistic_curve` (Eq. 3, closed form) and
:func:`logistic_paths` (Eq. 10, the project's fpmath and xoshiro streams). :func:`paired_ttest`
is the section 9 test.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from ..config import SweepError, shipped_config
from ..fpmath import exp
from ..rng import normal_pair, seed_stream

__all__ = ["EXPERIMENTS", "CONFIG_COLUMNS", "RESULT_COLUMNS", "USES", "grid_path", "config_row", "run_configs",
           "logistic_curve", "logistic_paths", "paired_ttest", "E0"]

#: The experiments with a sweep file, ``configs/sweeps/items-<name>.toml``.
EXPERIMENTS = ("e1", "e2", "e3", "e4a", "e4b", "e5")
#: The keys that identify a configuration in the tidy tables (``experiment`` first).
CONFIG_COLUMNS = ("mode", "truth", "algorithm", "cas_variant", "lam_hat_source", "n_robots", "capacity", "speed",
                  "sigma_e", "mu_l", "sigma_l", "grid_spacing", "steps")
#: The per-trial results of the tidy tables.
RESULT_COLUMNS = ("trial", "seed", "generated", "served", "rate")
#: The option keys each algorithm reads (a row of another algorithm carries the defaults, which it ignores).
USES = {"R": (), "GR": ("lam_hat_source",), "GRIC": ("lam_hat_source",), "CAS": ("cas_variant", "lam_hat_source"),
        "AS": (), "ASTC": (), "SF": ()}
#: E0 (spec 11, A22): growth rate [1/step], carrying capacity, x0, noise, horizon [steps], paths, root seed.
E0 = {"lambda_g": 0.04, "K": 100.0, "x0": 1.0, "sigma_e": 0.02, "steps": 400, "paths": 100, "seed": 2015}


def grid_path(experiment: str) -> Path:
    """``configs/sweeps/items-<experiment>.toml``, shipped with the package."""
    return shipped_config("sweeps", f"items-{experiment}.toml")


def config_row(config: Any) -> dict:
    """The :data:`CONFIG_COLUMNS` of a configuration."""
    return {column: getattr(config, column) for column in CONFIG_COLUMNS}


def _trials_of(config: Any) -> dict:
    """Per-trial results of one configuration (module level: it runs in worker processes)."""
    from .simulate import simulate

    summary = simulate(config)["summary"]
    return {column: summary[column] for column in RESULT_COLUMNS}


def run_configs(configs: Iterable[Any], experiment: str, outcomes: Callable | None = None,
                done: dict | None = None) -> pd.DataFrame:
    """Every trial of every configuration of ``experiment`` as one tidy table.

    Parameters
    ----------
    configs : sequence of items configs (the runs of a sweep: ``run.config``)
        Each one's trials (``first_trial`` .. ``first_trial + trials - 1``) run in one call.
    experiment : str
        Its name, the table's ``experiment`` column.
    outcomes : callable, optional
        ``outcomes(function, items)`` yields ``(item, result, error)`` as each is done
        (:meth:`dronefleet.contract.StudyContext.map`); None: one after the other here.
    done : dict, optional
        Results by configuration already run (not run again), filled with those run here.

    Returns
    -------
    pandas.DataFrame
        One row per (configuration, trial), in the order of ``configs`` then trial:
        ``experiment``, :data:`CONFIG_COLUMNS`, :data:`RESULT_COLUMNS` (``rate``: percent of
        generated; logistic foraging: items brought home, A19).
    """
    from ..console import progress

    configs = list(configs)
    done = {} if done is None else done
    todo = list(dict.fromkeys(config for config in configs if config not in done))
    each = outcomes or (lambda function, items: ((item, function(item), None) for item in items))
    with progress(len(todo), "configuration", f"  {experiment} configurations") as bar:
        for config, result, error in each(_trials_of, todo):
            if error is not None:
                raise SweepError(f"{experiment} configuration {config_row(config)}: {error}")
            done[config] = result
            bar.update()
    frames = []
    for config in configs:
        head = {"experiment": experiment, **config_row(config)}
        trials = len(done[config]["trial"])
        frames.append(pd.DataFrame({**{k: np.repeat(v, trials) for k, v in head.items()}, **done[config]}))
    return pd.concat(frames, ignore_index=True)


def logistic_curve(steps: int = E0["steps"], lambda_g: float = E0["lambda_g"], K: float = E0["K"],
                   x0: float = E0["x0"]) -> np.ndarray:
    """Eq. (3), deterministic logistic growth in closed form: x(t) = K / (1 + ((K - x0)/x0) e^(-lambda_g t)).

    Returns (steps + 1,) populations at t = 0..steps (fpmath's exp: the same bits everywhere).
    """
    a = (K - x0) / x0
    return np.array([K / (1.0 + a * exp(-lambda_g * t)) for t in range(steps + 1)])


def logistic_paths(paths: int = E0["paths"], steps: int = E0["steps"], lambda_g: float = E0["lambda_g"],
                   K: float = E0["K"], x0: float = E0["x0"], sigma_e: float = E0["sigma_e"],
                   seed: int = E0["seed"]) -> np.ndarray:
    """Eq. (10), the Stratonovich logistic SDE by Euler with dt = 1, clipped at 0 (spec section 4).

    Path p draws its N(0, 1) deviates from the xoshiro256** stream of (``seed``, key p)
    (:func:`dronefleet.rng.seed_stream`), in pairs (Marsaglia's polar method), as the kernel does.

    Returns (paths, steps + 1) populations, column 0 = x0.
    """
    rng = np.zeros((1, paths, 4), dtype=np.uint64)
    for p in range(paths):
        seed_stream(rng, 0, p, seed, p)
    z = np.empty((paths, steps + 1))
    for p in range(paths):
        for t in range(0, steps, 2):
            z[p, t], z[p, t + 1] = normal_pair(rng, 0, p)
    x = np.empty((paths, steps + 1))
    x[:, 0] = x0
    for t in range(steps):
        v = x[:, t]
        x[:, t + 1] = np.maximum(0.0, v + (lambda_g * v * (1.0 - v / K) + 0.5 * sigma_e * sigma_e * v)
                                 + sigma_e * v * z[:, t])
    return x


def paired_ttest(a: np.ndarray, b: np.ndarray) -> dict[str, float]:
    """Section 9's two-tailed tests of ``a`` against ``b``, the per-run values of two algorithms.

    ``a[i]`` and ``b[i]`` are the pair of the same (n, trial) (common random numbers). Paired:
    t = mean(d) / (sd(d) / sqrt(len(d))), d = a - b, len(d) - 1 degrees of freedom
    (scipy.stats.ttest_rel); unpaired: Student's equal-variance test (scipy.stats.ttest_ind).
    NaN where a test is undefined (all differences equal, or fewer than 2 pairs).
    """
    from scipy import stats

    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    with np.errstate(all="ignore"):
        paired = stats.ttest_rel(a, b)
        unpaired = stats.ttest_ind(a, b, equal_var=True)
    return {"pairs": len(a), "mean_a": float(np.mean(a)), "mean_b": float(np.mean(b)),
            "mean_diff": float(np.mean(a - b)), "t_paired": float(paired.statistic), "p_paired": float(paired.pvalue),
            "t_unpaired": float(unpaired.statistic), "p_unpaired": float(unpaired.pvalue)}
