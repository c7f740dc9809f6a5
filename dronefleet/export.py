"""``dronefleet export SOURCE``: any table dronefleet wrote as CSV, for tools that read no parquet.

SOURCE is a parquet file (one of a run folder's tables, a figure's table, a sweep's
``collected.parquet``), a run folder (each of its tables) or a sweep's dataset (each table over
all its runs, with the partition columns, and its ``collected.parquet`` if collected). Each table
becomes ``<table>.csv`` in the folder ``--out`` (default: ``<SOURCE>-csv`` beside SOURCE), a row
per row, a header of the column names; numbers are written so that they read back exactly
(Python's shortest round-trip form), missing values as empty fields. The config and provenance
that parquet files carry in their metadata stay in the parquet files.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING

from .config import ConfigError, _show
from .outputs import probe_folders, writing

if TYPE_CHECKING:
    import pandas


def tables_of(source: Path) -> dict[str, pandas.DataFrame]:
    """``{table name: DataFrame}`` of ``source`` (see the module doc); ConfigError, one line, if it is none."""
    import pandas as pd

    from . import replay
    from .datafiles import DataError

    try:
        if source.is_file() and source.suffix == ".parquet":
            return {source.stem: pd.read_parquet(source)}
        if source.is_dir() and replay.is_dataset(source):
            tables = {folder.name: pd.read_parquet(folder) for folder in sorted(source.iterdir())
                      if folder.is_dir() and not folder.name.startswith(("_", "."))}
            collected = source / "collected.parquet"
            return {**tables, **({"collected": pd.read_parquet(collected)} if collected.is_file() else {})}
        if source.is_dir() and (source / "summary.parquet").is_file():
            return {path.stem: pd.read_parquet(path) for path in sorted(source.glob("*.parquet"))}
    except (OSError, ValueError, DataError) as error:  # pyarrow's errors are ValueErrors and OSErrors
        raise ConfigError(f"{_show(str(source))} cannot be read as tables: {str(error).splitlines()[0]}") from None
    raise ConfigError(f"{_show(str(source))} is neither a parquet file, a run folder (with summary.parquet) nor a "
                      "sweep's dataset: give one that dronefleet wrote")


def export(source: str | os.PathLike, out: str | os.PathLike | None = None, overwrite: bool = False) -> Path:
    """Write every table of ``source`` as ``out/<table>.csv``; return ``out``. ``out`` must be absent,
    empty or (with ``overwrite``) a folder of CSV files only, checked before anything is read."""
    source = Path(source)
    if not os.path.lexists(source):
        raise ConfigError(f"{_show(str(source))} does not exist: give a parquet file, a run folder or a sweep's "
                          "dataset")
    out = Path(out) if out is not None else source.with_name(f"{source.stem if source.is_file() else source.name}-csv")
    if out.exists():
        if not out.is_dir():
            raise ConfigError(f"--out {_show(str(out))} is a file; give a folder for the CSV files")
        held = [path.name for path in out.iterdir()]
        if held and not (overwrite and all(name.endswith(".csv") for name in held)):
            hint = "" if overwrite else ", or --overwrite to replace the CSV files of an earlier export"
            raise ConfigError(f"--out {_show(str(out))} is not empty; give an empty or new folder{hint}")
    tables = tables_of(source)
    probe_folders([out])
    with writing(out):
        out.mkdir(parents=True, exist_ok=True)
        for name, frame in tables.items():
            frame.to_csv(out / f"{name}.csv", index=False)
    return out
