"""What the replay page (:mod:`dronefleet.replay`) shows of a lunar run: one of its runs.

The page draws the run's frames, the network snapshot recorded every n_T ticks (spec section
19, ``frames = true``): the walled field, the regions N, T, R, the obstacle, the beacons with
their guidance vectors, the mobile robots by role filled by their state of charge, the dead;
and beside them the resources returned over the run (the ``timeseries`` table). A run written
with frames is read from its folder; one written without is simulated again, that run alone,
with frames on (run j draws the same streams whatever runs are beside it, section 13), and
refused if its summary row is not the folder's. Positions are interpolated linearly between
frames (about v0 T = 12.5 m apart at the defaults: the page shows where robots were every
n_T, not their paths in between).
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

import numpy as np

from ..config import ConfigError

__all__ = ["replay_data", "check_replayable", "chosen_run", "MAX_VALUES", "ROLE_CODES"]

#: At most this many frame x robot values in a page (:data:`VALUES_PER_ROBOT` per robot and
#: frame; ~25 MB of page): the defaults (361 frames x 50 robots) hold 2.2e5.
MAX_VALUES = 3_000_000
#: x, y, SOC, role, load and the six vector components of each robot in each frame.
VALUES_PER_ROBOT = 11
#: The page's state code of a robot: its role while alive (R charging apart), dead, not spawned.
ROLE_CODES = {"F_OUT": 0, "F_IN": 1, "R": 2, "B": 3, "dead": 4, "unspawned": 5, "charging": 6}
KEYS = ("T", "N", "R")


def _frames(config) -> int:
    """Frames of a run of ``config``: one every n_T ticks (or ``frame_every_s``) from tick 0 to the end, at most."""
    return config.ticks // config.frame_every_ticks + 1


def _too_large(config) -> str | None:
    """Why a page of a run of ``config`` would be too large, or None."""
    size = _frames(config) * config.n_robots * VALUES_PER_ROBOT
    if size <= MAX_VALUES:
        return None
    return (f"a replay page of {_frames(config):,} frames x {config.n_robots} robots x {VALUES_PER_ROBOT} values = "
            f"{size:,} values is too large; at most {MAX_VALUES:,}: a shorter duration_s, a longer "
            "update_interval_s or fewer robots")


def check_replayable(config) -> None:
    """Refuse (ConfigError, one line) before ``dronefleet run --replay`` simulates a run whose
    page :func:`replay_data` would refuse after the run."""
    reason = _too_large(config)
    if reason is not None:
        raise ConfigError(f"--replay: {reason}; run it without --replay")


def chosen_run(run_dir: Path, config, run: int | None) -> int:
    """``run`` (None: the first the config holds); ConfigError (one line) if the config does not
    hold it, DataError if the folder's ``summary.parquet`` has no row of it."""
    import pyarrow as pa

    from ..datafiles import DataError, read_parquet
    from ..records import check_trial

    runs = range(config.first_run, config.first_run + config.runs)
    chosen = runs.start if run is None else run
    check_trial(chosen, runs, f"RUN_DIR {str(run_dir)!r}")
    summary = run_dir / "summary.parquet"
    if chosen not in read_parquet(summary, {"run": pa.int64()}).column("run").to_pylist():
        raise DataError(f"table {str(summary)!r} has no row of run {chosen}, one of the runs {runs.start} to "
                        f"{runs.stop - 1} its config says the folder holds")
    return chosen


def _read(run_dir: Path, name: str, run: int):
    """The rows of ``run`` of the folder's table ``name`` (every column of the simulator's schema,
    checked by :func:`dronefleet.datafiles.read_parquet`), as pandas."""
    from ..datafiles import read_parquet
    from .simulate import table_schemas

    schema = table_schemas()[name]
    table = read_parquet(run_dir / f"{name}.parquet", dict(zip(schema.names, schema.types))).to_pandas()
    return table[table["run"] == run].reset_index(drop=True)


def _tables(run_dir: Path, config, run: int) -> dict:
    """The timeseries and the frames of ``run``: from the folder if it holds frames, else the
    run simulated again with frames (DataError, one line, if its summary is not the folder's)."""
    from ..datafiles import DataError

    snapshots = _read(run_dir, "snapshots", run)
    if config.frames:
        return {"timeseries": _read(run_dir, "timeseries", run), "frames": _page_frames(snapshots, config)}
    from .simulate import simulate

    fresh = {name: table.to_pandas() for name, table in
             simulate(dataclasses.replace(config, first_run=run, runs=1, frames=True)).items()}
    stored = _read(run_dir, "summary", run)
    if not stored.equals(fresh["summary"]):   # pandas: NaN (no such metric) equals NaN
        raise DataError(f"table {str(run_dir / 'summary.parquet')!r}: run {run} simulated again from its config "
                        "gives another summary: a table of another run or dronefleet version; write the run again "
                        "with dronefleet run")
    return {"timeseries": fresh["timeseries"], "frames": _page_frames(fresh["snapshots"], config)}


def _page_frames(snapshots, config):
    """The snapshots the page draws: the frames, or the end snapshot of a run shorter than n_T
    (ticks count from 1, so such a run records no frame)."""
    label = "frame" if config.ticks >= config.n_T else "end"
    return snapshots[snapshots["label"] == label]


def replay_data(run_dir: Path, config: Any, description: str, run: int) -> dict[str, Any]:
    """The page's data of run ``run`` of the lunar run folder ``run_dir``, of ``config`` (a
    :class:`~dronefleet.lunar.params.LunarParams` read from its summary), described as ``description``.

    Returns a JSON-ready dict: ``title``, ``duration_s`` [s], ``run``, ``layout``, ``field``
    [w, h] [m], ``regions`` {N, T, R: [x, y, radius]}, ``obstacle`` (4 corners or null),
    ``obstacle_kind``, ``n_robots``, ``v0`` [m/s]; per frame: ``times`` [s]; per frame and robot,
    frame-major: ``x``, ``y`` [m], ``soc``, ``state`` (:data:`ROLE_CODES`), ``load`` [units],
    and per key X of T, N, R ``vx_X``, ``vy_X`` [m/s] (beacons' guidance vectors; 0 otherwise);
    the chart's series at the timeseries' times ``series_t`` [s]: ``resources``, ``n_mobile``,
    ``n_beacons``, ``n_dead``.

    ConfigError (one line, before the simulation) if the page would hold more than
    :data:`MAX_VALUES` values; DataError (one line) if a table is damaged, or the run simulated
    again does not give the folder's summary row.
    """
    from .layout import build

    reason = _too_large(config)
    if reason is not None:
        raise ConfigError(f"RUN_DIR {str(run_dir)!r}: {reason}")
    tables = _tables(run_dir, config, run)
    frames = tables["frames"].sort_values(["t", "robot"], kind="mergesort")
    times = np.sort(frames["t"].unique())
    n = config.n_robots
    whole = len(times) > 0 and len(frames) == len(times) * n
    if not whole or (frames["robot"].to_numpy() != np.tile(np.arange(n), len(times))).any():
        from ..datafiles import DataError

        raise DataError(f"table {str(run_dir / 'snapshots.parquet')!r}: the frames of run {run} do not hold each of "
                        f"its {n} robots once per frame")
    state = frames["role"].map(ROLE_CODES).to_numpy()
    state = np.where(frames["mode"].to_numpy() == "charging", ROLE_CODES["charging"], state)
    for status in ("dead", "unspawned"):
        state = np.where(frames["status"].to_numpy() == status, ROLE_CODES[status], state)
    series = tables["timeseries"].sort_values("t")
    geometry = build(config)
    rounded = {name: np.round(frames[name].to_numpy(dtype=float), 3).tolist()
               for name in ("x", "y", "soc", *(f"v{axis}_{key}" for key in KEYS for axis in "xy"))}
    return {
        "scenario": "lunar",
        "title": f"lunar run {run} of: {description}",
        "duration_s": float(config.ticks * config.tau),
        "run": run,
        "layout": config.layout,
        "field": [float(v) for v in geometry.field],
        "regions": {key: [*map(float, geometry.centres[key]), float(geometry.radii[key])] for key in KEYS},
        "obstacle": None if geometry.obstacle is None else np.round(geometry.obstacle, 4).tolist(),
        "obstacle_kind": geometry.kind,
        "n_robots": n,
        "v0": config.v0,
        "times": times.tolist(),
        **rounded,
        "state": state.astype(int).tolist(),
        "load": frames["load"].astype(int).tolist(),
        "series_t": series["t"].tolist(),
        **{name: series[name].astype(int).tolist() for name in ("resources", "n_mobile", "n_beacons", "n_dead")},
    }
