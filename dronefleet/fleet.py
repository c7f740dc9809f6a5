"""Saved fleets: the state a run leaves behind, from which another run starts (warm start).

A fleet file is a parquet file with the ``fleet`` table's columns (see
:mod:`dronefleet.records`) for one instant, one row per UAV: SoH, policy weights on the
standardised features, intercept, learner step counter, SoC, lost flag and the operating
period that produced it, with the resolved config of that run in its metadata. A run's
own ``fleet.parquet`` (one row per UAV and week end) is accepted too: its last instant
is taken.
"""

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .config import ConfigError

#: Columns a fleet file must have.
COLUMNS = ("t_s", "uav", "soh", "w_distance", "w_mass", "w_soc", "intercept", "steps", "soc", "lost", "period")
#: Config keys that must agree between the fleet file and the run: a policy means nothing
#: under another feature scaling, and the file has one row per UAV.
MUST_AGREE = ("n_uavs", "scaler_mean", "scaler_std")


class FleetFileError(ConfigError):
    """A fleet file that cannot start the run: missing, malformed or made under another config."""


@dataclass(frozen=True)
class SavedFleet:
    """A fleet at one instant; arrays of shape (n_uavs,) in UAV order, ``coef`` (n_uavs, 3)."""

    soh: np.ndarray
    coef: np.ndarray
    intercept: np.ndarray
    steps: np.ndarray
    soc: np.ndarray      # percent; nan for a lost UAV
    lost: np.ndarray     # bool
    period: int          # operating period that left this fleet (1 = learned from scratch)


def seeded_path(path, seed):
    """``path`` with ``{seed}`` replaced by ``seed``: one pattern names the fleet of every seed."""
    return Path(str(path).replace("{seed}", str(seed)))


def load_fleet(path, config):
    """Read the fleet saved in ``path`` for a run of ``config``; refuse a mismatch before any work.

    Raises
    ------
    FleetFileError
        If the file is missing or not a fleet file, or its fleet size or feature scaling
        differs from ``config``'s (the message names the key and both values).
    """
    # Imported here: simulation imports this module, and a run from a new fleet needs neither.
    import pyarrow.compute as pc
    import pyarrow.parquet as pq

    from .records import read_config

    path = seeded_path(path, config.seed)
    if not path.is_file():
        raise FleetFileError(f"run.fleet_file: no such file {str(path)!r}", ["fleet_file"])
    try:
        saved_config = read_config(path)
        table = pq.read_table(path)
    except Exception as error:  # any reason the file is not a dronefleet parquet file
        raise FleetFileError(f"run.fleet_file {str(path)!r} is not a dronefleet fleet file: {error}",
                             ["fleet_file"]) from error
    missing = [c for c in COLUMNS if c not in table.column_names]
    if missing:
        raise FleetFileError(f"run.fleet_file {str(path)!r} lacks the fleet column(s) {', '.join(missing)}",
                             ["fleet_file"])
    for key in MUST_AGREE:
        if getattr(saved_config, key) != getattr(config, key):
            raise FleetFileError(
                f"run.fleet_file {str(path)!r} was saved with {key} = {getattr(saved_config, key)!r}, "
                f"but this run has {key} = {getattr(config, key)!r}; they must agree", [key, "fleet_file"])
    last = table.filter(pc.equal(table["t_s"], pc.max(table["t_s"]))).sort_by("uav").to_pydict()
    if last["uav"] != list(range(config.n_uavs)):
        raise FleetFileError(f"run.fleet_file {str(path)!r} does not hold UAVs 0..{config.n_uavs - 1} "
                             "once each at its last instant", ["fleet_file"])
    column = {name: np.array(values, dtype=np.float64) for name, values in last.items()
              if name in ("soh", "w_distance", "w_mass", "w_soc", "intercept", "soc")}
    return SavedFleet(
        soh=column["soh"], coef=np.column_stack([column["w_distance"], column["w_mass"], column["w_soc"]]),
        intercept=column["intercept"], steps=np.array(last["steps"], dtype=np.float64),
        soc=column["soc"], lost=np.array(last["lost"], dtype=np.bool_), period=int(last["period"][0]))


def save_fleet(result, path):
    """Write the fleet at the end of ``result`` to ``path`` (``{seed}`` replaced), atomically, as a fleet file.

    A UAV in flight at the end is saved with its SoC at that instant, as if it were at
    the FC (a warm start puts it there); the learning step of its landing is not taken.
    """
    import pyarrow.compute as pc

    from .records import fleet_table, write_table

    path = seeded_path(path, result.config.seed)
    table = fleet_table(result)
    last = table.filter(pc.equal(table["t_s"], pc.max(table["t_s"])))
    path.parent.mkdir(parents=True, exist_ok=True)
    return write_table(last, path, result.config)
