"""Property-based tests of the replay loader: any damage to a run folder gives a page or one line.

One short delivery run, one short replenishment run and one short items run are made per module; every example
damages a copy of one of them (a table cut short, overwritten with random bytes, its config
metadata replaced by random or deeply nested JSON, a column dropped, retyped or given a hostile
value) and writes its page with :func:`dronefleet.replay.write`: the result is a page, or a
:class:`~dronefleet.config.ConfigError` (DataError included) of one line, never another
exception. Deterministic (``derandomize``) and small, as ``tests/test_loader_properties.py``.
"""

import json
import shutil
import tempfile
from pathlib import Path

import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from dronefleet import cli, replay
from dronefleet.config import ConfigError
from dronefleet.records import CONFIG_KEY, REPLAY_FILE

SETTINGS = settings(max_examples=100, deadline=None, derandomize=True, database=None,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
DELIVERY_TABLES = ("orders", "attempts", "fleet", "timeseries", "summary")
REPLENISHMENT_TABLES = ("summary", "timeseries")
ITEMS_TABLES = ("summary", "robots")
TABLES = {"delivery": DELIVERY_TABLES, "replenishment": REPLENISHMENT_TABLES, "items": ITEMS_TABLES}


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """``{scenario: run folder}``: a 0.05-week delivery run of 3 UAVs, a 1-trial replenishment run,
    a 2-trial items run of 100 steps."""
    folder = tmp_path_factory.mktemp("runs")
    assert cli.main(["run", "--set", "horizon_weeks=0.05", "--set", "n_uavs=3", "--seed", "4",
                     "--out", str(folder / "delivery")]) == 0
    (folder / "replenishment.toml").write_text('scenario = "replenishment"\n[run]\ntrials = 1\nticks = 600\n')
    assert cli.main(["run", str(folder / "replenishment.toml"), "--out", str(folder / "replenishment")]) == 0
    (folder / "items.toml").write_text('scenario = "items"\n[run]\ntrials = 2\nsteps = 100\n')
    assert cli.main(["run", str(folder / "items.toml"), "--out", str(folder / "items")]) == 0
    return {"delivery": folder / "delivery", "replenishment": folder / "replenishment", "items": folder / "items"}


def page_or_one_line(run_dir):
    """Write ``run_dir``'s page beside it; the page's path, or the ConfigError raised (one line)."""
    try:
        return replay.write(run_dir, run_dir.parent / "page.html")
    except ConfigError as error:  # DataError included
        assert str(error) and "\n" not in str(error), str(error)
        return error


def damaged(runs, scenario, damage):
    """``damage(copy)`` applied to a copy of the ``scenario`` run, then its page or its one-line error."""
    with tempfile.TemporaryDirectory() as folder:
        copy = Path(folder) / "run"
        shutil.copytree(runs[scenario], copy)
        damage(copy)
        result = page_or_one_line(copy)
        assert isinstance(result, (Path, ConfigError))
        return result


scenario_tables = st.sampled_from([(scenario, name) for scenario, tables in TABLES.items() for name in tables])


@SETTINGS
@given(scenario_tables, st.floats(0.0, 1.0, exclude_max=True))
def test_a_table_cut_short_gives_a_page_or_one_line(runs, where, fraction):
    scenario, name = where

    def cut(run):
        path = run / f"{name}.parquet"
        data = path.read_bytes()
        path.write_bytes(data[:int(len(data) * fraction)])
    assert isinstance(damaged(runs, scenario, cut), ConfigError)


@SETTINGS
@given(scenario_tables, st.binary(max_size=2000), st.floats(0.0, 1.0), st.booleans())
def test_random_bytes_in_a_table_give_a_page_or_one_line(runs, where, junk, fraction, whole):
    scenario, name = where

    def overwrite(run):
        path = run / f"{name}.parquet"
        data = path.read_bytes()
        start = int(len(data) * fraction)
        path.write_bytes(junk if whole else data[:start] + junk[:len(data) - start] + data[start + len(junk):])
    damaged(runs, scenario, overwrite)


json_scalars = (st.none() | st.booleans() | st.integers(-2**70, 2**70) | st.floats(allow_nan=False)
                | st.text(max_size=12) | st.sampled_from(["delivery", "replenishment", "items", "evilmod:x",
                                                          "<!--<script>"]))
keys = st.sampled_from(["scenario", "run", "orders", "fleet", "auction", "rule", "n_uavs", "horizon_weeks", "ticks",
                        "trials", "first_trial", "steps", "locations", "n_robots", "mode"]) | st.text(max_size=6)
json_values = st.recursive(json_scalars, lambda inner: st.lists(inner, max_size=4)
                           | st.dictionaries(keys, inner, max_size=4), max_leaves=12)


@st.composite
def config_texts(draw):
    """What a table's config metadata may hold: the run's own config with one key changed, random
    JSON, JSON nested deeper than any reader should follow, or bytes that are no JSON at all."""
    kind = draw(st.sampled_from(["changed", "random", "deep", "bytes"]))
    if kind == "random":
        return json.dumps(draw(json_values)).encode()
    if kind == "deep":
        depth = draw(st.integers(1, 100_000))
        opening = draw(st.sampled_from(['[', '{"run":']))
        return (opening * depth + "0" + ("]" if opening == "[" else "}") * depth).encode()
    if kind == "bytes":
        return draw(st.binary(max_size=200))
    return None  # the run's config, one key changed: made from the table


@SETTINGS
@given(st.sampled_from(list(TABLES)), config_texts(), keys, json_values, st.booleans())
def test_any_config_metadata_gives_a_page_or_one_line(runs, scenario, text, key, value, every_table):
    def rewrite(run):
        tables = TABLES[scenario]
        config = text
        if config is None:
            document = json.loads(pq.read_schema(run / "summary.parquet").metadata[CONFIG_KEY])
            section = next(iter(document.values())) if document else document
            (section if isinstance(section, dict) else document)[key] = value
            config = json.dumps(document).encode()
        for name in tables if every_table else ("summary",):
            path = run / f"{name}.parquet"
            table = pq.read_table(path)
            pq.write_table(table.replace_schema_metadata({**table.schema.metadata, CONFIG_KEY: config}), path)
    if scenario == "replenishment" and text is None:
        assume(key not in ("ticks", "trials"))  # a valid longer run re-simulates: not for a quick test
    damaged(runs, scenario, rewrite)


cells = (st.none() | st.integers(-3, 3) | st.sampled_from([10**6, 2**15 - 1, 2**31 - 1]) | st.integers(-2**63, 2**63 - 1)
         | st.floats() | st.text(max_size=8) | st.sampled_from(["teleported", "lost"]) | st.booleans())
#: Columns the pages read, drawn more often than the rest (any column may be drawn).
READ = ["order_id", "uav", "outcome", "takeoff_s", "takeoff_soc", "turn_s", "return_s", "return_soc", "distance_m",
        "arrival_s", "t_s", "unallocated", "trial"]


@st.composite
def column_changes(draw):
    """A change of one table: a column dropped, retyped (to text or another number type),
    all null, or one cell given a hostile value."""
    action = draw(st.sampled_from(["drop", "text", "double", "int64", "nulls", "cell"]))
    which, row, value = draw(st.sampled_from(READ) | st.integers(0, 63)), draw(st.integers(0, 10**6)), draw(cells)

    def change(table):
        position = which if isinstance(which, int) else READ.index(which)
        index = table.column_names.index(which) if which in table.column_names else position % table.num_columns
        name, column = table.column_names[index], table.column(index)
        if action == "drop":
            return table.remove_column(index)
        if action == "text":
            new = pa.array([None if v is None else str(v) for v in column.to_pylist()], pa.string())
        elif action == "nulls":
            new = pa.nulls(table.num_rows, column.type)
        elif action == "cell":
            values = column.to_pylist()
            if not values:
                return table
            values[row % len(values)] = value
            try:
                new = pa.array(values, column.type)
            except (pa.ArrowException, OverflowError, TypeError, ValueError):
                new = pa.array([None if v is None else str(v) for v in values], pa.string())
        else:
            try:
                new = column.cast(pa.float64() if action == "double" else pa.int64(), safe=False)
            except pa.ArrowException:
                return table.remove_column(index)
        return table.set_column(index, name, new)
    return change


@SETTINGS
@given(scenario_tables, column_changes())
def test_any_column_change_gives_a_page_or_one_line(runs, where, change):
    scenario, name = where

    def rewrite(run):
        path = run / f"{name}.parquet"
        table = pq.read_table(path)
        pq.write_table(change(table).replace_schema_metadata(table.schema.metadata), path)
    damaged(runs, scenario, rewrite)


def test_the_undamaged_runs_give_pages(runs):
    for scenario in runs:
        assert isinstance(damaged(runs, scenario, lambda run: (run / REPLAY_FILE).unlink(missing_ok=True)), Path)
