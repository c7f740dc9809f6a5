"""Tidy tables for the study's figures (docs/delivery-experiments.md, Figures 16-20), from the runs' tables.

Every function takes pandas DataFrames as read from a sweep's parquet datasets
(``pd.read_parquet("results/<sweep>/<table>")``: the run table's own columns plus the
grid keys and ``seed``) and returns a tidy DataFrame; nothing here simulates. A run is
identified by its grid keys (the ``by`` argument) and its seed.

Grid keys read by ``pd.read_parquet`` from hive-partitioned directories come back as
categoricals, and a float key such as ``tau_minutes=15.0`` as the strings ``"15.0"``
(``dronefleet.sweeps.dataset`` types them); every function returns them as plain values
(numbers where every value is one) so that they sort and plot as numbers.

Units are those of ``dronefleet.records``: seconds, metres, kilograms, SoC in percent.

==========  ================================================================
Figure      functions
==========  ================================================================
16, 19      :func:`run_outcomes` (a, b), :func:`backlog_by_arrival_week` (c)
17          :func:`weekly_accuracy`
18          :func:`winner_soh_grid`
19          :func:`threshold_table`, :func:`best_threshold_runs`
20          :func:`backlog_by_arrival_week` with ``by=("rule",)`` (its ``pending``)
==========  ================================================================
"""

from collections.abc import Sequence

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike

from .config import Config
from .metrics import by_arrival_week
from .policy import standardise

#: Metrics of the ``summary`` table that :func:`run_outcomes` keeps.
OUTCOMES = ("orders_arrived", "delivered", "median_delivery_time_s", "attempts", "aborted_pct", "pending",
            "backlog_age_s", "lost_uavs", "decision_accuracy")


def _read_only(values):
    """``values`` as a float64 array that cannot be changed in place (it is a default argument)."""
    array = np.asarray(values, dtype=np.float64)
    array.flags.writeable = False
    return array


#: Figure 18's grid: SoC [%], distance [m], mass [kg]. Built from integers so that every
#: value is the double nearest its decimal (0.55, not 0.5 + 0.05 = 0.55000000000000004).
SOC_GRID = _read_only(np.arange(10, 101, 10))
DISTANCE_GRID = _read_only(np.arange(1000, 5001, 50))
MASS_GRID = _read_only(np.arange(50, 501, 5) / 100.0)


def _plain(column):
    """A grid-key column as plain values: categoricals decoded, all-numeric strings as numbers."""
    if isinstance(column.dtype, pd.CategoricalDtype):
        # Convert the few categories, not the millions of values.
        categories = _plain(pd.Series(column.cat.categories))
        return column.cat.rename_categories(categories.to_numpy()).astype(categories.dtype)
    if pd.api.types.is_string_dtype(column):
        numbers = pd.to_numeric(column, errors="coerce")
        if numbers.notna().all():
            return numbers
    return column


def _select(frame, keys, columns):
    """A copy of ``frame[keys + columns]`` with plain key columns; a clear error if one is missing."""
    wanted = [*keys, *columns]
    missing = [name for name in wanted if name not in frame.columns]
    if missing:
        raise KeyError(f"missing column(s) {missing}; the table has {list(frame.columns)}")
    out = frame[wanted].reset_index(drop=True)
    for key in keys:
        out[key] = _plain(out[key])
    return out


def _groups(frame, keys):
    """The groupby of ``frame`` over ``keys`` used everywhere: sorted, observed values, nan kept."""
    return frame.groupby(list(keys), sort=True, observed=True, dropna=False)


def run_outcomes(summary: pd.DataFrame, by: Sequence[str] = ("rule", "tau_minutes")) -> pd.DataFrame:
    """One row per run with the metrics of Figures 16 and 19, panels (a) and (b).

    Parameters
    ----------
    summary : pandas.DataFrame
        The sweep's ``summary`` table: one row per run, with the grid keys ``by``, ``seed``
        and the metrics of :func:`dronefleet.delivery.metrics.run_metrics`.
    by : sequence of str
        Grid keys that, with ``seed``, identify a run.

    Returns
    -------
    pandas.DataFrame
        Columns ``*by, seed`` and :data:`OUTCOMES`: orders_arrived, delivered (parcels),
        median_delivery_time_s (per-run median, s), attempts, aborted_pct (% of attempts),
        pending (orders), backlog_age_s (s), lost_uavs, decision_accuracy (0..1); sorted by
        the keys.

    Raises
    ------
    ValueError
        If two rows share the same keys (a grid key is missing from ``by``).
    """
    keys = [*by, "seed"]
    out = _select(summary, keys, OUTCOMES)
    if out.duplicated(keys).any():
        raise ValueError(f"several summary rows per {keys}: is a grid key missing from by?")
    return out.sort_values(keys, ignore_index=True)


def backlog_by_arrival_week(orders: pd.DataFrame, horizon_s: float,
                            by: Sequence[str] = ("rule", "tau_minutes")) -> pd.DataFrame:
    """Pending orders and backlog age at the horizon by arrival week, for every run.

    The same computation as :func:`dronefleet.delivery.metrics.by_arrival_week`, done for all runs
    at once. Figures 16c and 19c stack ``backlog_age_s``; Figure 20 compares ``pending``
    with and without reservations (``by=("rule",)``).

    Parameters
    ----------
    orders : pandas.DataFrame
        The sweep's ``orders`` table: one row per order with the grid keys ``by``,
        ``seed``, ``arrival_s`` and ``delivered_s`` (s; null or nan: not delivered by the
        horizon).
    horizon_s : float
        The runs' common horizon, s (every arrival lies in [0, horizon_s)).
    by : sequence of str
        Grid keys that, with ``seed``, identify a run.

    Returns
    -------
    pandas.DataFrame
        One row per run and arrival week 1..ceil(horizon / week), sorted: ``*by, seed,
        arrival_week, arrived`` (orders), ``pending`` (orders not delivered by the horizon),
        ``backlog_age_s`` (sum of horizon - arrival over them, s).
    """
    keys = [*by, "seed"]
    frame = _select(orders, keys, ("arrival_s", "delivered_s"))
    groups = _groups(frame, keys)
    table = by_arrival_week(frame["arrival_s"].to_numpy(np.float64),
                            frame["delivered_s"].to_numpy(np.float64, na_value=np.nan),
                            horizon_s, run=groups.ngroup().to_numpy())
    runs = groups.size().index.to_frame(index=False)
    return pd.concat([runs.iloc[table["run"]].reset_index(drop=True), table.drop(columns="run")], axis=1)


def weekly_accuracy(fleet: pd.DataFrame, by: Sequence[str] = ("rule",), confidence: float = 0.95) -> pd.DataFrame:
    """Mean decision accuracy per week with its confidence band (Figure 17).

    The sample is every UAV of every run in a group (25 UAVs x 20 runs = 500 per rule in
    the study), each UAV's accuracy counted once; the band is the t-interval of the mean,
    mean +- t(n - 1) s / sqrt(n) with s the sample standard deviation over the n UAVs.
    UAVs of one run share their orders and so are not independent; treating them as
    independent, as the study's 500-UAV sample does, gives a narrower band than one over
    the runs' fleet means would.

    Parameters
    ----------
    fleet : pandas.DataFrame
        The sweep's ``fleet`` table: one row per UAV per week end, with the grid keys
        ``by``, ``week`` and ``decision_accuracy`` (0..1; nan rows are left out).
    by : sequence of str
        Grid keys to keep apart (the rule in Figure 17).
    confidence : float
        Coverage of the band.

    Returns
    -------
    pandas.DataFrame
        One row per group and week: ``*by, week, uavs`` (sample size n),
        ``mean_accuracy``, ``ci_low``, ``ci_high`` (0..1; nan if n < 2), ``confidence``.
    """
    from scipy import stats  # here: scipy.stats alone takes 0.4 s to import, and only this needs it

    keys = [*by, "week"]
    frame = _select(fleet, keys, ("decision_accuracy",)).dropna(subset=["decision_accuracy"])
    out = _groups(frame, keys)["decision_accuracy"].agg(uavs="count", mean_accuracy="mean", sd="std")
    out = out.reset_index()
    half = stats.t.ppf(0.5 + confidence / 2.0, out["uavs"] - 1) * out["sd"] / np.sqrt(out["uavs"])
    out["ci_low"] = out["mean_accuracy"] - half
    out["ci_high"] = out["mean_accuracy"] + half
    out["confidence"] = confidence
    return out.drop(columns="sd")


def winner_soh_grid(final_policies: pd.DataFrame, config: Config, socs: ArrayLike = SOC_GRID,
                    distances_m: ArrayLike = DISTANCE_GRID, masses_kg: ArrayLike = MASS_GRID) -> pd.DataFrame:
    """Mean SoH of the least_confident winner over a grid of orders and SoCs (Figure 18).

    For every SoC, distance and mass, one auction among each run's UAVs, all at that
    SoC (lost UAVs take no part): a UAV bids iff f >= 0 and the bidder with the lowest
    f / ||w|| wins, ties to the highest UAV id, exactly as ``auction.least_confident`` in
    the engine (f summed in the engine's order, so ties are ties here too). The winner's
    SoH is then averaged over the runs that have a winner. Vectorised over runs, UAVs
    and orders, one SoC at a time (20 runs x 25 UAVs x 7371 orders: 30 MB per array).

    Parameters
    ----------
    final_policies : pandas.DataFrame
        One row per UAV of each run at the end of its last week (the ``fleet`` rows of
        the last ``week`` of one condition): ``seed, uav, soh, w_distance, w_mass, w_soc,
        intercept`` and optionally ``lost`` (bool).
    config : Config
        Its ``scaler_mean`` and ``scaler_std`` standardise the features.
    socs : array_like of float
        SoCs, %.
    distances_m, masses_kg : array_like of float
        Order distances (m) and parcel masses (kg).

    Returns
    -------
    pandas.DataFrame
        One row per (soc, distance_m, mass_kg), in that order of nesting:
        ``mean_winner_soh`` (nan where nobody bid in any run), ``runs_with_winner`` and
        ``runs`` (number of runs).

    Raises
    ------
    ValueError
        If a (seed, uav) appears twice, or a policy has w = 0 (no bid value f / ||w||).
    """
    policies = final_policies
    if "lost" in policies.columns:
        policies = policies[~policies["lost"].astype(bool)]
    frame = _select(policies, ["seed"], ("uav", "soh", "w_distance", "w_mass", "w_soc", "intercept"))
    if frame.duplicated(["seed", "uav"]).any():
        raise ValueError("several rows per (seed, uav): pass the last week's fleet rows of one condition")
    frame = frame.sort_values(["seed", "uav"], ignore_index=True)
    # Runs x slots, UAVs in ascending id within a run so that the last best slot is the highest
    # id; a run with fewer UAVs (some lost) has padding slots that never bid.
    runs = _groups(frame, ["seed"])
    run, slot = runs.ngroup().to_numpy(), runs.cumcount().to_numpy()
    shape = (run.max() + 1, slot.max() + 1)
    present = np.zeros(shape, dtype=bool)
    present[run, slot] = True
    coef = np.zeros(shape + (3,))
    coef[run, slot] = frame[["w_distance", "w_mass", "w_soc"]].to_numpy(np.float64)
    intercept, soh = np.zeros(shape), np.zeros(shape)
    intercept[run, slot] = frame["intercept"].to_numpy(np.float64)
    soh[run, slot] = frame["soh"].to_numpy(np.float64)
    w_norm = np.sqrt(coef[..., 0] * coef[..., 0] + coef[..., 1] * coef[..., 1] + coef[..., 2] * coef[..., 2])
    if (w_norm[present] == 0.0).any():
        raise ValueError("a policy has w = 0, so it has no bid value f / ||w||")
    w_norm[~present] = 1.0

    distance, mass = (a.ravel() for a in np.meshgrid(np.asarray(distances_m, dtype=np.float64),
                                                     np.asarray(masses_kg, dtype=np.float64), indexing="ij"))
    mean, std = np.array(config.scaler_mean), np.array(config.scaler_std)
    parts = []
    for soc in np.asarray(socs, dtype=np.float64):
        x = standardise(np.column_stack([distance, mass, np.full(distance.shape, soc)]), mean, std)
        # f of policy.decision, (((0 + w0 x0) + w1 x1) + w2 x2) + b: shape (runs, slots, orders).
        f = coef[:, :, 0, None] * x[:, 0]
        f += coef[:, :, 1, None] * x[:, 1]
        f += coef[:, :, 2, None] * x[:, 2]
        f += intercept[:, :, None]
        bids = (f >= 0.0) & present[:, :, None]
        score = np.negative(np.divide(f, w_norm[:, :, None], out=f), out=f)  # least_confident: -(f / ||w||)
        score[~bids] = -np.inf
        best = bids & (score == score.max(axis=1, keepdims=True))
        winner = best.shape[1] - 1 - np.argmax(best[:, ::-1], axis=1)  # the last best slot
        has_winner = bids.any(axis=1)
        runs_with_winner = has_winner.sum(axis=0)
        total = np.where(has_winner, np.take_along_axis(soh, winner, axis=1), 0.0).sum(axis=0)
        parts.append(pd.DataFrame({
            "soc": soc, "distance_m": distance, "mass_kg": mass,
            "mean_winner_soh": np.where(runs_with_winner > 0, total / np.maximum(runs_with_winner, 1), np.nan),
            "runs_with_winner": runs_with_winner, "runs": shape[0],
        }))
    return pd.concat(parts, ignore_index=True)


def threshold_table(outcomes: pd.DataFrame) -> tuple[pd.DataFrame, float]:
    """Figure 19's table: every threshold(theta) over all tau and seeds, and the best theta.

    The best theta is the study's: the most deliveries and the shortest delivery times
    (docs/delivery-experiments.md, Figure 19), both read as medians over a theta's runs, the centres of
    Figure 19a's boxes (the delivery time of a run is already a median, and a mean of
    medians would mix the two). Each theta is ranked on both measures (1 = most delivered
    parcels, 1 = shortest delivery time; equal values share the better rank) and the lowest
    sum of the two ranks wins. That winner is always on the Pareto front of the two
    measures (no other theta is as good on both and better on one); when the measures
    conflict, so that several theta share the lowest sum, the most deliveries win, then
    the shorter delivery time, then the lower theta.

    Parameters
    ----------
    outcomes : pandas.DataFrame
        :func:`run_outcomes` rows of threshold runs only, with a ``theta`` column (%).

    Returns
    -------
    table : pandas.DataFrame
        One row per theta, ascending: ``theta, runs, delivered_mean, delivered_median``
        (parcels per run), ``median_delivery_time_s`` (median over runs of the per-run
        median, s), ``aborted_pct_mean`` (%), ``pending_mean`` (orders), ``backlog_age_s_mean``
        (s), ``delivered_rank``, ``delivery_time_rank`` (1 = best; a theta whose runs delivered
        nothing has no delivery time and ranks last), ``best`` (bool).
    best_theta : float
    """
    if "rule" in outcomes.columns and (_plain(outcomes["rule"]) != "threshold").any():
        raise ValueError("threshold_table takes threshold runs only")
    frame = _select(outcomes, ["theta"], ("delivered", "median_delivery_time_s", "aborted_pct", "pending",
                                          "backlog_age_s"))
    groups = _groups(frame, ["theta"])
    table = groups.agg(runs=("delivered", "size"), delivered_mean=("delivered", "mean"),
                       delivered_median=("delivered", "median"),
                       median_delivery_time_s=("median_delivery_time_s", "median"),
                       aborted_pct_mean=("aborted_pct", "mean"), pending_mean=("pending", "mean"),
                       backlog_age_s_mean=("backlog_age_s", "mean")).reset_index()
    table["delivered_rank"] = table["delivered_median"].rank(method="min", ascending=False).astype(int)
    table["delivery_time_rank"] = table["median_delivery_time_s"].rank(method="min", na_option="bottom").astype(int)
    ranked = table.assign(rank_sum=table["delivered_rank"] + table["delivery_time_rank"]).sort_values(
        ["rank_sum", "delivered_median", "median_delivery_time_s", "theta"], ascending=[True, False, True, True],
        na_position="last")
    best_theta = float(ranked["theta"].iloc[0])
    table["best"] = table["theta"] == best_theta
    return table, best_theta


def best_threshold_runs(frame: pd.DataFrame, theta: float) -> pd.DataFrame:
    """The rows of threshold(``theta``) runs, labelled to sit beside learning runs (Fig. 19 a-c).

    Parameters
    ----------
    frame : pandas.DataFrame
        Rows of threshold runs with a ``theta`` column, e.g. from :func:`run_outcomes` or
        :func:`backlog_by_arrival_week` with ``by=("theta", "tau_minutes")``.
    theta : float
        The threshold to keep, % (:func:`threshold_table`'s best, or one chosen by hand).

    Returns
    -------
    pandas.DataFrame
        Those rows without ``theta`` and with ``rule = "threshold(<theta>)"``, ready to
        concatenate with the same table of least_confident runs.
    """
    out = frame[_plain(frame["theta"]).to_numpy() == theta].drop(columns="theta")
    return out.assign(rule=f"threshold({theta:g})").reset_index(drop=True)
