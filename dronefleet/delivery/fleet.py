"""Saved fleets: the state a run leaves behind, from which another run starts (warm start).

A fleet file is a parquet file with the ``fleet`` table's columns (see
:mod:`dronefleet.records`) for one instant, one row per UAV: SoH, policy weights on the
standardised features, intercept, learner step counter, SoC, lost flag and the operating
period that produced it, with the resolved config of that run in its metadata. A run's
own ``fleet.parquet`` (one row per UAV and week end) is accepted too: its last instant
is taken.

A fleet file is input like a config: :func:`load_fleet` checks all of it before a run
starts (the engine trusts its arrays and would read or write out of bounds on, say, a
NaN SoH) and refuses it with a one-line :class:`FleetFileError` naming the file, the
column, the UAV and the value.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..config import ConfigError, brief

if TYPE_CHECKING:
    from .config import Config
    from .result import RunResult

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


def seeded_path(path: str | os.PathLike, seed: int) -> Path:
    """``path`` with ``{seed}`` replaced by ``seed``: one pattern names the fleet of every seed."""
    return Path(str(path).replace("{seed}", str(seed)))


#: Column kinds a fleet file must have (pyarrow type predicates by name): numbers may be
#: written as integers or floats, ``uav`` and ``period`` must be integers, ``lost`` booleans.
_KINDS = {"t_s": "number", "uav": "integer", "soh": "number", "w_distance": "number", "w_mass": "number",
          "w_soc": "number", "intercept": "number", "steps": "number", "soc": "number", "lost": "boolean",
          "period": "integer"}
#: Largest magnitude of a policy weight or intercept: learned ones are of order 1-10; this
#: keeps every decision value finite.
MAX_WEIGHT = 1e6
#: Largest row count read from a fleet file (a run's fleet.parquet has n_uavs x (weeks + 1)).
MAX_ROWS = 10_000_000


def _is_kind(type_, kind):
    import pyarrow.types as pt

    if kind == "integer":
        return pt.is_integer(type_)
    if kind == "boolean":
        return pt.is_boolean(type_)
    return pt.is_integer(type_) or pt.is_floating(type_)


def _first_bad(ok):
    """Index of the first False in ``ok``, or None."""
    bad = np.flatnonzero(~ok)
    return int(bad[0]) if bad.size else None


def load_fleet(path: str | os.PathLike, config: Config) -> SavedFleet:
    """Read the fleet saved in ``path`` for a run of ``config``; refuse a bad file before any work.

    Checked, in order: the file (exists, a readable parquet file of at most MAX_ROWS rows,
    with a dronefleet config in its metadata), its columns (all of COLUMNS, of the right
    kinds: numbers, integer ``uav`` and ``period``, boolean ``lost``), the config keys of
    MUST_AGREE, then the rows of the last instant: UAVs 0..n_uavs-1 once each, and values
    that can start a run: SoH in (0, 1], finite weights and intercept of magnitude at most
    MAX_WEIGHT, steps an integral value >= 0, SoC in [0, 100] (null only for a lost UAV),
    ``lost`` not null, one period >= 1.

    Raises
    ------
    FleetFileError
        For any of the above; the message names the file, the column, the UAV and the value.
    """
    # Imported here: simulation imports this module, and a run from a new fleet needs neither.
    import pyarrow as pa
    import pyarrow.compute as pc
    import pyarrow.parquet as pq

    from ..datafiles import DataError
    from ..records import read_config_dict
    from .config import config_from_dict

    path = seeded_path(path, config.seed)
    where = f"run.fleet_file {str(path)!r}"

    def refuse(message, keys=("fleet_file",)):
        return FleetFileError(f"{where}: {message}", keys)

    if not path.exists():
        raise FleetFileError(f"run.fleet_file: no such file {str(path)!r}", ["fleet_file"])
    if not path.is_file():
        raise refuse("is not a file")
    try:
        rows = pq.ParquetFile(path).metadata.num_rows
    except (OSError, pa.ArrowException) as error:
        raise refuse(f"is not a readable parquet file ({brief(error)})") from None
    if rows > MAX_ROWS:
        raise refuse(f"has {rows} rows; a fleet file has at most {MAX_ROWS}")
    try:
        document = read_config_dict(path, "fleet file")
    except DataError:  # no or bad metadata
        raise refuse("is not a dronefleet fleet file: its metadata holds no dronefleet config") from None
    try:
        # files are data: a plugin rule the file names is not imported (the run's rule is the user's)
        saved_config = config_from_dict(document, trusted=False)
    except ConfigError as error:
        raise refuse(f"holds a config that is not valid now ({error})") from None
    schema = pq.read_schema(path)
    missing = [c for c in COLUMNS if c not in schema.names]
    if missing:
        raise refuse(f"lacks the fleet column(s) {', '.join(missing)}")
    for name, kind in _KINDS.items():
        if not _is_kind(schema.field(name).type, kind):
            raise refuse(f"column {name} has type {schema.field(name).type}; allowed: {kind}s")
    for key in MUST_AGREE:
        if getattr(saved_config, key) != getattr(config, key):
            raise FleetFileError(
                f"{where} was saved with {key} = {getattr(saved_config, key)!r}, "
                f"but this run has {key} = {getattr(config, key)!r}; they must agree", [key, "fleet_file"])
    try:
        table = pq.read_table(path, columns=list(COLUMNS))
    except (OSError, pa.ArrowException) as error:
        raise refuse(f"cannot be read ({brief(error)})") from None
    t = table["t_s"].to_numpy(zero_copy_only=False).astype(np.float64)
    if table.num_rows == 0 or table["t_s"].null_count or not np.isfinite(t).all() or (t < 0).any():
        raise refuse("column t_s must hold finite times >= 0, one per row (an empty file has none)")
    last = table.filter(pc.equal(table["t_s"], pc.max(table["t_s"]))).sort_by("uav")
    uav = last["uav"].to_numpy(zero_copy_only=False)
    if last["uav"].null_count or uav.tolist() != list(range(config.n_uavs)):
        raise refuse(f"does not hold UAVs 0..{config.n_uavs - 1} once each at its last instant "
                     f"(t_s = {_num(t.max())}; found {last.num_rows} rows)")
    lost_column = last["lost"]
    if lost_column.null_count:
        raise refuse(f"column lost is null for UAV {lost_column.is_null().to_numpy(zero_copy_only=False).argmax()}")
    lost = lost_column.to_numpy(zero_copy_only=False).astype(np.bool_)

    def column(name, ok, allowed, nullable=None):
        """The column as float64 (nan for null), refused at the first value that is not ``ok``."""
        values = last[name]
        null = values.is_null().to_numpy(zero_copy_only=False)
        x = values.cast(pa.float64()).fill_null(np.nan).to_numpy(zero_copy_only=False)
        with np.errstate(invalid="ignore"):
            good = np.isfinite(x) & ok(x)
        if nullable is not None:
            good |= null & nullable
        i = _first_bad(good)
        if i is not None:
            value = "null" if null[i] else _num(x[i])
            raise refuse(f"column {name} of UAV {i} is {value}; allowed: {allowed}")
        return x

    soh = column("soh", lambda x: (x > 0) & (x <= 1), "(0, 1]")
    weights = [column(name, lambda x: np.abs(x) <= MAX_WEIGHT, f"finite, within +-{MAX_WEIGHT:g}")
               for name in ("w_distance", "w_mass", "w_soc", "intercept")]
    steps = column("steps", lambda x: (x >= 0) & (x <= 2.0**53) & (x == np.floor(x)),
                   "an integral value >= 0")
    soc = column("soc", lambda x: (x >= 0) & (x <= 100), "[0, 100] (null only for a lost UAV)", nullable=lost)
    periods = set(last["period"].to_pylist())
    if len(periods) != 1 or None in periods or not 1 <= min(periods) < np.iinfo(np.int16).max:
        raise refuse(f"column period at the last instant is {sorted(periods, key=str)[:3]}; "
                     f"allowed: one integer in [1, {np.iinfo(np.int16).max - 1}]")
    return SavedFleet(soh=soh, coef=np.column_stack(weights[:3]), intercept=weights[3], steps=steps,
                      soc=soc, lost=lost, period=int(periods.pop()))


def _num(x):
    return f"{x:g}"


def save_fleet(result: RunResult, path: str | os.PathLike) -> Path:
    """Write the fleet at the end of ``result`` to ``path`` (``{seed}`` replaced), atomically, as a fleet file.

    A UAV in flight at the end is saved with its SoC at that instant, as if it were at
    the FC (a warm start puts it there); the learning step of its landing is not taken.
    """
    import pyarrow.compute as pc

    from ..records import write_table
    from .records import fleet_table

    path = seeded_path(path, result.config.seed)
    table = fleet_table(result)
    last = table.filter(pc.equal(table["t_s"], pc.max(table["t_s"])))
    path.parent.mkdir(parents=True, exist_ok=True)
    return write_table(last, path, result.config)
