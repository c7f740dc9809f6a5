"""A damaged file never blocks a whole sweep dataset, and side files are read with limits.

A run's file that is truncated, garbled, without its config or with other columns is
"damaged": ``sweep status`` lists it in one line naming the file, ``sweep collect`` leaves the
run out saying so in one line, ``sweep run`` (and ``reproduce``) redo the run, replacing its
files. A ``_layout.json`` that is not a small regular file of ``{"keys": [...]}`` is refused in
one line naming it (exit 2, nothing written); a ``_failed/`` record that cannot be read leaves
``status`` listing the run as failed, and ``sweep run`` redoes it.
"""

import json
import os
import shutil

import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from dronefleet import cli, console, reproduce, scenarios, sweeps as sw
from dronefleet.datafiles import MAX_JSON_BYTES, DataError
from dronefleet.records import CONFIG_KEY

from conftest import TINY_SWEEPS


def run_cli(args):
    try:
        return cli.main(args)
    except SystemExit as stop:
        return stop.code


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    """The tiny delivery sweep (4 runs), run once: ``(sweep file, results root)``, to be copied."""
    root = tmp_path_factory.mktemp("built")
    path = root / "tiny.toml"
    path.write_text(TINY_SWEEPS["delivery"])
    assert cli.main(["sweep", "run", str(path), "--results", str(root / "results"), "--jobs", "1"]) == 0
    return path, root / "results"


@pytest.fixture
def copy(built, tmp_path, monkeypatch, capsys):
    """A copy of the built dataset: ``(sweep file, results root, sweep, dataset folder)``."""
    for name, _ in sw.TASK_VARIABLES:
        monkeypatch.delenv(name, raising=False)
    path, results = built
    shutil.copytree(results, tmp_path / "results")
    capsys.readouterr()
    return path, tmp_path / "results", sw.load_sweep(path), tmp_path / "results" / "tiny"


def snapshot(root):
    return sorted((str(p.relative_to(root)), p.lstat().st_size if not p.is_dir() else 0) for p in root.rglob("*"))


def rewrite(path, change):
    """Write ``change(table)`` (its metadata kept unless changed) over the parquet file ``path``."""
    table = pq.read_table(path)
    pq.write_table(change(table), path)


def truncated(path):
    path.write_bytes(path.read_bytes()[:path.stat().st_size // 2])


def garbled_footer(path):
    data = bytearray(path.read_bytes())
    data[-40:-8] = b"\xab" * 32   # the footer's thrift; its length and the magic stay
    path.write_bytes(bytes(data))


def without_config(path):
    rewrite(path, lambda t: t.replace_schema_metadata({k: v for k, v in t.schema.metadata.items() if k != CONFIG_KEY}))


def with_a_column_more(path):
    rewrite(path, lambda t: t.append_column("extra", pa.array([0] * t.num_rows)))


def with_a_partition_column(path):   # readers refuse a column that is also a partition key
    rewrite(path, lambda t: t.append_column("seed", pa.array([0] * t.num_rows)))


def retyped(path):
    rewrite(path, lambda t: t.set_column(0, t.field(0).name, pa.array([str(v) for v in t.column(0).to_pylist()])))


def float_for_int(path):   # the same values, as another writer may give them
    def change(t):
        i = next(i for i, field in enumerate(t.schema) if pa.types.is_integer(field.type))
        return t.set_column(i, t.field(i).name, t.column(i).cast(pa.float64()))
    rewrite(path, change)


def another_config(path):
    document = json.loads(pq.read_schema(path).metadata[CONFIG_KEY])
    section = next(name for name, keys in document.items() if "n_uavs" in keys)
    document[section]["n_uavs"] += 1
    rewrite(path, lambda t: t.replace_schema_metadata({**t.schema.metadata, CONFIG_KEY: json.dumps(document)}))


def to_dev_zero(path):
    path.unlink()
    os.symlink("/dev/zero", path)


def fifo(path):
    path.unlink()
    os.mkfifo(path)


def folder(path):
    path.unlink()
    path.mkdir()


DAMAGES = [truncated, garbled_footer, without_config, with_a_column_more, with_a_partition_column, retyped,
           float_for_int, to_dev_zero, fifo]


@pytest.mark.parametrize("table", ["summary", "orders"])
@pytest.mark.parametrize("damage", DAMAGES + [another_config])
def test_status_lists_a_damaged_run_in_one_line_naming_its_file(copy, capsys, damage, table):
    path, results, s, out = copy
    if damage is another_config and table == "summary":
        pytest.skip("a summary of another config is a changed sweep file: refused, see test_sweep.py")
    part = s.runs[0].path(out, table)
    damage(part)
    assert run_cli(["sweep", "status", str(path), "--results", str(results)]) == 1
    captured = capsys.readouterr()
    assert "Traceback" not in captured.err and captured.err == ""
    assert "3 done, 0 missing, 0 failed, 1 damaged" in captured.out
    lines = [line for line in captured.out.splitlines() if "damaged  " in line]
    assert len(lines) == 1 and s.runs[0].partition in lines[0] and str(part) in lines[0], captured.out
    assert sw.inspect(s.runs[1], out) == ("done", None)


@pytest.mark.parametrize("table", ["summary", "timeseries"])
@pytest.mark.parametrize("damage", DAMAGES)
def test_collect_leaves_a_damaged_run_out_in_one_line(copy, capsys, damage, table):
    path, results, s, out = copy
    part = s.runs[2].path(out, table)
    damage(part)
    assert run_cli(["sweep", "collect", str(path), "--results", str(results)]) == 1
    captured = capsys.readouterr()
    assert "Traceback" not in captured.err
    warnings = [line for line in captured.err.splitlines() if str(part) in line]
    assert len(warnings) == 1 and s.runs[2].partition in warnings[0], captured.err
    assert "3 of 4 runs" in captured.out
    collected = pq.read_table(out / "collected.parquet")
    assert sorted(collected.column("seed").to_pylist()) == [0, 1, 1]   # runs[2] is random, seed 0


@pytest.mark.parametrize("table", ["summary", "fleet"])
@pytest.mark.parametrize("damage", DAMAGES + [another_config])
def test_sweep_run_redoes_a_damaged_run_replacing_its_files(copy, capsys, damage, table):
    path, results, s, out = copy
    if damage is another_config and table == "summary":
        pytest.skip("a summary of another config is a changed sweep file: refused, see test_sweep.py")
    part = s.runs[3].path(out, table)
    damage(part)
    assert run_cli(["sweep", "run", str(path), "--results", str(results), "--jobs", "1"]) == 0
    captured = capsys.readouterr()
    assert "Traceback" not in captured.err
    warnings = [line for line in captured.err.splitlines() if str(part) in line]
    assert len(warnings) == 1 and s.runs[3].partition in warnings[0], captured.err
    assert "ran 1, skipped 3 done before, 0 failed" in captured.out
    assert [sw.inspect(run, out) for run in s.runs] == [("done", None)] * 4
    assert part.is_file() and not part.is_symlink()
    assert not list(out.rglob("*.tmp"))


@pytest.mark.parametrize("rows", [0, 2, 1000])
def test_a_summary_of_another_number_of_rows_than_its_runs_replicates_is_damage(copy, capsys, rows):
    path, results, s, out = copy
    part = s.runs[1].path(out, "summary")   # a delivery run is one replicate: one row
    rewrite(part, lambda t: t.take(pa.array([0] * rows, pa.int64())))
    assert run_cli(["sweep", "status", str(path), "--results", str(results)]) == 1
    captured = capsys.readouterr()
    assert "3 done, 0 missing, 0 failed, 1 damaged" in captured.out
    assert f"damaged  {s.runs[1].partition}: part {str(part)!r} holds {rows:,} rows; the summary of run" in captured.out
    assert run_cli(["sweep", "collect", str(path), "--results", str(results)]) == 1
    assert pq.read_table(out / "collected.parquet").num_rows == 3
    capsys.readouterr()
    assert run_cli(["sweep", "run", str(path), "--results", str(results), "--jobs", "1"]) == 0
    assert "ran 1, skipped 3 done before" in capsys.readouterr().out
    assert pq.read_metadata(part).num_rows == 1


@pytest.mark.parametrize("table", ["summary", "orders"])
def test_a_folder_where_a_part_goes_is_refused_in_one_line_before_any_run_writes(copy, capsys, table):
    path, results, s, out = copy
    part = s.runs[0].path(out, table)
    folder(part)
    (part / "mine.txt").write_text("the user's")
    shutil.rmtree(s.runs[1].path(out, "summary").parent)   # a run to do beside it
    before = snapshot(results)
    assert run_cli(["sweep", "run", str(path), "--results", str(results), "--jobs", "1"]) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err and len(err.splitlines()) == 1, err
    assert f"{str(part)!r}, the {table} file of run {s.runs[0].partition}, is a folder" in err
    assert snapshot(results) == before   # no run written, the folder kept
    assert run_cli(["sweep", "status", str(path), "--results", str(results)]) == 1
    assert f"damaged  {s.runs[0].partition}: part {str(part)!r} is not a regular file" in capsys.readouterr().out


@pytest.mark.parametrize("name, changes", [("delivery", {"horizon_weeks": 0.02, "n_uavs": 3}),
                                           ("replenishment", {"trials": 2, "ticks": 200})])
def test_the_declared_schemas_are_those_the_scenarios_write(name, changes):
    scenario = scenarios.SCENARIOS[name]
    tables = scenario.simulate(scenario.replace(scenario.load(None), changes))
    schemas = scenario.table_schemas()
    assert set(tables) == set(schemas) == set(scenario.tables)
    for table, data in tables.items():
        assert [(f.name, f.type) for f in data.schema] == [(f.name, f.type) for f in schemas[table]], table


# ---------------------------------------------------------------------------- reproduce reads sweep datasets


def study_of(s, results):
    """A reproduce study whose sweep ``tiny`` is ``s``, under ``results``, on this process."""
    study = reproduce.Study(results, jobs=1)
    study._sweeps["tiny"] = s
    return study


def test_reproduce_redoes_a_damaged_run_before_reading_the_sweep(copy, capsys):
    _, results, s, out = copy
    part = s.runs[1].path(out, "orders")
    truncated(part)
    console.configure()
    study = study_of(s, results)
    study.ensure("tiny")
    err = capsys.readouterr().err
    assert "Traceback" not in err and len([line for line in err.splitlines() if str(part) in line]) == 1, err
    orders = study.table("tiny", "orders", seed=1)
    assert set(orders["rule"]) == {"least_confident", "random"}


def garbled_page(path):
    """Garble the first page, leaving the footer whole: only reading the data finds it."""
    data = bytearray(path.read_bytes())
    data[4:36] = b"\xab" * 32
    path.write_bytes(bytes(data))


def test_a_page_garbled_behind_a_whole_footer_is_named_when_read(copy, capsys):
    path, results, s, out = copy
    part = s.runs[2].path(out, "attempts")
    garbled_page(part)
    study = study_of(s, results)
    with pytest.raises(DataError) as refused:
        study.table("tiny", "attempts")
    message = str(refused.value)
    assert "\n" not in message and str(part) in message and s.runs[2].partition in message
    # removed as the message says, the run is redone
    part.unlink()
    assert run_cli(["sweep", "run", str(path), "--results", str(results), "--jobs", "1"]) == 0
    assert "ran 1, skipped 3 done before, 0 failed" in capsys.readouterr().out
    assert study_of(s, results).table("tiny", "attempts").shape[0] > 0


# ---------------------------------------------------------------------------- side files


def deeply_nested(path):
    path.write_text("[" * 100_000 + "]" * 100_000)


def too_large(path):
    path.write_text('{"keys": ["rule", "seed"]}' + " " * MAX_JSON_BYTES)


def written(text):
    def write(path):
        path.write_text(text)
    write.__name__ = f"written {text!r}"
    return write


SIDE_DAMAGES = [deeply_nested, too_large, to_dev_zero, fifo, folder, written("[1, 2]"), written('{"keys": [1]}'),
                written('{"keys": ["rule\\nseed"]}'), written('{"keys": ["rule", "seed"], "more": 1}'),
                written('{"keys": []}'), written("\"keys\"")]


@pytest.mark.parametrize("damage", SIDE_DAMAGES, ids=lambda f: f.__name__)
@pytest.mark.parametrize("command", ["run", "plan", "status", "collect"])
def test_a_damaged_layout_file_is_refused_in_one_line_naming_it(copy, capsys, damage, command):
    path, results, s, out = copy
    layout = out / sw.LAYOUT_FILE
    if damage in (to_dev_zero, fifo, folder):
        layout.write_text("{}")
    damage(layout)
    before = snapshot(results)
    assert run_cli(["sweep", command, str(path), "--results", str(results)]) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err and len(err.splitlines()) == 1, err
    assert str(layout) in err and "fix or remove it" in err
    assert snapshot(results) == before


@pytest.mark.parametrize("damage", SIDE_DAMAGES, ids=lambda f: f.__name__)
def test_a_damaged_failure_record_is_listed_and_its_run_redone(copy, capsys, damage):
    path, results, s, out = copy
    run = s.runs[0]
    shutil.rmtree(run.path(out, "summary").parent)
    record = run.failure_path(out)
    record.parent.mkdir()
    if damage in (to_dev_zero, fifo, folder):
        record.write_text("{}")
    damage(record)
    assert run_cli(["sweep", "status", str(path), "--results", str(results)]) == 1
    captured = capsys.readouterr()
    assert "Traceback" not in captured.err and "3 done, 0 missing, 1 failed" in captured.out
    line = [line for line in captured.out.splitlines() if "failed   " in line]
    assert len(line) == 1 and f"{run.partition}: (the record {record.name} cannot be read" in line[0], captured.out
    if damage is folder:
        return  # a folder in its place is not removed: the run's own tests cover the warning
    assert run_cli(["sweep", "run", str(path), "--results", str(results), "--jobs", "1"]) == 0
    assert "ran 1, skipped 3 done before, 0 failed" in capsys.readouterr().out
    assert not os.path.lexists(record)


def test_a_failure_record_is_shown_as_one_line_of_text(copy, capsys):
    path, results, s, out = copy
    run = s.runs[0]
    shutil.rmtree(run.path(out, "summary").parent)
    record = run.failure_path(out)
    record.parent.mkdir()
    record.write_text(json.dumps({"error": "PluginError: it \x1b[2J\x1b]0;owned\x07 failed\r\x85more"}))
    assert run_cli(["sweep", "status", str(path), "--results", str(results)]) == 1
    line = [line for line in capsys.readouterr().out.splitlines() if run.partition in line]
    assert line == [f"  failed   {run.partition}: PluginError: it \\x1b[2J\\x1b]0;owned\\x07 failed"], line


@pytest.mark.parametrize("command", ["status", "collect", "run"])
def test_a_file_where_a_tables_folder_goes_is_refused_in_one_line_naming_it(copy, capsys, command):
    path, results, s, out = copy
    shutil.rmtree(out / "orders")
    (out / "orders").write_text("not a folder")
    before = snapshot(results)
    assert run_cli(["sweep", command, str(path), "--results", str(results)]) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err and len(err.splitlines()) == 1, err
    assert f"{str(out / 'orders')!r}" in err and "move or remove it" in err
    assert snapshot(results) == before
