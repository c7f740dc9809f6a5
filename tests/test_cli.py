"""The ``dronefleet run`` command: outputs, summary, refusal of bad input before any work."""

import io
import json
import subprocess
import sys

import pyarrow.parquet as pq
import pytest

from dronefleet import cli, provenance
from dronefleet.config import shipped_config
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


class Terminal(io.StringIO):
    """A stream that says it is a terminal, as stderr is in an interactive shell."""

    def isatty(self):
        return True


def test_a_run_draws_its_week_bar_only_on_a_terminal_and_not_with_quiet(tmp_path, monkeypatch):
    drawn = {}
    for name, stream, flags in (("terminal", Terminal(), []), ("pipe", io.StringIO(), []),
                                ("quiet", Terminal(), ["-q"])):
        monkeypatch.setattr(sys, "stderr", stream)
        assert cli.main([*flags, "run", *SHORT, "--out", str(tmp_path / name)]) == 0
        drawn[name] = stream.getvalue()
    assert "simulated" in drawn["terminal"] and "week" in drawn["terminal"]
    assert drawn["pipe"] == drawn["quiet"] == ""


def test_quiet_prints_nothing_and_verbose_adds_the_resolved_config(tmp_path, capsys):
    assert cli.main(["run", *SHORT, "--out", str(tmp_path / "normal")]) == 0
    normal = capsys.readouterr()
    assert "orders arrived" in normal.out and "config {" not in normal.out and normal.err == ""
    assert cli.main(["-q", "run", *SHORT, "--out", str(tmp_path / "quiet")]) == 0
    assert capsys.readouterr() == ("", "")
    assert cli.main(["run", *SHORT, "--out", str(tmp_path / "verbose"), "--verbose"]) == 0  # after the command too
    verbose = capsys.readouterr().out
    config = json.loads(next(line for line in verbose.splitlines() if line.startswith("  config {"))[len("  config "):])
    assert (config["fleet"]["n_uavs"], config["run"]["horizon_weeks"]) == (5, 0.05)
    assert "orders arrived" in verbose
    # -q still shows what went wrong
    assert cli.main(["-q", "run", "--set", "tau=5", "--out", str(tmp_path / "bad")]) == 2
    assert "tau_minutes" in capsys.readouterr().err


def test_a_configs_path_missing_here_names_the_shipped_file(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)  # away from the repository: configs/... is not here
    assert cli.main(["run", "configs/replenishment.toml"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("dronefleet: error: cannot read config file 'configs/replenishment.toml': No such file")
    assert err.endswith(f" (the one shipped with dronefleet is {shipped_config('replenishment.toml')})\n")
    assert cli.main(["run", "configs/mine.toml"]) == 2  # no such file shipped: no hint
    assert "shipped" not in capsys.readouterr().err


@pytest.mark.parametrize("argv, fragment", [
    (["run", "-q", "-v"], "not allowed with argument"),
    (["-q", "run", "-v"], "-q/--quiet and -v/--verbose are not allowed together"),
    (["-v", "sweep", "status", "x.toml", "--quiet"], "-q/--quiet and -v/--verbose are not allowed together"),
    (["sweep", "-v", "status", "x.toml", "-q"], "-q/--quiet and -v/--verbose are not allowed together"),
])
def test_quiet_and_verbose_together_are_refused(argv, fragment, capsys):
    with pytest.raises(SystemExit) as end:
        cli.main(argv)
    err = capsys.readouterr().err
    assert end.value.code == 2 and err.count("\n") == 1 and fragment in err, err


def test_the_same_level_before_and_after_the_command_is_that_level(tmp_path, capsys):
    assert cli.main(["-q", "run", *SHORT, "--out", str(tmp_path / "run"), "-q"]) == 0
    assert capsys.readouterr().out == ""


def test_python_dash_m_dronefleet_is_the_command():
    done = subprocess.run([sys.executable, "-m", "dronefleet", "--version"], capture_output=True, text=True,
                          timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout == provenance.version_line() + "\n"
    done = subprocess.run([sys.executable, "-m", "dronefleet", "run", "--bad-flag"], capture_output=True, text=True,
                          timeout=120)
    assert done.returncode == 2 and done.stderr.startswith("dronefleet: error: unrecognized arguments: --bad-flag")


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


def _refused(capsys, argv, fragment):
    try:
        code = cli.main(argv)
    except SystemExit as stop:  # argparse
        code = stop.code
    err = capsys.readouterr().err
    assert code == 2 and "Traceback" not in err
    assert len(err.splitlines()) == 1 and fragment in err, err


def test_usage_errors_are_one_line(capsys):
    _refused(capsys, ["run", "--seed", "1e3"], "argument --seed: invalid int value: '1e3' (see dronefleet run --help)")
    _refused(capsys, ["reproduce", "fig99"], "'fig99' is not a figure (did you mean 'fig19'?)")


@pytest.mark.parametrize("argv", [["run", "--out", ""], ["run", "--fleet", ""], ["run", "--save-fleet", ""],
                                  ["replay", "run", "--out", ""], ["sweep", "status", "s.toml", "--results", ""],
                                  ["sweep", "plan", "s.toml", "--out", ""], ["reproduce", "fig20", "--out", ""]])
def test_an_empty_path_is_refused_not_taken_as_the_default_or_the_current_folder(argv, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    _refused(capsys, argv, f"argument {argv[-2]}: expected a path, got an empty one ''")
    assert not list(tmp_path.iterdir())


def test_a_config_that_is_a_pipe_is_refused_not_waited_on(tmp_path, capsys):
    import os
    fifo = tmp_path / "c.toml"
    os.mkfifo(fifo)
    _refused(capsys, ["run", str(fifo), "--out", str(tmp_path / "out")], "is not a regular file")
    assert not (tmp_path / "out").exists()


def test_out_as_a_symlink_and_a_fleet_inside_out_are_refused_before_any_work(tmp_path, capsys, monkeypatch):
    from dronefleet.delivery import simulation
    monkeypatch.setattr(simulation, "simulate", lambda *a, **k: pytest.fail("simulated"))
    (tmp_path / "loop").symlink_to(tmp_path / "loop")
    _refused(capsys, ["run", *SHORT, "--out", str(tmp_path / "loop")], "is a symbolic link")
    out = tmp_path / "out"
    _refused(capsys, ["run", *SHORT, "--out", str(out), "--save-fleet", str(out / "fleet.parquet")],
             "lies inside --out")
    assert not out.exists()


def test_a_degenerate_run_stops_at_the_attempt_limit_in_one_line(tmp_path, capsys, monkeypatch):
    # theta = 0: a UAV with an empty battery takes off, aborts at once and bids again next tick.
    monkeypatch.setattr(simulation_module(), "attempt_limit", lambda config: 5_000)
    out = tmp_path / "out"
    _refused(capsys, ["run", "--set", "rule=threshold", "--set", "theta=0", "--set", "advert_interval_s=0.05",
                      "--set", "horizon_weeks=1", "--out", str(out)], "delivery attempts")
    assert not out.exists()


def simulation_module():
    from dronefleet.delivery import simulation
    return simulation


def test_a_failed_run_write_removes_the_fleet_file_written_before_it(tmp_path, capsys, monkeypatch):
    import errno
    from dronefleet.delivery import records

    def full(*args, **kwargs):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(records, "write_run", full)
    fleet = tmp_path / "fleet.parquet"
    _refused(capsys, ["run", *SHORT, "--out", str(tmp_path / "out"), "--save-fleet", str(fleet)],
             "No space left on device")
    assert not fleet.exists() and not (tmp_path / "out").exists()


def test_a_closed_stdout_ends_quietly(tmp_path):
    import subprocess
    import sys
    proc = subprocess.Popen([sys.executable, "-m", "dronefleet.cli", "run", *SHORT, "--out", str(tmp_path / "o")],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    proc.stdout.close()  # the reader went away, as with `| head -c1`
    err = proc.stderr.read().decode()
    assert proc.wait(timeout=120) == 141 and "Traceback" not in err, err


def test_ctrl_c_ends_in_one_line_with_the_outputs_absent(tmp_path, capsys, monkeypatch):
    from dronefleet.delivery import simulation

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(simulation, "simulate", interrupted)
    assert cli.main(["run", *SHORT, "--out", str(tmp_path / "out")]) == 130
    assert capsys.readouterr().err == "dronefleet: interrupted\n"
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("argv, fragment", [
    (["replay", "run", "--trial", "0"], "argument --trial: expected an integer >= 1"),
    (["run", "--replay", "--trial", "x"], "argument --trial: expected an integer >= 1"),
    (["replay", "ds", "--run"], "argument --run: expected one argument"),
])
def test_replay_options_with_bad_values_are_one_line_usage_errors(argv, fragment, capsys):
    with pytest.raises(SystemExit) as stop:
        cli.main(argv)
    err = capsys.readouterr().err
    assert stop.value.code == 2 and err.count("\n") == 1 and fragment in err, err


def test_replay_help_names_the_dataset_run_and_the_trial(capsys):
    for argv, options in ((["replay", "--help"], ("RUN_DIR|DATASET", "--run KEY=VALUE", "--trial K")),
                          (["run", "--help"], ("--replay", "--trial K"))):
        with pytest.raises(SystemExit):
            cli.main(argv)
        shown = capsys.readouterr().out
        assert all(option in shown for option in options), shown


# ---------------------------------------------------------------- shipped configs and sweep files by name


def test_run_and_bounds_take_a_shipped_config_by_name_from_any_directory(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)  # away from the repository's configs/
    assert cli.main(["run", "replenishment", "--set", "trials=1", "--set", "ticks=30", "--out", "r"]) == 0
    config = json.loads(pq.read_schema(tmp_path / "r" / "summary.parquet").metadata[b"dronefleet.config"])
    assert config["scenario"] == "replenishment" and config["run"]["ticks"] == 30
    assert "dronefleet run: replenishment," in capsys.readouterr().out
    assert cli.main(["bounds", "replenishment"]) == 0
    assert capsys.readouterr().out.startswith("dronefleet bounds: replenishment,")


def test_bounds_defaults_to_the_replenishment_config_and_its_e_cs_with_loss_is_positive(tmp_path, capsys,
                                                                                       monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert cli.main(["bounds", "--set", "transfer_loss=0.6"]) == 0
    (e_cs,) = [line.split()[1] for line in capsys.readouterr().out.splitlines() if line.split()[:1] == ["E_cs"]]
    assert float(e_cs) == pytest.approx(0.3731, abs=5e-5)


def test_a_path_wins_over_the_shipped_file_of_the_same_name(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "replenishment").write_text('scenario = "replenishment"\n[run]\ntrials = 1\nticks = 20\n')
    assert cli.main(["run", "replenishment", "--out", "r"]) == 0
    config = json.loads(pq.read_schema(tmp_path / "r" / "summary.parquet").metadata[b"dronefleet.config"])
    assert config["run"]["ticks"] == 20


def test_sweep_commands_take_a_shipped_sweep_file_by_name(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert cli.main(["sweep", "plan", "smoke", "--results", "res"]) == 0
    assert str(shipped_config("sweeps", "smoke.toml")) in (tmp_path / "res" / "smoke" / "smoke.sbatch").read_text()
    capsys.readouterr()
    assert cli.main(["sweep", "status", "rules", "--results", "res"]) == 1  # nothing run yet
    assert capsys.readouterr().out.startswith("sweep rules: ")


@pytest.mark.parametrize("argv, named", [
    (["run", "replenishmnt"], "'replenishmnt' is neither a file nor a shipped config (did you mean 'replenishment'?)"),
    (["bounds", "papr"], "'papr' is neither a file nor a shipped config (did you mean 'paper'?)"),
    (["sweep", "run", "rule"], "'rule' is neither a file nor a shipped sweep file (did you mean 'rules'?)"),
])
def test_a_name_that_is_neither_a_file_nor_shipped_is_refused_listing_the_names(argv, named, tmp_path, capsys,
                                                                               monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert cli.main(argv) == 2
    captured = capsys.readouterr()
    assert captured.err.startswith(f"dronefleet: error: {named}") and captured.err.count("\n") == 1
    assert ("replenishment" if argv[0] != "sweep" else "replenishment-fig12") in captured.err and captured.out == ""
    assert list(tmp_path.iterdir()) == []


def test_configs_lists_every_shipped_config_and_sweep_file_with_a_description(capsys):
    assert cli.main(["configs"]) == 0
    lines = capsys.readouterr().out.splitlines()
    folder = shipped_config("paper.toml").parent
    for path in [*folder.glob("*.toml"), *folder.glob("sweeps/*.toml")]:
        (line,) = [line for line in lines if line.split()[:1] == [path.stem]]
        assert len(line.split()) > 2, line  # a description after the name
    assert any(line.startswith("configs: ") and str(folder) in line for line in lines)


# ---------------------------------------------------------------- what the commands print


@pytest.mark.parametrize("command", [[], ["run"], ["bounds"], ["configs"], ["sweep", "run"], ["replay"]])
def test_help_shows_no_rest_markup(command, capsys):
    with pytest.raises(SystemExit) as done:
        cli.main([*command, "--help"])
    assert done.value.code == 0
    shown = capsys.readouterr().out
    assert "usage: dronefleet" in shown
    assert "``" not in shown and ":mod:`" not in shown and ":func:`" not in shown


def test_a_cached_run_prints_no_compile_notice(tmp_path, capsys):
    args = ["run", str(shipped_config("replenishment.toml")), "--set", "trials=1", "--set", "ticks=30"]
    assert cli.main([*args, "--out", str(tmp_path / "first")]) == 0  # compiles if no cache has the kernel
    capsys.readouterr()
    assert cli.main([*args, "--out", str(tmp_path / "again")]) == 0
    assert "compil" not in capsys.readouterr().out


def test_one_of_a_thing_is_singular_and_the_backlog_age_says_it_is_a_sum(tmp_path, capsys):
    assert cli.main(["run", "--set", "horizon_weeks=1", "--set", "n_uavs=1",
                     "--out", str(tmp_path / "d")]) == 0
    printed = capsys.readouterr().out
    assert ", 1 UAV, 1 week" in printed.splitlines()[0]
    (backlog,) = [line for line in printed.splitlines() if "backlog age" in line]
    summary = pq.read_table(tmp_path / "d" / "summary.parquet").to_pylist()[0]
    days, pending = summary["backlog_age_s"] / 86400.0, summary["pending"]
    assert pending > 1  # one UAV cannot keep up with a week of orders
    assert backlog.split(None, 3)[:3] == ["backlog", "age", "(summed)"]
    assert f"{days:,.1f} days over {pending} pending order" in backlog
    assert f"{days / pending:.1f} days each on average" in backlog
    assert cli.main(["run", "replenishment", "--set", "n_workers=1", "--set", "n_chargers=1", "--set", "trials=1",
                     "--set", "ticks=30", "--out", str(tmp_path / "r")]) == 0
    printed = capsys.readouterr().out
    assert "1 worker, 1 mobile charger (phi 2)" in printed and "over 1 trial " in printed
