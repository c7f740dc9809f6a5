"""The ``dronefleet run`` command: outputs, summary, refusal of bad input before any work."""

import io

import pyarrow.parquet as pq
import pytest

from dronefleet import cli
from dronefleet.delivery.records import TABLES, read_config

SHORT = ["--set", "horizon_weeks=0.05", "--set", "n_uavs=5"]


def test_run_writes_every_table_with_its_config_and_prints_the_summary(tmp_path, capsys):
    out = tmp_path / "run"
    assert cli.main(["run", *SHORT, "--seed", "3", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    for label in ("orders arrived", "delivered", "median delivery time", "aborted attempts", "backlog age",
                  "lost UAVs", "wall time"):
        assert label in printed
    assert sorted(p.name for p in out.iterdir()) == sorted(f"{name}.parquet" for name in TABLES)
    config = read_config(out / "summary.parquet")
    assert (config.seed, config.n_uavs, config.horizon_weeks) == (3, 5, 0.05)
    summary = pq.read_table(out / "summary.parquet").to_pylist()[0]
    assert f"orders arrived        {summary['orders_arrived']}" in printed


def test_config_file_and_overrides(tmp_path):
    path = tmp_path / "mine.toml"
    path.write_text("[orders]\ntau_minutes = 40.0\n[fleet]\nn_uavs = 3\n")
    out = tmp_path / "run"
    assert cli.main(["run", str(path), "--set", "horizon_weeks=0.02", "--out", str(out)]) == 0
    config = read_config(out / "orders.parquet")
    assert (config.tau_minutes, config.n_uavs, config.seed) == (40.0, 3, 0)


@pytest.mark.parametrize("args, message", [
    (["--set", "tau=5"], "tau_minutes"),
    (["--set", "tau_minutes=-1"], "orders.tau_minutes"),
    (["--set", "soh_min=0"], "fleet.soh_min"),
    (["--set", "xi=1"], "energy.xi"),
    (["--set", "rule=best"], "least_confident"),
    (["--set", "n_uavs"], "key=value"),
])
def test_bad_input_is_refused_before_any_work(tmp_path, capsys, args, message):
    out = tmp_path / "run"
    assert cli.main(["run", *args, "--out", str(out)]) == 2
    assert message in capsys.readouterr().err
    assert not out.exists()


def test_progress_bar_draws_weeks_only_on_a_terminal():
    class Terminal(io.StringIO):
        def isatty(self):
            return True

    stream = Terminal()
    bar = cli.ProgressBar(8 * 604800.0, stream=stream, width=8)
    bar(4 * 604800.0)
    assert "week  4.0 of 8 [####....]" in stream.getvalue()
    bar(8 * 604800.0)
    assert stream.getvalue().endswith("[########]\n")

    quiet = io.StringIO()
    cli.ProgressBar(8 * 604800.0, stream=quiet)(604800.0)
    assert quiet.getvalue() == ""


@pytest.mark.parametrize("error", ["SupervisorError", "InvalidStateError"])
def test_a_run_the_engine_stops_ends_in_one_line_and_writes_nothing(tmp_path, capsys, monkeypatch, error):
    from dronefleet import supervisor
    from dronefleet.delivery import simulation
    cls = {"SupervisorError": supervisor.SupervisorError, "InvalidStateError": simulation.InvalidStateError}[error]

    def stopped(*args, **kwargs):
        raise cls("UAV 3 has a NaN event time")

    monkeypatch.setattr(simulation, "simulate", stopped)
    out = tmp_path / "run"
    assert cli.main(["run", *SHORT, "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.splitlines() == ["dronefleet: error: the run stopped: UAV 3 has a NaN event time"]
    assert not out.exists() and not any(p.name.startswith(".") for p in tmp_path.iterdir())
