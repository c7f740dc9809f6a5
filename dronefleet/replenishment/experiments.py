"""The replenishment study's experiment grids (docs/replenishment-model.md section 10) and running them.

The grids live in ``configs/sweeps/replenishment-figNN.toml`` (the one source of truth), sweep
files read like any other (:func:`dronefleet.sweeps.load_sweep`): ``[set]`` holds the values
every configuration shares (``trials`` among them), and each ``[[grid]]`` table one cartesian
product of lists; the configurations are the union of the products, in file order, each a
run holding all its trials. Everything not named keeps the default of
``configs/replenishment.toml``. ``dronefleet sweep run`` writes them into a hive dataset;
``dronefleet reproduce`` runs them here, in memory (seconds).

:func:`run_configs` runs a list of configurations (each one's trials in one
:func:`~dronefleet.replenishment.simulate.simulate` call, the configurations spread over
processes by the executor the caller passes: this package sits below the sweeps and their
executors, docs/scenario-contract.md) into a tidy per-trial table; :func:`bounds_table` gives the analytic bounds
(section 9) of each configuration.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd

from ..config import SweepError, shipped_config
from .bounds import BoundUndefinedError, bounds
from .params import Params

if TYPE_CHECKING:
    from .config import Config

__all__ = ["FIGURES", "CONFIG_COLUMNS", "METRIC_COLUMNS", "grid_path", "config_row", "run_configs",
           "bounds_table"]

#: The study's figures whose grid is ``configs/sweeps/replenishment-<figure>.toml``.
FIGURES = ("fig09", "fig10", "fig11", "fig12")
#: The parameters that identify a configuration in the tidy tables (trials and sampling do not).
CONFIG_COLUMNS = ("strategy", "n_workers", "n_chargers", "charger_capacity_factor", "work_ratio",
                  "charge_rate", "transfer_loss", "worker_capacity", "ticks")
#: The per-trial metrics of the tidy table (simulate's per-trial results besides trial and seed).
METRIC_COLUMNS = ("work", "energy", "work_energy", "efficiency", "efficiency_with_loss",
                  "depleted_workers", "depleted_chargers", "shared", "lost")


def grid_path(figure: str) -> Path:
    """``configs/sweeps/replenishment-<figure>.toml``, shipped with the package."""
    return shipped_config("sweeps", f"replenishment-{figure}.toml")


def config_row(params: Params) -> dict:
    """The :data:`CONFIG_COLUMNS` of ``params``."""
    return {column: getattr(params, column) for column in CONFIG_COLUMNS}


def _trials_of(config) -> dict:
    """Per-trial columns of one configuration (module level: it runs in worker processes)."""
    from .simulate import simulate

    result = simulate(config.params, first_trial=config.first_trial)
    return {column: result[column] for column in ("trial", "seed", *METRIC_COLUMNS)}


def run_configs(configs: Iterable[Config], outcomes: Callable | None = None,
                done: dict[Config, dict[str, Any]] | None = None) -> pd.DataFrame:
    """Every trial of every configuration as one tidy table.

    Parameters
    ----------
    configs : sequence of replenishment configs (:class:`dronefleet.replenishment.config.Config`)
        Each one's trials (``first_trial`` .. ``first_trial + trials - 1``, trial k with seed
        876 k) run in one ``simulate`` call; the runs of a sweep give them (``run.config``).
    outcomes : callable, optional
        ``outcomes(function, items)`` yields ``(item, result, error)`` as each item is done
        (:class:`dronefleet.contract.StudyContext.map`: ``reproduce`` spreads them over its
        ``--jobs`` processes); None: one after the other in this process. A bar counts the
        configurations done (:func:`dronefleet.console.progress`: on a terminal only).
    done : dict, optional
        Per-trial results by configuration, already run (those are not run again) and
        filled with the ones run here: figures that share configurations, or that run
        together on one set of workers, pass the same dict.

    Returns
    -------
    pandas.DataFrame
        One row per trial in the order of ``configs`` then trial: :data:`CONFIG_COLUMNS`,
        ``trial``, ``seed`` and :data:`METRIC_COLUMNS`.
    """
    from ..console import progress

    configs = list(configs)
    done = {} if done is None else done
    todo = list(dict.fromkeys(config for config in configs if config not in done))
    each = outcomes or (lambda function, items: ((item, function(item), None) for item in items))
    with progress(len(todo), "configuration", "  configurations") as bar:
        for config, result, error in each(_trials_of, todo):
            if error is not None:
                raise SweepError(f"configuration {config_row(config.params)}: {error}")
            done[config] = result
            bar.update()
    frames = []
    for config in configs:
        trials = config.params.trials
        head = pd.DataFrame({column: np.repeat(value, trials) for column, value in config_row(config.params).items()})
        frames.append(pd.concat([head, pd.DataFrame(done[config])], axis=1))
    return pd.concat(frames, ignore_index=True)


def bounds_table(configs: Iterable[Params]) -> pd.DataFrame:
    """The section 9 bounds of each configuration (its strategy's reference bound).

    Returns
    -------
    pandas.DataFrame
        One row per configuration: :data:`CONFIG_COLUMNS`, ``bound_work`` (points),
        ``bound_efficiency`` (for mobile with lambda > 0: work energy / (total + lost)),
        ``bound_duty``; NaN where the bound does not exist (section 9's validity conditions).
    """
    rows = []
    for params in configs:
        try:
            b = bounds(params)
            values = {"bound_work": b.work, "bound_efficiency": b.efficiency, "bound_duty": b.duty}
        except BoundUndefinedError:
            values = dict.fromkeys(("bound_work", "bound_efficiency", "bound_duty"), np.nan)
        rows.append({**config_row(params), **values})
    return pd.DataFrame(rows)
