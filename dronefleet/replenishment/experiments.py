"""The replenishment study's experiment grids (REPLENISHMENT.md section 10) and running them.

The grids live in ``configs/sweeps/replenishment-figNN.toml`` (the one source of truth):
``[sweep]`` names the grid and its trials, ``[set]`` the values every configuration
shares, and each ``[[grid]]`` table one cartesian product of lists; the configurations
are the union of the products, in file order. Everything not named keeps the default of
:class:`~dronefleet.replenishment.params.Params`.

:func:`run_configs` runs a list of configurations (each one's trials in one
:func:`~dronefleet.replenishment.simulate.simulate` call, the configurations spread over
processes) into a tidy per-trial table; :func:`bounds_table` gives the analytic bounds
(section 9) of each configuration.
"""

from __future__ import annotations

import dataclasses
import functools
import itertools
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from ..config import ConfigError, read_toml
from ..sweep import SweepError
from .bounds import BoundUndefinedError, bounds
from .params import Params, ParamsError

__all__ = ["FIGURES", "CONFIG_COLUMNS", "METRIC_COLUMNS", "Grid", "grid_path", "load_grid", "config_row",
           "run_configs", "bounds_table"]

#: The study's figures whose grid is ``configs/sweeps/replenishment-<figure>.toml``.
FIGURES = ("fig09", "fig10", "fig11", "fig12")
#: The parameters that identify a configuration in the tidy tables (trials and sampling do not).
CONFIG_COLUMNS = ("strategy", "n_workers", "n_chargers", "charger_capacity_factor", "work_ratio",
                  "charge_rate", "transfer_loss", "worker_capacity", "ticks")
#: The per-trial metrics of the tidy table (simulate's per-trial results besides trial and seed).
METRIC_COLUMNS = ("work", "energy", "work_energy", "efficiency", "efficiency_with_loss",
                  "depleted_workers", "depleted_chargers", "shared", "lost")

_SECTIONS = ("sweep", "set", "grid")
_SWEEP_KEYS = ("name", "scenario", "trials")
# trials is per grid ([sweep] trials); sample_every only shapes the time series, not kept here.
_PARAMETERS = tuple(f.name for f in dataclasses.fields(Params) if f.name not in ("trials", "sample_every"))


@dataclass(frozen=True)
class Grid:
    """One experiment grid: its configurations (validated) and trials per configuration."""

    path: Path
    name: str
    trials: int
    configs: tuple[Params, ...]


def grid_path(figure: str) -> Path:
    """``configs/sweeps/replenishment-<figure>.toml`` of the source tree this package runs from."""
    path = Path(__file__).resolve().parents[2] / "configs" / "sweeps" / f"replenishment-{figure}.toml"
    if not path.is_file():
        raise SweepError(f"the grid of {figure} needs {path}, which is missing: run from a clone of the "
                         "repository (pip install -e .)")
    return path


def _check_names(table, allowed, where):
    if not isinstance(table, dict):
        raise SweepError(f"{where} must be a table of key = value")
    for key in table:
        if key not in allowed:
            raise SweepError(f"{where}: unknown key {key!r}. Allowed: {', '.join(allowed)}", (key,))


def load_grid(path, changes=None, trials=None) -> Grid:
    """Read a grid file and validate every configuration, before anything runs.

    Parameters
    ----------
    path : str or Path
    changes : dict, optional
        Parameter values overriding ``[set]`` and the grids (``{"ticks": 1500}`` for a quick variant).
    trials : int, optional
        Trials per configuration, overriding ``[sweep] trials``.

    Raises
    ------
    SweepError
        Unreadable file, unknown section or key (the message lists the allowed ones), an
        empty list, or a value :meth:`Params.validate` refuses (naming the grid point).
    """
    path = Path(path)
    try:
        _, doc = read_toml(path, "grid file")
    except ConfigError as error:
        raise SweepError(str(error)) from None
    _check_names(doc, _SECTIONS, f"{path}: sections")
    head = doc.get("sweep", {})
    _check_names(head, _SWEEP_KEYS, f"{path}: [sweep]")
    if head.get("scenario", "replenishment") != "replenishment":
        raise SweepError(f"{path}: [sweep] scenario = {head['scenario']!r}: a grid file of the "
                         "replenishment study needs \"replenishment\"")
    trials = head.get("trials", Params.trials) if trials is None else trials
    if isinstance(trials, bool) or not isinstance(trials, int) or trials < 1:
        raise SweepError(f"{path}: trials = {trials!r} is not allowed: must be an integer >= 1")
    shared = doc.get("set", {})
    _check_names(shared, _PARAMETERS, f"{path}: [set]")
    products = doc.get("grid")
    if not isinstance(products, list) or not products:
        raise SweepError(f"{path}: needs at least one [[grid]] table of lists")
    configs = []
    for n, product in enumerate(products, 1):
        where = f"{path}: [[grid]] {n}"
        _check_names(product, _PARAMETERS, where)
        for key, values in product.items():
            if not isinstance(values, list) or not values:
                raise SweepError(f"{where}: {key} must be a non-empty list of values, got {values!r}", (key,))
        for point in itertools.product(*product.values()):
            values = {**shared, **dict(zip(product, point)), **(changes or {})}
            try:
                configs.append(dataclasses.replace(Params(), **values).validate())
            except ParamsError as error:
                at = ", ".join(f"{k} = {v!r}" for k, v in zip(product, point))
                raise SweepError(f"{where} at {at}: {error}", error.keys) from None
    return Grid(path.absolute(), head.get("name", path.stem), trials, tuple(configs))


def config_row(params: Params) -> dict:
    """The :data:`CONFIG_COLUMNS` of ``params``."""
    return {column: getattr(params, column) for column in CONFIG_COLUMNS}


def _trials_of(params: Params, trials: int) -> dict:
    """Per-trial columns of one configuration (module level: it runs in worker processes)."""
    from .simulate import simulate

    result = simulate(params, trials)
    return {column: result[column] for column in ("trial", "seed", *METRIC_COLUMNS)}


def run_configs(configs, trials, jobs=1) -> pd.DataFrame:
    """Every trial of every configuration as one tidy table.

    Parameters
    ----------
    configs : sequence of Params
    trials : int
        Trials per configuration (trial k uses seed 876 k), all in one ``simulate`` call.
    jobs : int
        Processes (:func:`dronefleet.executors.local`; the first configuration runs here
        and compiles or loads the kernel before any worker starts).

    Returns
    -------
    pandas.DataFrame
        ``len(configs) * trials`` rows in the order of ``configs`` then trial:
        :data:`CONFIG_COLUMNS`, ``trial``, ``seed`` and :data:`METRIC_COLUMNS`.
    """
    from ..executors import local

    configs = list(configs)
    function = functools.partial(_trials_of, trials=trials)
    results = {}
    for params, result, error in local(function, configs, jobs):
        if error is not None:
            raise SweepError(f"configuration {config_row(params)}: {error}")
        results[params] = result
    frames = []
    for params in configs:
        per_trial = results[params]
        head = pd.DataFrame({column: np.repeat(value, trials) for column, value in config_row(params).items()})
        frames.append(pd.concat([head, pd.DataFrame(per_trial)], axis=1))
    return pd.concat(frames, ignore_index=True)


def bounds_table(configs) -> pd.DataFrame:
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
