"""Parquet files of any scenario's runs, with their config and provenance, written atomically.

Every file carries the full resolved config (JSON) in its schema metadata under
``dronefleet.config``, and what made it under ``dronefleet.provenance`` (see
:mod:`dronefleet.provenance`). Files are written under a temporary name and renamed, so a
reader never sees a truncated file. A run folder is complete or absent: its tables are
written into a hidden sibling folder that is renamed into place (:func:`write_tables`).
A scenario's own tables are built in its subpackage (delivery: :mod:`dronefleet.delivery.records`).
"""

import errno
import os
import re
import shutil
import socket
from collections.abc import Callable, Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from .provenance import stamp

CONFIG_KEY = b"dronefleet.config"
#: The replay page (:mod:`dronefleet.replay`) that ``dronefleet run --replay`` writes beside
#: the tables: the one file other than tables that a run folder may hold.
REPLAY_FILE = "replay.html"


def arrow_array(values: np.ndarray | Sequence, null: np.ndarray | None = None) -> pa.Array:
    """A numpy array (or a list of scalars) as an Arrow array, built from its buffers.

    ``pyarrow.array`` imports pandas (0.3-0.4 s, most of a run's start-up) to ask whether its
    input is a pandas object; the tables of a run never hold one, so their columns are made
    here from the values' memory instead. Types follow numpy's: integers and floats keep their
    width, ``bool`` becomes Arrow's bit-packed boolean, strings (``str`` arrays or lists)
    UTF-8 ``string``; Python ints, floats and bools become int64, float64 and bool.

    Parameters
    ----------
    values : numpy.ndarray of shape (n,) or list
    null : numpy.ndarray of bool, shape (n,), optional
        True where the value is null (a float column's NaN: pass ``numpy.isnan(values)``).
    """
    values = np.asarray(values)
    n = values.shape[0]
    validity = None
    if null is not None and null.any():
        validity = pa.py_buffer(np.packbits(~null, bitorder="little"))
    if values.dtype.kind == "U":
        encoded = [str(value).encode() for value in values]
        offsets = np.zeros(n + 1, dtype=np.int32)
        np.cumsum([len(value) for value in encoded], out=offsets[1:])
        return pa.Array.from_buffers(pa.string(), n, [validity, pa.py_buffer(offsets), pa.py_buffer(b"".join(encoded))])
    if values.dtype == np.bool_:
        return pa.Array.from_buffers(pa.bool_(), n, [validity, pa.py_buffer(np.packbits(values, bitorder="little"))])
    values = np.ascontiguousarray(values)
    return pa.Array.from_buffers(pa.from_numpy_dtype(values.dtype), n, [validity, pa.py_buffer(values)])


def arrow_table(columns: Mapping[str, np.ndarray | pa.Array], metadata: Mapping | None = None) -> pa.Table:
    """``{name: numpy array or arrow array}`` as a table (see :func:`arrow_array`)."""
    table = pa.table({name: column if isinstance(column, pa.Array) else arrow_array(column)
                      for name, column in columns.items()})
    return table if metadata is None else table.replace_schema_metadata(metadata)


def _temporary_name(path, kind):
    """Hidden sibling of ``path`` for this host and process: ``.<name>.<host>-<pid>.<kind>``."""
    return path.with_name(f".{path.name}.{socket.gethostname()}-{os.getpid()}.{kind}")


def write_atomic(path: str | os.PathLike, write: Callable[[Path], object]) -> Path:
    """``write(tmp)`` a hidden sibling temporary file, then rename it to ``path``; return ``path``.

    A reader never sees a partial file, and an interrupted write leaves only the hidden
    temporary, whose name ends in ``.tmp`` (no dataset reader or ``*.parquet`` glob takes
    it). It names the host and process: writers on several hosts of a shared filesystem
    never collide.
    """
    path = Path(path)
    tmp = _temporary_name(path, "tmp")
    try:
        write(tmp)
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)
    return path


def write_table(table: pa.Table, path: str | os.PathLike, config: Any) -> Path:
    """Write ``table`` to ``path`` atomically, with the resolved ``config`` and the provenance in its metadata."""
    table = stamp(table.replace_schema_metadata({CONFIG_KEY: config.to_json()}))
    return write_atomic(path, lambda tmp: pq.write_table(table, tmp))


def run_dir_state(out_dir: str | os.PathLike, table_names: Iterable[str]) -> str:
    """What ``out_dir`` holds: ``"absent"``, ``"empty"``, ``"complete"`` (every table ``table_names`` of a run),
    ``"partial"`` (some tables and nothing else: left by a dronefleet before complete-or-absent
    run folders), ``"file"`` (not a folder) or ``"other"`` (files that are not a run's tables).
    Hidden entries (``.DS_Store``, ...) and the run's :data:`REPLAY_FILE` go with the run, but a
    folder holding only those is not empty."""
    out_dir = Path(out_dir)
    if not out_dir.exists():
        return "absent"
    if not out_dir.is_dir():
        return "file"
    entries = [p.name for p in out_dir.iterdir()]
    names = {name for name in entries if not name.startswith(".") and name != REPLAY_FILE}
    tables = {f"{name}.parquet" for name in table_names}
    if not entries:
        return "empty"
    if not names or not names <= tables:
        return "other"
    return "complete" if names == tables else "partial"


def clean_leftovers(out_dir: str | os.PathLike) -> None:
    """Remove what interrupted writers of the run folder ``out_dir`` left beside it.

    Only this host's leftovers whose process is gone are touched. A killed replacement
    may have left the previous run aside (``.<name>.<host>-<pid>.old``) and no run in
    place: that run is put back, so the folder again holds the old complete run.
    """
    out_dir = Path(out_dir)
    pattern = re.compile(rf"\.{re.escape(out_dir.name)}\.{re.escape(socket.gethostname())}-(\d+)\.(tmp|old)")
    if not out_dir.parent.is_dir():
        return
    for leftover in sorted(out_dir.parent.iterdir(), key=lambda p: p.name.endswith(".tmp")):  # .old first
        match = pattern.fullmatch(leftover.name)
        if match is None or _alive(int(match[1])):
            continue
        if match[2] == "old" and run_dir_state(out_dir, ()) in ("absent", "empty"):  # whatever the tables
            os.replace(leftover, out_dir)
        else:
            shutil.rmtree(leftover, ignore_errors=True)


def _alive(pid):
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # another user's process
        return True
    return True


def write_tables(named_tables: Mapping[str, pa.Table], out_dir: str | os.PathLike, config: Any,
                 overwrite: bool = False) -> dict[str, Path]:
    """Write ``named_tables`` (name -> pyarrow Table) as ``out_dir/<name>.parquet`` with
    ``config`` (anything with ``to_json()``) and the provenance in each file's metadata
    (:func:`write_table`); return the paths. Any scenario's run folder is written here.

    The folder is complete or absent: the tables go into the hidden sibling
    ``.<name>.<host>-<pid>.tmp``, which is then renamed to ``out_dir`` (atomic on POSIX). An
    existing run is replaced only with ``overwrite``: it is renamed aside to ``...old``, the
    new one renamed in, the old one deleted. A crash at any point leaves the old complete
    run or the new one, plus at most a hidden leftover that :func:`clean_leftovers` (called
    here first) removes or, if the crash fell between the two renames, puts back in place.

    Raises
    ------
    FileExistsError
        If ``out_dir`` holds a run and not ``overwrite``, or holds files other than a run's
        tables (never deleted, whatever ``overwrite``).
    OSError
        Any failure to write (disk full, read-only, ...); ``out_dir`` is then as it was.
    """
    out_dir = Path(out_dir)
    clean_leftovers(out_dir)
    out_dir.parent.mkdir(parents=True, exist_ok=True)
    tmp, aside = _temporary_name(out_dir, "tmp"), _temporary_name(out_dir, "old")
    try:
        tmp.mkdir()
        paths = {name: out_dir / write_table(table, tmp / f"{name}.parquet", config).name
                 for name, table in named_tables.items()}
        state = run_dir_state(out_dir, named_tables)
        if state in ("complete", "partial") and overwrite:
            os.replace(out_dir, aside)
        elif state not in ("absent", "empty"):
            why = {"other": "holds files other than a run's tables", "file": "is a file"}.get(state, "holds a run")
            raise FileExistsError(errno.EEXIST, why, str(out_dir))
        os.replace(tmp, out_dir)  # fails, leaving out_dir as it is, if another writer came first
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        if aside.exists() and not out_dir.exists():
            os.replace(aside, out_dir)
        raise
    shutil.rmtree(aside, ignore_errors=True)
    return paths


def read_config_dict(path: str | os.PathLike, kind: str = "table") -> dict[str, Any]:
    """The resolved config embedded in a dronefleet parquet file, as the dict of its JSON.

    DataError naming the file (the ``kind`` of file it is) if it is not a readable parquet file,
    holds no config, or holds one that is not JSON (nested at most
    :data:`dronefleet.datafiles.MAX_JSON_DEPTH` deep) of an object.
    """
    from .datafiles import DataError, parquet_schema, parse_json

    where = f"{kind} {str(path)!r}"
    text = (parquet_schema(path, kind).metadata or {}).get(CONFIG_KEY)
    if text is None:
        raise DataError(f"{where} holds no dronefleet config in its metadata: it was not written by dronefleet")
    document = parse_json(text, f"the config in {where}")
    if not isinstance(document, dict):
        raise DataError(f"the config in {where} is a JSON {type(document).__name__}, not an object of sections")
    return document


def read_config(path: str | os.PathLike, build: Callable[[dict[str, Any]], Any], kind: str = "table") -> Any:
    """The config embedded in a dronefleet parquet file, made by ``build`` (a scenario's
    ``config_from_dict``, which must not trust it: files are data) from :func:`read_config_dict`.

    DataError naming the file if it holds no config, or one that ``build`` refuses (the
    refusal's ConfigError follows the file's name).
    """
    from .config import ConfigError
    from .datafiles import DataError

    document = read_config_dict(path, kind)
    try:
        return build(document)
    except ConfigError as error:
        raise DataError(f"{kind} {str(path)!r} holds a config that is not valid: {error}", error.keys) from None


def check_trial(trial: int, trials: range, holder: str) -> None:
    """ConfigError (one line) unless ``trial`` is one of ``trials``, those ``holder`` (a run
    folder, or the run about to be made) holds."""
    from .config import ConfigError

    if trial not in trials:
        raise ConfigError(f"--trial {trial}: {holder} holds trials {trials.start} to {trials.stop - 1}")


def chosen_trial(run_dir: Path, trials: range, trial: int | None) -> int:
    """``trial`` (None: the first of ``trials``, the trials its config says the run in ``run_dir``
    holds); ConfigError (one line) if the config does not hold it or the run's ``summary.parquet``
    has no row of it (a table whose rows are not its config's)."""
    from .datafiles import DataError, read_parquet

    chosen = trials.start if trial is None else trial
    check_trial(chosen, trials, f"RUN_DIR {str(run_dir)!r}")
    summary = run_dir / "summary.parquet"
    if chosen not in read_parquet(summary, {"trial": pa.int64()}).column("trial").to_pylist():
        raise DataError(f"table {str(summary)!r} has no row of trial {chosen}, one of the trials "
                        f"{trials.start} to {trials.stop - 1} its config says the run holds")
    return chosen
