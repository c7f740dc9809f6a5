"""What the commands tell their user: log lines through :mod:`logging`, and progress bars.

Every module logs to its own logger under ``dronefleet`` (``dronefleet.<module>``).
The command line (:func:`configure`) prints their lines bare, INFO and DEBUG on stdout,
warnings and errors on stderr; ``-q`` keeps warnings and errors only, ``-v`` adds DEBUG.
Used as a library, dronefleet adds no handler: the caller's logging set-up decides (Python's
default shows warnings only).

Progress (:func:`progress`) is a tqdm bar on stderr when stderr is a terminal, a notebook's
bar (tqdm.auto) in Jupyter, and otherwise (nohup, a pipe, a CI log, a batch job) a log line
every :data:`PROGRESS_INTERVAL` seconds of long work; all of them only while INFO lines are
shown (``-q`` gets none). :func:`compile_notice` says when numba compiles, and only then.
"""

from __future__ import annotations

import atexit
import contextlib
import logging
import os
import sys
import threading
import time
import weakref
from collections.abc import Iterator
from typing import Any, NoReturn

#: The logger every module's logger descends from.
LOGGER = "dronefleet"
#: Seconds between two progress lines off a terminal (the first one after as long).
PROGRESS_INTERVAL = 5.0
_clock = time.monotonic  # a test's fake clock replaces it: no test waits for the interval


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


def counted(n: float, noun: str, plural: str | None = None) -> str:
    """``n`` and the noun, singular for exactly 1: "1 week", "8 weeks", "0.5 weeks", "1 mobile
    charger"; ``plural`` where adding "s" is wrong ("process", "processes")."""
    return f"{n:g} {noun if n == 1 else plural or noun + 's'}"


def _in_notebook() -> bool:
    """Whether this is a Jupyter kernel (whose output cell draws tqdm.auto's widget bar)."""
    shell = sys.modules.get("IPython")
    ipython = getattr(shell, "get_ipython", lambda: None)() if shell else None
    return type(ipython).__name__ == "ZMQInteractiveShell"


def progress(total: float, unit: str, desc: str) -> Any:
    """Progress to ``total`` ``unit``: a tqdm bar on a terminal's stderr, tqdm.auto's bar in a
    notebook, else (stderr not a terminal) :class:`ProgressLines`; each with tqdm's ``update``,
    ``n``, ``set_postfix_str`` and ``close``, and a context manager. Nothing is shown unless the
    ``dronefleet`` logger shows INFO lines (in a notebook: unless its level is set above INFO).
    """
    logger = logging.getLogger(LOGGER)
    if _in_notebook():
        from tqdm.auto import tqdm as auto

        return auto(total=total, unit=unit, desc=desc.strip(), disable=logger.level > logging.INFO, leave=False)
    shown = logger.isEnabledFor(logging.INFO)
    if not sys.stderr.isatty():
        return ProgressLines(total, unit, desc, shown)
    return _LateBar(total, unit, desc, shown)


class _LateBar:
    """A terminal's tqdm bar, drawn from the first progress on: while numba compiles (before any),
    the compile notice stands alone instead of under a bar stuck at 0 %, and the bar, drawn after
    it, is cleared from the screen when closed (``leave=False``). tqdm's interface as
    :class:`ProgressLines` has it."""

    def __init__(self, total: float, unit: str, desc: str, shown: bool) -> None:
        self.total, self.unit, self.desc, self.shown = total, unit, desc, shown
        self.bar: Any = None
        self.postfix = ""

    @property
    def n(self) -> float:
        return 0 if self.bar is None else self.bar.n

    def update(self, n: float = 1) -> None:
        if self.bar is None:
            if not n:
                return
            from tqdm import tqdm  # not for --help and --version: a command that draws no bar does not load it

            self.bar = tqdm(total=self.total, unit=self.unit, desc=self.desc, file=sys.stderr, disable=not self.shown,
                            leave=False, dynamic_ncols=True, initial=n, postfix=self.postfix or None)
            return
        self.bar.update(n)

    def set_postfix_str(self, text: str, refresh: bool = True) -> None:
        self.postfix = text
        if self.bar is not None:
            self.bar.set_postfix_str(text, refresh=refresh)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()

    def __enter__(self) -> _LateBar:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class ProgressLines:
    """Progress off a terminal: an INFO line ("  runs: 12 of 360 runs (3 %), 0 failed, 41 s") at
    an update at least :data:`PROGRESS_INTERVAL` seconds after the start or the last line, so
    short work prints none and long work is never silent for long. The subset of tqdm's
    interface the commands use."""

    def __init__(self, total: float, unit: str, desc: str, shown: bool = True) -> None:
        self.total, self.unit, self.desc, self.shown = total, unit, desc, shown
        self.n: float = 0
        self.postfix = ""
        self.start = self.last = _clock()

    def update(self, n: float = 1) -> None:
        self.n += n
        now = _clock()
        if self.shown and now - self.last >= PROGRESS_INTERVAL:
            self.last = now
            done = f" ({100.0 * self.n / self.total:.0f} %)" if self.total else ""
            count = f"{self.n:.1f}" if self.n != int(self.n) else f"{self.n:g}"
            logging.getLogger(f"{LOGGER}.progress").info(
                f"{self.desc}: {count} of {counted(self.total, self.unit)}{done}"
                f"{', ' + self.postfix if self.postfix else ''}, {now - self.start:.0f} s")

    def set_postfix_str(self, text: str, refresh: bool = True) -> None:
        self.postfix = text

    def close(self) -> None:
        pass

    def __enter__(self) -> ProgressLines:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


@contextlib.contextmanager
def compile_notice(what: str) -> Iterator[None]:
    """Within the block, one INFO line when numba starts compiling ``what`` (a kernel it does not
    find in its disk cache: the first run of a version on a machine, a new warm start or rule
    plugin), printed as compilation starts; nothing when everything loads from the cache."""
    from numba.core import event

    logger = logging.getLogger(f"{LOGGER}.console")

    class Notice(event.Listener):
        told = False

        def on_start(self, ev: event.Event) -> None:
            if not self.told:  # the kernel's callees compile inside it: one line
                self.told = True
                logger.info(f"  compiling {what} (once per version and machine; numba caches it)")

        def on_end(self, ev: event.Event) -> None:
            pass

    with event.install_listener("numba:compile", Notice()):
        yield


#: Threads (not daemons) that a plugin's import started (:func:`dronefleet.plugins.importing`): a
#: finished command does not wait for them.
PLUGIN_THREADS: weakref.WeakSet = weakref.WeakSet()


def exit_now(code: int) -> NoReturn:
    """End the process of a finished command with exit code ``code``, skipping the interpreter's
    teardown.

    Tearing down, Python frees every module's objects one by one, numba's compiled code and
    LLVM state among them: 0.2 s of CPU after a run, a fifth of a whole ``dronefleet run``, for
    memory the system takes back at once anyway. What an exit does that has effects is kept:
    the atexit handlers (logging's last flush, temporary folders' removal) run, and stdout and
    stderr are flushed. With a thread other than daemons still running, or output that cannot be
    flushed (a reader gone), the usual exit happens instead, with its usual behaviour; a thread a
    plugin's import started (:data:`PLUGIN_THREADS`) is not waited for: it would hold the
    finished command for good.
    """
    if any(thread is not threading.main_thread() and not thread.daemon and thread not in PLUGIN_THREADS
           for thread in threading.enumerate()):
        sys.exit(code)
    try:
        atexit._run_exitfuncs()  # what the usual exit runs (logging.shutdown, weakref finalizers)
        for stream in (sys.stdout, sys.stderr):
            if stream is not None:
                stream.flush()
    except BaseException:  # a handler that fails, a closed pipe: as the usual exit reports it
        sys.exit(code)
    os._exit(code)
