"""What the commands tell their user: log lines through :mod:`logging`, and progress bars.

Every module logs to its own logger under ``dronefleet`` (``dronefleet.<module>``).
The command line (:func:`configure`) prints their lines bare, INFO and DEBUG on stdout,
warnings and errors on stderr; ``-q`` keeps warnings and errors only, ``-v`` adds DEBUG.
Used as a library, dronefleet adds no handler: the caller's logging set-up decides (Python's
default shows warnings only).

Progress bars (tqdm, on stderr) are drawn only when stderr is a terminal and INFO lines are
shown, so pipes, log files, batch jobs and ``-q`` get none.
"""

from __future__ import annotations

import logging
import sys
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from tqdm import tqdm

#: The logger every module's logger descends from.
LOGGER = "dronefleet"


class _Console(logging.StreamHandler):
    """Bare lines: below WARNING on stdout, the rest on stderr, each time on the streams of the
    moment (a caller or test may have replaced ``sys.stdout`` since the handler was added)."""

    def __init__(self) -> None:
        super().__init__(sys.stdout)
        self.setFormatter(logging.Formatter("%(message)s"))

    def emit(self, record: logging.LogRecord) -> None:
        self.stream = sys.stdout if record.levelno < logging.WARNING else sys.stderr
        super().emit(record)  # flushes: lines appear in order with the bars and child processes

    def handleError(self, record: logging.LogRecord) -> None:
        if isinstance(sys.exc_info()[1], BrokenPipeError):  # the reader went away (| head): cli.main
            raise                                            # stops quietly, not with logging's report
        super().handleError(record)


def configure(level: int = logging.INFO) -> None:
    """Print the ``dronefleet`` loggers' lines from ``level`` up (``logging.INFO``, ``WARNING``
    for ``-q``, ``DEBUG`` for ``-v``); called again, it changes the level only."""
    logger = logging.getLogger(LOGGER)
    logger.setLevel(level)
    if not any(isinstance(handler, _Console) for handler in logger.handlers):
        logger.addHandler(_Console())


def progress(total: float, unit: str, desc: str) -> tqdm:
    """A tqdm bar to ``total`` ``unit`` on stderr, disabled (drawing nothing) unless stderr is a
    terminal and the ``dronefleet`` logger shows INFO lines. Close it when done."""
    from tqdm import tqdm  # not for --help and --version: a command that draws no bar does not load it

    shown = sys.stderr.isatty() and logging.getLogger(LOGGER).isEnabledFor(logging.INFO)
    return tqdm(total=total, unit=unit, desc=desc, file=sys.stderr, disable=not shown, leave=False,
                dynamic_ncols=True)
