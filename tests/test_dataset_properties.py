"""Property-based tests of a sweep's readers: any damage gives a result or the project's own error.

A run's files (truncated, garbled, replaced by other bytes or by a parquet table of other
columns, nested types or metadata), the side files ``_layout.json`` and ``_failed/`` records
(any JSON, any nesting, any bytes) and sweep files (any TOML, truncated, nested): each read
gives a correct result or a ConfigError (SweepError, DataError) of one line, never another
exception, never a hang. The dataset is built once per module, by the real writer from
made-up tables (no simulation, no numba compilation), and each example damages one file
that is put back afterwards. Deterministic and small, like tests/test_loader_properties.py.
"""

import json
import math
import tempfile
from pathlib import Path

import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from dronefleet import sweeps as sw
from dronefleet.config import ConfigError
from dronefleet.delivery import scenario as delivery
from dronefleet.records import CONFIG_KEY

from conftest import TINY_SWEEPS

SETTINGS = settings(max_examples=60, deadline=None, derandomize=True, database=None,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])


def one_line(error):
    assert isinstance(error, ConfigError) and str(error) and "\n" not in str(error), repr(error)
    return error


def outcome(read, *args):
    """``read(*args)``, or the ConfigError it raised (after checking its message is one line)."""
    try:
        return read(*args)
    except ConfigError as error:
        return one_line(error)


ROWS = {**dict.fromkeys(delivery.TABLES, 2), "summary": 1}
SAMPLE = {pa.types.is_integer: 1, pa.types.is_floating: 0.5, pa.types.is_string: "x", pa.types.is_boolean: True}


def made_up(config):
    """Rows of every table of the delivery scenario, of its declared columns and types: two, and
    the summary's one (a run is one replicate)."""
    def column(kind, rows):
        if pa.types.is_list(kind):
            return [[1], []][:rows]
        return [next(value for test, value in SAMPLE.items() if test(kind))] * rows

    return {table: pa.table({field.name: pa.array(column(field.type, ROWS[table]), field.type) for field in schema})
            for table, schema in delivery.table_schemas().items()}


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    """The tiny delivery sweep, written by the sweep's own writer from made-up tables: ``(sweep, out)``."""
    root = tmp_path_factory.mktemp("dataset")
    path = root / "tiny.toml"
    path.write_text(TINY_SWEEPS["delivery"])
    s = sw.load_sweep(path)
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(delivery, "simulate", made_up)
        ran, failures = sw.run_sweep(s, root / "tiny", s.runs, jobs=1)
    assert ran == 4 and not failures
    return s, root / "tiny"


class Damaged:
    """``with Damaged(path, data):`` ``path`` holds ``data`` (bytes), then its own bytes again."""

    def __init__(self, path, data):
        self.path, self.data = path, data

    def __enter__(self):
        self.kept = self.path.read_bytes()
        self.path.write_bytes(self.data)

    def __exit__(self, *exc):
        self.path.write_bytes(self.kept)


# --------------------------------------------------------------------------- a run's files

TABLES = delivery.TABLES
arrow_types = st.recursive(st.sampled_from([pa.int16(), pa.int32(), pa.int64(), pa.float64(), pa.string(),
                                            pa.bool_(), pa.null()]),
                           lambda inner: inner.map(pa.list_) | inner.map(lambda t: pa.struct([("a", t)])),
                           max_leaves=12)
known_names = sorted({field.name for schema in delivery.table_schemas().values() for field in schema})
column_names = st.sampled_from([*known_names, "seed", "rule"]) | st.text(max_size=6)
metadata = st.one_of(
    st.just("config"),   # the run's own config
    st.none(),
    st.binary(max_size=30),
    st.integers(1, 5000).map(lambda n: ("[" * n + "]" * n).encode()),
    st.recursive(st.integers() | st.text(max_size=4) | st.none(),
                 lambda inner: st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=4), inner, max_size=3),
                 max_leaves=10).map(lambda value: json.dumps(value).encode()),
)


@st.composite
def other_tables(draw):
    """A parquet file of drawn columns (nested types), rows (nulls) and config metadata, as bytes."""
    columns = draw(st.dictionaries(column_names, arrow_types, max_size=6))
    rows = draw(st.integers(0, 2))
    table = pa.table({name: pa.nulls(rows, kind) for name, kind in columns.items()}) if columns else pa.table({})
    return table, draw(metadata)


damages = st.one_of(
    st.tuples(st.just("truncate"), st.floats(0, 1)),
    st.tuples(st.just("garble"), st.floats(0, 1), st.binary(min_size=1, max_size=64)),
    st.tuples(st.just("bytes"), st.binary(max_size=300)),
    st.tuples(st.just("table"), other_tables()),
)


def damaged_bytes(original, damage, config):
    kind, *how = damage
    if kind == "truncate":
        return original[:int(how[0] * (len(original) - 1))]
    if kind == "garble":
        at = int(how[0] * (len(original) - 1))
        return original[:at] + how[1] + original[at + len(how[1]):]
    if kind == "bytes":
        return how[0]
    table, meta = how[0]
    meta = config.to_json().encode() if meta == "config" else meta
    table = table.replace_schema_metadata(None if meta is None else {CONFIG_KEY: meta})
    sink = pa.BufferOutputStream()
    pq.write_table(table, sink)
    return sink.getvalue().to_pybytes()


@settings(SETTINGS, max_examples=25)   # each example reads the dataset three ways
@given(st.integers(0, 3), st.sampled_from(TABLES), damages)
def test_any_damage_to_a_part_gives_a_state_and_readers_a_result_or_a_data_error(dataset, index, table, damage):
    s, out = dataset
    run = s.runs[index]
    path = run.path(out, table)
    with Damaged(path, damaged_bytes(path.read_bytes(), damage, run.config)):
        found = outcome(sw.inspect, run, out)
        if isinstance(found, ConfigError):   # a summary of another config: the sweep file changed
            assert isinstance(found, sw.SweepError) and table == "summary"
            return
        state, why = found
        assert state == "done" and why is None or state == "damaged" and str(path) in why and "\n" not in why
        data = sw.dataset(s, out, table)
        read = outcome(sw.rows, s, out, table, data)
        assert isinstance(read, (pa.Table, ConfigError))
        if isinstance(read, pa.Table):
            assert read.num_rows == ROWS[table] * len(data.files)
        collected = outcome(sw.collect, s, out)
        assert isinstance(collected, (tuple, ConfigError))


# --------------------------------------------------------------------------- side files

json_values = st.recursive(st.integers() | st.floats() | st.text(max_size=6) | st.booleans() | st.none(),
                           lambda inner: st.lists(inner, max_size=4) | st.dictionaries(
                               st.sampled_from(["keys", "error", "run"]) | st.text(max_size=4), inner, max_size=3),
                           max_leaves=16)
side_bytes = st.one_of(
    json_values.map(lambda value: json.dumps(value).encode()),
    st.lists(st.text(alphabet="[]{}\"keys:, 01", max_size=3), max_size=40).map(lambda parts: "".join(parts).encode()),
    st.integers(1, 100_000).map(lambda n: ('{"keys": ' + "[" * n + "]" * n + "}").encode()),
    st.binary(max_size=200),
)


@SETTINGS
@given(side_bytes)
def test_any_layout_file_gives_a_layout_or_a_sweep_error(dataset, data):
    s, out = dataset
    with Damaged(out / sw.LAYOUT_FILE, data):
        result = outcome(sw.check_layout, s, out)
    assert result is None or isinstance(result, sw.SweepError) and sw.LAYOUT_FILE in str(result)


@SETTINGS
@given(side_bytes)
def test_any_failure_record_gives_one_line_for_status(dataset, data):
    s, out = dataset
    record = s.runs[0].failure_path(out)
    record.parent.mkdir(exist_ok=True)
    record.write_text("{}")
    try:
        with Damaged(record, data):
            shown = sw._recorded_error(record)
    finally:
        record.unlink()
    assert isinstance(shown, str) and "\n" not in shown and "\r" not in shown


# --------------------------------------------------------------------------- sweep files


def toml_value(value):
    """A TOML spelling of a drawn value: scalars, arrays and inline tables, nested."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return "nan" if math.isnan(value) else ("inf" if value > 0 else "-inf") if math.isinf(value) else repr(value)
    if isinstance(value, str):
        return json.dumps(value)   # a JSON string is a TOML basic string
    if isinstance(value, list):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{json.dumps(k)} = {toml_value(v)}" for k, v in value.items()) + "}"
    return str(value)


keys = st.sampled_from(["name", "base", "seeds", "runs_per_task", "scenario", "rule", "tau_minutes", "n_uavs",
                        "horizon_weeks", "seed", "start", "count", "auction.rule"]) | st.text("abz_.", max_size=6)
sweep_values = st.recursive(st.integers(-10, 10**6) | st.floats() | st.booleans()
                            | st.sampled_from(["tiny", "random", "least_confident", "delivery", "replenishment"]),
                            lambda inner: st.lists(inner, max_size=4) | st.dictionaries(keys, inner, max_size=3),
                            max_leaves=10)
sweep_lines = st.one_of(
    st.sampled_from(["[sweep]", "[set]", "[grid]", "[[grid]]", "[other]"]),
    st.builds(lambda k, v: f"{json.dumps(k) if '.' not in k else k} = {toml_value(v)}", keys, sweep_values),
    st.integers(1, 3000).map(lambda n: "rule = " + "[" * n + "]" * n),
    st.text(max_size=20),
)


@SETTINGS
@given(st.lists(sweep_lines, max_size=10), st.floats(0, 1), st.binary(max_size=60))
def test_any_sweep_file_gives_a_sweep_or_a_sweep_error(lines, cut, junk):
    tiny = TINY_SWEEPS["delivery"].encode()
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "drawn.toml"
        for data in ("\n".join(lines).encode("utf-8", "surrogatepass"), tiny[:int(cut * len(tiny))], junk,
                     tiny + b"\n" + "\n".join(lines).encode("utf-8", "surrogatepass")):
            path.write_bytes(data)
            assert isinstance(outcome(sw.load_sweep, path), (sw.Sweep, ConfigError))
