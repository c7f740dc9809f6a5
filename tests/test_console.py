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
