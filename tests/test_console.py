"""dronefleet.console: log lines by level on the streams of the moment, progress bars on a terminal only."""

import io
import logging
import sys

import pytest

from dronefleet import console, scenarios
from dronefleet.replenishment import experiments


class Terminal(io.StringIO):
    def isatty(self):
        return True


@pytest.fixture(autouse=True)
def logger():
    """The ``dronefleet`` logger, its level put back after the test."""
    logger = logging.getLogger(console.LOGGER)
    level = logger.level
    yield logger
    logger.setLevel(level)


def test_lines_by_level_on_stdout_and_stderr_through_one_handler(logger, capsys):
    console.configure(logging.INFO)
    console.configure(logging.INFO)  # again (cli.main runs once per call): still one handler
    module = logging.getLogger("dronefleet.somewhere")
    module.debug("hidden")
    module.info("a line")
    module.warning("a warning")
    assert capsys.readouterr() == ("a line\n", "a warning\n")
    console.configure(logging.DEBUG)
    module.debug("shown")
    console.configure(logging.WARNING)
    module.info("hidden too")
    assert capsys.readouterr() == ("shown\n", "")
    assert sum(isinstance(handler, console._Console) for handler in logger.handlers) == 1


def test_replenishment_configurations_count_on_a_bar_on_a_terminal_only(monkeypatch):
    scenario = scenarios.SCENARIOS["replenishment"]
    configs = [scenario.load(None, ["trials=1", "ticks=30", *changes])
               for changes in (["strategy=fixed", "n_chargers=0"], ["strategy=mobile"])]
    drawn = {}
    for name, stream, level in (("terminal", Terminal(), logging.INFO), ("pipe", io.StringIO(), logging.INFO),
                                ("quiet", Terminal(), logging.WARNING)):
        monkeypatch.setattr(sys, "stderr", stream)
        console.configure(level)
        assert len(experiments.run_configs(configs)) == 2
        drawn[name] = stream.getvalue()
    assert "  configurations:" in drawn["terminal"] and "/2 " in drawn["terminal"]
    assert drawn["pipe"] == drawn["quiet"] == ""


def test_progress_off_a_terminal_is_a_log_line_every_interval(monkeypatch, capsys):
    # nohup, a pipe, a CI log: stderr is no terminal, and long work was silent
    now = [0.0]
    monkeypatch.setattr(console, "_clock", lambda: now[0])  # no waiting: the clock moves 1 s per run
    monkeypatch.setattr(sys, "stderr", io.StringIO())
    console.configure(logging.INFO)
    with console.progress(360, "run", "  runs") as bar:
        for _ in range(12):
            now[0] += console.PROGRESS_INTERVAL / 5
            bar.set_postfix_str("0 failed", refresh=False)
            bar.update(1)
    seconds = console.PROGRESS_INTERVAL
    assert capsys.readouterr().out.splitlines() == [f"  runs: 5 of 360 runs (1 %), 0 failed, {seconds:.0f} s",
                                                    f"  runs: 10 of 360 runs (3 %), 0 failed, {2 * seconds:.0f} s"]
    assert sys.stderr.getvalue() == ""  # no bar drawn into a log
    console.configure(logging.WARNING)  # -q: no lines either
    with console.progress(1, "week", "  simulated") as bar:
        now[0] += 10 * seconds
        bar.update(0.5)
    assert capsys.readouterr().out == ""


def test_the_compile_notice_is_printed_only_when_numba_compiles(capsys):
    from numba import njit

    console.configure(logging.INFO)

    @njit
    def twice(x):
        return 2 * x

    for times in (1, 0):  # compiled, then the compiled function called again
        with console.compile_notice("a test function"):
            assert twice(2) == 4
        assert capsys.readouterr().out.count("compiling a test function") == times


def test_counted_nouns_are_singular_for_one():
    assert [console.counted(n, "week") for n in (1, 1.0, 0.5, 8)] == ["1 week", "1 week", "0.5 weeks", "8 weeks"]
    assert console.counted(1, "mobile charger") == "1 mobile charger"
    assert console.counted(2, "process", "processes") == "2 processes"


def test_in_a_notebook_progress_is_tqdm_auto_s_bar_even_without_logging_set_up(monkeypatch, logger):
    from tqdm.auto import tqdm as auto

    monkeypatch.setattr(console, "_in_notebook", lambda: True)
    logger.setLevel(logging.NOTSET)  # dronefleet used as a library: no level set
    with console.progress(3, "run", "  runs") as bar:
        assert isinstance(bar, auto) and not bar.disable
    logger.setLevel(logging.WARNING)  # quiet asked for
    with console.progress(3, "run", "  runs") as bar:
        assert bar.disable
