"""What the replay page (:mod:`dronefleet.replay`) shows of an items run: one of its trials.

A run's tables hold per-trial totals, not where the robots were, so the trial is simulated
again, alone, from the config in the run's summary, with the kernel's trace on (a trial's
outcome does not depend on the trials beside it, so this is exactly the trial of the run):
every robot's node, destination, steps left and payload, and every location's count, step by
step. Nothing of it is stored in the run folder.

The page's time is the model's: one page second is one step. Robots move on straight lines
between nodes: at the end of step t a robot in transit from a to b, with l of its t(a, b)
steps left, is at a + (t(a, b) - l) / t(a, b) (b - a), the point the kernel's A7 observation
uses; the page interpolates linearly between steps.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from ..config import ConfigError

__all__ = ["replay_data", "check_replayable", "trial_world", "MAX_VALUES"]

#: At most this many (steps + 1) x (robots + locations) values in a page (~6 MB of page; the
#: trace ~50 MB while it is built); the paper's largest cell (1000 steps, 10 robots, 441
#: locations) has 4.5e5.
MAX_VALUES = 2_000_000


def _size(config) -> int:
    return (config.steps + 1) * (config.n_robots + config.n_locations)


def _too_large(config) -> str | None:
    """Why a page of ``config``'s trial would be too large, or None."""
    size = _size(config)
    if size <= MAX_VALUES:
        return None
    return (f"a replay page of (steps {config.steps} + 1) x ({config.n_robots} robots + {config.n_locations} "
            f"locations) = {size:,} values is too large; at most {MAX_VALUES:,}: fewer steps or locations")


def check_replayable(config) -> None:
    """Refuse (ConfigError, one line) before ``dronefleet run --replay`` simulates a run whose
    page :func:`replay_data` would refuse after the run."""
    reason = _too_large(config)
    if reason is not None:
        raise ConfigError(f"--replay: {reason}; run it without --replay")


def trial_world(config, trial: int) -> tuple[np.ndarray, np.ndarray]:
    """(positions (m + 1, 2), true parameters (m + 1,)) of ``trial``: node 0 is home. Drawn by
    the kernel's own :func:`~dronefleet.items.kernel.draw_world` from the trial's stream (a)."""
    from ..rng import seed_stream
    from . import kernel as k
    from .simulate import kernel_inputs, trial_seeds

    one = config.replace(first_trial=trial, trials=1)
    opts, pars, positions, truth_par = kernel_inputs(one)
    rng = np.empty((1, 1, 4), dtype=np.uint64)
    seed_stream(rng, 0, k.STREAM_WORLD, trial_seeds(one)[0], k.STREAM_WORLD)
    k.draw_world(opts, pars, config.n_locations, rng, positions, truth_par)
    return positions, truth_par


def _paths(trace: np.ndarray, positions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """x, y (T + 1, n) of every robot at the end of every step, from the kernel's trace
    (T + 1, n, 4): at its node, or on its straight path from the node it left (the trace has
    no origin: it is the node of the robot's last departure, home before any)."""
    from . import kernel as k

    node, dest, left = (trace[:, :, c] for c in (k.TR_NODE, k.TR_DEST, k.TR_LEFT))
    start = np.zeros_like(node[:1])   # every robot starts at home, not in transit
    prev_node, prev_dest, prev_left = (np.concatenate([start, a[:-1]]) for a in (node, dest, left))
    transit = node < 0
    # a departure at step t: from the node it stood at, or from the one it reached at step t
    departs = transit & ((prev_node >= 0) | (prev_left == 1))
    origin_now = np.where(prev_node >= 0, prev_node, prev_dest)
    last = np.maximum.accumulate(np.where(departs, np.arange(node.shape[0])[:, None], 0), axis=0)
    robots = np.arange(node.shape[1])[None, :]
    origin, total = origin_now[last, robots], left[last, robots]  # steps left at departure = t(a, b)
    done = np.where(transit, (total - left) / np.maximum(total, 1), 0.0)
    at = np.where(transit, origin, node)
    to = np.where(transit, dest, node)
    xy = positions[at] + done[:, :, None] * (positions[to] - positions[at])
    return xy[:, :, 0], xy[:, :, 1]


def _check_totals(summary: Path, trial: int, totals: np.ndarray) -> None:
    """DataError (one line) unless the row of ``trial`` in ``summary`` holds the ``totals`` the
    trial gives again (the kernel's per-trial columns): the page must be the run's trial, not
    that of a config tampered with in every table, or of a version that drew other numbers."""
    import pyarrow as pa

    from ..datafiles import DataError, read_parquet
    from . import kernel as k

    columns = {"trial": pa.int64(), "generated": pa.int64(), "served": pa.int64()}
    table = read_parquet(summary, columns).to_pandas()
    row = table[table.trial == trial].iloc[0]
    again = {"generated": int(totals[k.T_GENERATED]), "served": int(totals[k.T_SERVED])}
    if any(row[name] != value for name, value in again.items()):
        raise DataError(f"table {str(summary)!r}: trial {trial} has generated {row.generated}, served {row.served}, "
                        f"but its config gives generated {again['generated']}, served {again['served']}: a table of "
                        "another run or dronefleet version; write the run again with dronefleet run")


def replay_data(run_dir: Path, config: Any, description: str, trial: int) -> dict[str, Any]:
    """The page's data of trial ``trial`` of the items run in ``run_dir``, of ``config`` (a
    :class:`dronefleet.items.params.Params` read from its summary), described as ``description``.

    Returns a JSON-ready dict: ``title``, ``duration_s`` (= steps T: one page second per step),
    ``mode``, ``truth``, ``algorithm``, ``trial``, ``n_robots``, ``capacity``, ``home`` [x, y];
    per location (m): ``loc_x``, ``loc_y`` (world units, the unit square), ``loc_rate`` (its
    true parameter: p_j, lambda_j; logistic: null); per step (T + 1) and robot, step-major:
    ``x``, ``y`` (end of the step), ``payload`` [items]; per step and location, step-major:
    ``counts`` (items or demands waiting; logistic: the population x_j, 0.1); per step:
    ``served``, ``generated`` (cumulative as the summary counts them, its last values are the
    trial's; logistic: foraged and A19's net growth).

    ConfigError (one line, before the simulation) if the page would hold more than
    :data:`MAX_VALUES` values (the scenario's hook checked ``trial``); DataError (one line) if
    the trial simulated again does not give the summary's generated and served.
    """
    from . import kernel as k
    from .simulate import run_cell

    reason = _too_large(config)
    if reason is not None:
        raise ConfigError(f"RUN_DIR {str(run_dir)!r}: {reason}")
    positions, truth_par = trial_world(config, trial)
    r = run_cell(config.replace(first_trial=trial, trials=1), world=(positions, truth_par), trace=True)
    _check_totals(run_dir / "summary.parquet", trial, r["totals"][0])
    trace, counts = r["trace"], r["trace_counts"][:, 1:]
    payload = trace[:, :, k.TR_Y]
    # payloads grow only at locations (picked) and drop to 0 only at home (unloaded)
    change = np.diff(payload, axis=0, prepend=np.zeros_like(payload[:1]))
    picked = np.cumsum(np.maximum(change, 0).sum(axis=1))
    unloaded = np.cumsum(np.maximum(-change, 0).sum(axis=1))
    served = unloaded if config.foraging and config.count_at == "unload" else picked
    logistic = config.truth == "logistic"
    if logistic:  # A19, summed in the kernel's order
        stock = np.array([sum(row) for row in counts.tolist()])
        generated = np.floor(stock + picked - config.n_locations * config.x0).astype(np.int64)
    else:
        generated = counts.sum(axis=1).astype(np.int64) + picked
    x, y = _paths(trace, positions)
    return {
        "scenario": "items",
        "title": f"items run, trial {trial} of: {description}",
        "duration_s": config.steps,
        "mode": config.mode,
        "truth": config.truth,
        "algorithm": config.algorithm,
        "trial": trial,
        "n_robots": config.n_robots,
        "capacity": config.capacity,
        "home": positions[0].tolist(),
        "loc_x": np.round(positions[1:, 0], 6).tolist(),
        "loc_y": np.round(positions[1:, 1], 6).tolist(),
        "loc_rate": None if logistic else np.round(truth_par[1:], 4).tolist(),
        "x": np.round(x, 4).reshape(-1).tolist(),
        "y": np.round(y, 4).reshape(-1).tolist(),
        "payload": payload.reshape(-1).tolist(),
        "counts": (np.round(counts, 1) if logistic else counts.astype(np.int64)).reshape(-1).tolist(),
        "served": served.astype(np.int64).tolist(),
        "generated": generated.tolist(),
    }
