"""Files read as data: every file the tool reads back (tables, side files of a sweep, a run's
metadata) goes through here, so that a damaged or tampered file is refused in one line and
never hangs, exhausts memory or runs code.

* :func:`read_bytes`: a regular file (not a pipe, device or folder) of at most ``limit`` bytes;
* :func:`parse_json`, :func:`read_json`: JSON nested at most :data:`MAX_JSON_DEPTH` deep;
* :func:`parquet_schema`, :func:`parquet_rows`, :func:`read_parquet`: a parquet file whose footer
  can be read and whose columns have the names and types expected, read whole (so a truncated or
  garbled file is found before any of it is used); :func:`check_columns`, the columns of a schema
  read from a footer alone (where reading every file whole would cost too much);
* :func:`checked_column`: a column read so, every value checked (nulls, range, codes) before use.

Every refusal is a :class:`DataError` (a :class:`~dronefleet.config.ConfigError`: one line,
exit code 2) naming the file. What a value must be beyond its type (a range, a code) is the
reader's to say: the scenario knows it; :func:`checked_column` checks it.
"""

from __future__ import annotations

import json
import os
import stat
from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING, Any

from .config import ConfigError, _show, brief, too_deep

if TYPE_CHECKING:
    import numpy
    import pyarrow

__all__ = ["DataError", "MAX_JSON_BYTES", "MAX_JSON_DEPTH", "MAX_TABLE_BYTES", "check_columns", "checked_column",
           "parse_json", "parquet_rows", "parquet_schema", "read_bytes", "read_json", "read_parquet"]

#: Largest JSON side file read [bytes] (a sweep's layout, a failed run's record: a few KB).
MAX_JSON_BYTES = 1_000_000
#: Deepest nesting of lists and objects accepted in JSON (configs nest 2-3 levels).
MAX_JSON_DEPTH = 32
#: Largest parquet file read [bytes]; the largest run allowed writes a few GB.
MAX_TABLE_BYTES = 16_000_000_000


class DataError(ConfigError):
    """A file read back as data that is not what it should be: damaged, tampered with, of another
    kind, or not a regular file. The message names the file and what is wrong, in one line."""


def _regular(path: str | os.PathLike, kind: str, limit: int) -> int:
    """The size of ``path`` [bytes] after checking it is a regular file of at most ``limit`` bytes."""
    try:
        info = os.stat(path)
    except (OSError, ValueError) as e:  # ValueError: a NUL byte in the path
        raise DataError(f"cannot read {kind} {str(path)!r}: {getattr(e, 'strerror', None) or e}") from None
    if not stat.S_ISREG(info.st_mode):
        raise DataError(f"{kind} {str(path)!r} is not a regular file (a folder, pipe or device)")
    if info.st_size > limit:
        raise DataError(f"{kind} {str(path)!r} has {info.st_size} bytes; at most {limit} are read")
    return info.st_size


def read_bytes(path: str | os.PathLike, limit: int, kind: str = "file") -> bytes:
    """The bytes of the regular file ``path``, of at most ``limit`` bytes; DataError naming ``kind``
    and the path otherwise (a pipe would block, ``/dev/zero`` would never end)."""
    _regular(path, kind, limit)
    try:
        # O_NONBLOCK: a file swapped for a pipe after the check does not block the open
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
        with os.fdopen(fd, "rb") as fh:
            data = fh.read(limit + 1)  # no further: the file may have grown since
    except OSError as e:
        raise DataError(f"cannot read {kind} {str(path)!r}: {e.strerror or e}") from None
    if data is None or len(data) > limit:
        raise DataError(f"{kind} {str(path)!r} is larger than {limit} bytes or not a regular file")
    return data


def parse_json(text: str | bytes, where: str, max_depth: int = MAX_JSON_DEPTH) -> Any:
    """``text`` parsed as JSON; DataError naming ``where`` if it is not JSON or nests deeper than
    ``max_depth``. Only plain values come out: JSON has no way to name code."""
    try:
        value = json.loads(text)
    except RecursionError:
        raise DataError(f"{where} nests lists or objects more than {max_depth} deep") from None
    except ValueError as e:  # JSONDecodeError, UnicodeDecodeError, an integer of too many digits
        raise DataError(f"{where} is not valid JSON: {brief(e)}") from None
    if too_deep(value, max_depth) is not None:
        raise DataError(f"{where} nests lists or objects more than {max_depth} deep")
    return value


def read_json(path: str | os.PathLike, kind: str = "file", limit: int = MAX_JSON_BYTES,
              max_depth: int = MAX_JSON_DEPTH) -> Any:
    """The JSON document in the regular file ``path`` (at most ``limit`` bytes, nested at most
    ``max_depth`` deep); DataError naming ``kind`` and the path otherwise."""
    return parse_json(read_bytes(path, limit, kind), f"{kind} {str(path)!r}", max_depth)


def parquet_schema(path: str | os.PathLike, kind: str = "table", limit: int = MAX_TABLE_BYTES):
    """The Arrow schema (with its metadata) of the parquet file ``path``, read from its footer
    alone; DataError if the file is not a regular file of at most ``limit`` bytes or not parquet."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    _regular(path, kind, limit)
    try:
        return pq.read_schema(path)
    except (pa.ArrowException, OSError, ValueError) as e:
        raise DataError(f"{kind} {str(path)!r} is not a readable parquet file ({brief(e)})") from None


def parquet_rows(path: str | os.PathLike, kind: str = "table", limit: int = MAX_TABLE_BYTES) -> int:
    """How many rows the parquet file ``path`` holds, read from its footer alone (before reading a
    table too large to use); DataError as :func:`parquet_schema`."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    _regular(path, kind, limit)
    try:
        return pq.ParquetFile(path).metadata.num_rows
    except (pa.ArrowException, OSError, ValueError) as e:
        raise DataError(f"{kind} {str(path)!r} is not a readable parquet file ({brief(e)})") from None


class ColumnType:
    """A test of a column's arrow type (``test(type)``) and what it accepts, in ``words``
    ("an integer"): messages say the words, not the test's function name."""

    def __init__(self, words: str, test: Callable[[Any], bool]) -> None:
        self.words, self.test = words, test

    def __call__(self, arrow_type) -> bool:
        return self.test(arrow_type)


def check_columns(schema, columns: Mapping[str, Any], path: str | os.PathLike, kind: str = "table",
                  exact: bool = False) -> None:
    """Refuse (DataError naming the file and the first column at fault) a parquet ``schema`` (of
    the file ``path``) that lacks one of ``columns`` (name -> pyarrow DataType, a :class:`ColumnType`,
    or a predicate such as ``pyarrow.types.is_integer``) or holds one of another type; with ``exact``, also
    one holding a column not in ``columns``."""
    import pyarrow as pa

    for name, expected in columns.items():
        index = schema.get_field_index(name)
        if index < 0:
            raise DataError(f"{kind} {str(path)!r} has no column {name!r} (it has "
                            f"{', '.join(schema.names[:12]) or 'none'}); it was not written by this dronefleet")
        actual = schema.field(index).type
        ok = actual == expected if isinstance(expected, pa.DataType) else expected(actual)
        if not ok:
            wanted = (expected if isinstance(expected, pa.DataType)
                      else expected.words if isinstance(expected, ColumnType) else expected.__name__)
            raise DataError(f"{kind} {str(path)!r}: column {name!r} is {actual}, not {wanted}")
    extra = [name for name in schema.names if name not in columns] if exact else []
    if extra or len(schema.names) != len(set(schema.names)):
        shown = extra[0] if extra else next(n for n in schema.names if schema.names.count(n) > 1)
        raise DataError(f"{kind} {str(path)!r} has a column {shown!r} beyond (or repeating) its {len(columns)} "
                        f"columns ({', '.join(list(columns)[:12])}); it was not written by this dronefleet")


def read_parquet(path: str | os.PathLike, columns: Mapping[str, Any], kind: str = "table",
                 limit: int = MAX_TABLE_BYTES, exact: bool = False):
    """The columns ``columns`` (name -> pyarrow DataType, or a predicate such as
    ``pyarrow.types.is_integer``) of the parquet file ``path``, read whole, with the file's
    schema metadata.

    DataError, naming the file and the first column at fault, if the file is not a readable
    parquet file (truncated, garbled), lacks a column or holds one of another type (with
    ``exact``, or one more: see :func:`check_columns`), or is not a regular file of at most
    ``limit`` bytes. Nulls are the reader's to check.
    """
    import pyarrow as pa
    import pyarrow.parquet as pq

    check_columns(parquet_schema(path, kind, limit), columns, path, kind, exact)
    try:
        return pq.read_table(path, columns=list(columns))
    except (pa.ArrowException, OSError, ValueError) as e:
        raise DataError(f"{kind} {str(path)!r} is damaged ({brief(e)})") from None


def checked_column(table: pyarrow.Table, name: str, path: str | os.PathLike, ok: Callable[[Any], Any], allowed: str,
                   kind: str = "table", nullable: bool = False) -> numpy.ndarray:
    """Column ``name`` of ``table`` (as :func:`read_parquet` read it from ``path``) as a numpy
    array of shape (rows,), after checking every value.

    ``ok`` maps the array to a bool array, True where a value is allowed (a float column holds
    NaN at its nulls; a string column, objects); ``allowed`` says what is, for the message.
    Nulls are refused unless ``nullable``. DataError naming the file, the column, the first row
    at fault and its value otherwise.
    """
    import numpy as np

    column = table[name]
    null = column.is_null().to_numpy(zero_copy_only=False)
    values = column.to_numpy(zero_copy_only=False)
    with np.errstate(invalid="ignore", over="ignore"):
        good = null if nullable else np.zeros(len(values), dtype=bool)
        good = good | (~null & np.asarray(ok(values), dtype=bool))
    if good.all():
        return values
    row = int(np.argmin(good))
    value = "null" if null[row] else _show(values[row].item() if isinstance(values[row], np.generic) else values[row])
    raise DataError(f"{kind} {str(path)!r}: column {name!r} holds {value} at row {row}; allowed: {allowed}")
