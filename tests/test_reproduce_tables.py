"""``reproduce --redraw`` and ``--check`` read the figures' tables as data: every column they rely on is
checked (present, of its type, value by value) before any drawing or re-run, and a table that fails
is one line naming the file and the column, exit code 2, with nothing drawn, run or written.

The tables are copies of the committed ``results/``, each damaged in one column.
"""

import importlib
import shutil
from pathlib import Path

import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from dronefleet import cli

RESULTS = Path(__file__).resolve().parents[1] / "results"


def copy_tables(figure, root):
    """The parquet tables of the committed ``figure`` copied to ``root/figure``."""
    (root / figure).mkdir(parents=True)
    for table in (RESULTS / figure).glob("*.parquet"):
        shutil.copy(table, root / figure / table.name)


def set_first(name, value):
    """A change of a table: column ``name``'s first value set to ``value`` (of the column's type)."""
    def change(table):
        values = table[name].to_pylist()
        values[0] = value
        return table.set_column(table.schema.get_field_index(name), name, pa.array(values, table.schema.field(name).type))
    return change


def as_text(name):
    return lambda table: table.set_column(table.schema.get_field_index(name), name, table[name].cast(pa.string()))


def numbered(name):
    """A change of a table: column ``name`` replaced by the row numbers."""
    return lambda table: table.set_column(table.schema.get_field_index(name), name, pa.array(range(table.num_rows)))


def without(name):
    return lambda table: table.drop_columns([name])


def tamper(path, change):
    table = pq.read_table(path)
    pq.write_table(change(table).replace_schema_metadata(table.schema.metadata), path)


def refused(argv, capsys, *fragments):
    assert cli.main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("dronefleet: error: ") and err.count("\n") == 1, err
    for fragment in fragments:
        assert fragment in err, err


REDRAWN = [
    ("fig16", "outcomes", without("rule"), "has no column 'rule'"),
    # the kind a column must be, in words
    ("fig16", "outcomes", as_text("tau_minutes"), "column 'tau_minutes' is string, not a number"),
    ("fig16", "outcomes", numbered("rule"), "column 'rule' is int64, not text"),
    ("fig19", "thresholds", as_text("best"), "column 'best' is string, not true or false"),
    ("fig16", "outcomes", set_first("delivered", None), "column 'delivered' holds null at row 0"),
    ("fig16", "outcomes", set_first("tau_minutes", float("nan")), "column 'tau_minutes' holds nan at row 0"),
    ("fig16", "backlog", set_first("rule", None), "column 'rule' holds null at row 0; allowed: text"),
    ("fig16", "backlog", without("backlog_age_s"), "has no column 'backlog_age_s'"),
    ("fig17", "accuracy", set_first("confidence", float("inf")), "column 'confidence' holds inf at row 0"),
    ("fig17", "accuracy", set_first("week", None), "column 'week' holds null at row 0"),
    ("fig18", "winner_soh", set_first("soc", float("nan")), "column 'soc' holds nan at row 0"),
    ("fig18", "winner_soh", without("mass_kg"), "has no column 'mass_kg'"),
    ("fig19", "thresholds", set_first("best", None), "column 'best' holds null at row 0"),
    ("fig19", "thresholds", as_text("runs"), "column 'runs' is string, not an integer"),
    ("fig20", "pending", set_first("pending", -1), "column 'pending' holds -1 at row 0; allowed: an integer >= 0"),
    ("fig20", "pending", without("arrival_week"), "has no column 'arrival_week'"),
    ("fig10", "runs", set_first("strategy", None), "column 'strategy' holds null at row 0"),
    ("fig10", "bounds", without("bound_work"), "has no column 'bound_work'"),
    ("fig09", "runs", as_text("work"), "column 'work' is string"),
    ("fig10", "runs", lambda table: table.slice(0, 0), "holds no rows"),
    ("fig16", "outcomes", lambda table: table.slice(0, 0), "holds no rows"),
    ("fig17", "accuracy", lambda table: table.slice(0, 0), "holds no rows"),
    # every run records its robots: no rows is a broken run's table (deaths need not happen: below)
    ("lunar-fig08", "robots", lambda table: table.slice(0, 0), "holds no rows"),
    ("lunar-fig08", "deaths", set_first("role", None), "column 'role' holds null at row 0"),
    ("fig18", "winner_soh", lambda table: pa.concat_tables([table, table.slice(0, 1)]), "repeats soc, mass_kg, "
                                                                                        "distance_m = "),
    ("fig20", "pending", set_first("arrival_week", 2**62), "column 'arrival_week' holds 4611686018427387904"),
    ("fig16", "backlog", set_first("arrival_week", -5), "column 'arrival_week' holds -5 at row 0"),
    ("fig17", "accuracy", set_first("week", 1001), "column 'week' holds 1001 at row 0"),
    ("fig10", "runs", set_first("strategy", "evilmod:x"), "strategy = 'evilmod:x'"),
    ("fig09", "runs", set_first("n_chargers", -3), "n_chargers = -3"),
    ("fig09", "runs", set_first("n_chargers", 10**9), "n_chargers = 1000000000"),
    ("fig12", "bounds", set_first("transfer_loss", 2.0), "transfer_loss = 2.0"),
    # a column of the simulator's summary the figure's statistics are derived from
    ("lunar-fig07", "runs", as_text("trips"), "column 'trips' is string, not an integer"),
    ("lunar-control", "runs", as_text("deaths_per_session"), "column 'deaths_per_session' is string"),
]


@pytest.mark.parametrize("figure, table, change, fragment", REDRAWN,
                         ids=[f"{figure}-{table}-{fragment[:30]}" for figure, table, _, fragment in REDRAWN])
def test_redraw_refuses_a_table_it_cannot_draw_in_one_line(figure, table, change, fragment, tmp_path, capsys):
    copy_tables(figure, tmp_path)
    path = tmp_path / figure / f"{table}.parquet"
    tamper(path, change)
    before = sorted(tmp_path.rglob("*"))
    refused(["reproduce", figure, "--redraw", "--out", str(tmp_path)], capsys, str(path), fragment)
    assert sorted(tmp_path.rglob("*")) == before  # nothing drawn


def test_tables_of_events_a_run_need_not_have_redraw_without_rows(tmp_path, capsys):
    # lunar-fig08's deaths and recharging interruptions (none in --quick's short runs, say)
    copy_tables("lunar-fig08", tmp_path)
    for name in ("deaths", "recharge_triggers"):
        tamper(tmp_path / "lunar-fig08" / f"{name}.parquet", lambda table: table.slice(0, 0))
    assert cli.main(["reproduce", "lunar-fig08", "--redraw", "--out", str(tmp_path)]) == 0
    assert (tmp_path / "lunar-fig08" / "lunar-fig08.png").is_file()


def test_the_committed_tables_redraw(tmp_path, capsys):
    copy_tables("fig20", tmp_path)
    assert cli.main(["reproduce", "fig20", "--redraw", "--out", str(tmp_path)]) == 0
    assert (tmp_path / "fig20" / "fig20.png").is_file()


def test_a_redrawn_side_table_keeps_the_bytes_of_the_committed_one(tmp_path, capsys):
    # --redraw read the table with its checked columns first: thresholds.csv came out reordered
    copy_tables("fig19", tmp_path)
    assert cli.main(["reproduce", "fig19", "--redraw", "--out", str(tmp_path)]) == 0
    for name in ("thresholds.csv", "thresholds.md"):
        assert (tmp_path / "fig19" / name).read_bytes() == (RESULTS / "fig19" / name).read_bytes(), name


def no_run(*args, **kwargs):
    raise AssertionError("--check ran a simulation before its table was checked")


@pytest.mark.parametrize("change, fragment", [
    (without("run"), "has no column 'run'"),
    (set_first("sweep", None), "column 'sweep' holds null at row 0"),
    (lambda table: table.append_column("extra", pa.array([[1]] * table.num_rows)), "not one value a row (not a list, struct or map)"),
])
def test_check_refuses_a_delivery_runs_table_it_cannot_compare_before_any_run(change, fragment, tmp_path, capsys,
                                                                             monkeypatch):
    from dronefleet.delivery import simulation

    monkeypatch.setattr(simulation, "simulate", no_run)
    copy_tables("fig16", tmp_path)
    path = tmp_path / "fig16" / "runs.parquet"
    tamper(path, change)
    refused(["reproduce", "fig16", "--check", "--out", str(tmp_path)], capsys, str(path), fragment)


@pytest.mark.parametrize("column, value, fragment", [
    ("ticks", 10**12, "ticks = 1000000000000"),  # past the upper limit of one trial
    ("ticks", 10**8, "robot-ticks"),  # each trial allowed, all of them together days of running
    ("work_ratio", -1.0, "work_ratio"),
    ("charge_rate", float("nan"), "column 'charge_rate' holds nan at row 0"),
    ("trial", range, "first_trial = 0 is out of range"),  # trials 0, 1, 2, ...: consecutive, but from 0
    ("trial", 1, "holds the trials [1, 1, 1,"),  # each row trial 1: re-running them would be one trial many times
    ("n_workers", -6, "n_workers"),
])
def test_check_refuses_a_replenishment_configuration_it_cannot_re_run_before_any_run(column, value, fragment, tmp_path,
                                                                                    capsys, monkeypatch):
    # the module (the package's attribute of that name is its function)
    monkeypatch.setattr(importlib.import_module("dronefleet.replenishment.simulate"), "simulate", no_run)
    copy_tables("fig09", tmp_path)
    path = tmp_path / "fig09" / "runs.parquet"

    def change(table):  # every row: the configurations --check picks hold the value too
        index = table.schema.get_field_index(column)
        values = value(table.num_rows) if callable(value) else [value] * table.num_rows
        return table.set_column(index, column, pa.array(values, table.schema.field(column).type))
    tamper(path, change)
    refused(["reproduce", "fig09", "--check", "--out", str(tmp_path)], capsys, str(path), fragment)


@pytest.mark.parametrize("figure, table", [("items-fig04", "runs"), ("lunar-fig07", "timeseries")])
def test_redraw_refuses_a_table_of_more_rows_than_a_study_writes_before_reading_it(figure, table, tmp_path, capsys):
    # Read whole, 2-3 million rows exhausted 4 GiB of address space (a MemoryError traceback); the
    # bound is the table's row count, in its footer.
    from dronefleet.reproduce import MAX_TABLE_ROWS

    copy_tables(figure, tmp_path)
    path = tmp_path / figure / f"{table}.parquet"
    tamper(path, lambda rows: pa.concat_tables([rows] * (MAX_TABLE_ROWS // rows.num_rows + 1))
           .slice(0, MAX_TABLE_ROWS + 1))
    before = sorted(tmp_path.rglob("*"))
    refused(["reproduce", figure, "--redraw", "--out", str(tmp_path)], capsys, str(path),
            f"holds {MAX_TABLE_ROWS + 1:,} rows")
    assert sorted(tmp_path.rglob("*")) == before  # nothing drawn


@pytest.mark.parametrize("command", ["--redraw", "--check"])
@pytest.mark.parametrize("table, column, value, fragment", [
    ("runs", "battery_wh", 0.0, "energy.battery_wh = 0.0 is out of range"),
    ("runs", "battery_wh", 1e308, "energy.battery_wh = 1e+308 is out of range"),
    ("timeseries", "v0", 50.0, "robots.v0 = 50.0 is out of range"),
    ("runs", "layout", "MOON", "world.layout = 'MOON' is not allowed"),
])
def test_a_lunar_condition_outside_a_config_files_rules_is_refused_before_any_run(command, table, column, value,
                                                                                  fragment, tmp_path, capsys,
                                                                                  monkeypatch):
    monkeypatch.setattr(importlib.import_module("dronefleet.lunar.simulate"), "simulate", no_run)
    copy_tables("lunar-fig07", tmp_path)
    path = tmp_path / "lunar-fig07" / f"{table}.parquet"
    tamper(path, set_first(column, value))
    before = sorted(tmp_path.rglob("*"))
    refused(["reproduce", "lunar-fig07", command, "--out", str(tmp_path)], capsys, str(path), fragment)
    assert sorted(tmp_path.rglob("*")) == before  # nothing drawn


def test_every_column_of_the_scenario_studies_tables_has_a_kind_to_check():
    # A column a study does not declare is read as any flat type (text where a number belongs);
    # the delivery figures' tables keep the sweeps' other columns, which --check compares value by value.
    from dronefleet import reproduce

    for path in sorted(RESULTS.glob("*/*.parquet")):
        if path.parent.name not in reproduce.FIGURES:   # a design's dataset summary (*-sensitivity), not a figure's
            continue
        study = reproduce.owner(path.parent.name)
        if study is not reproduce.DELIVERABLE:
            undeclared = set(pq.read_schema(path).names) - set(study.TABLE_COLUMNS[path.stem])
            assert not undeclared, (path, undeclared)
