"""Ctrl-C during a compiled kernel: the kernel stops at its next check point, then KeyboardInterrupt.

Compiled code does not look at signals. Python's SIGINT handler only runs once the kernel
has returned, and if it runs while numba turns the kernel's results into Python objects,
that conversion meets an exception it does not expect: the process dies (SIGSEGV) or
raises SystemError. So :func:`call` runs the kernel in a thread of its own, compiled
``nogil=True``, and the main thread waits, where Ctrl-C raises KeyboardInterrupt as
anywhere in Python. It then sets the kernel's ``stop`` flag (a one-element array the
kernel reads at every check point: once per event or tick, one load), waits for the
kernel to return, and raises the KeyboardInterrupt: the command ends with "interrupted"
(exit 130), and nothing is written, as outputs are written after the kernels.

Where no Ctrl-C can arrive (another thread than the main one, SIGINT ignored or left to
the system's default), the kernel is simply called.
"""

import contextlib
import signal
import threading
from collections.abc import Sequence
from typing import Any

import numpy as np
from numba import types
from numba.core.dispatcher import Dispatcher

#: How long, after Ctrl-C, a kernel may take to reach its next check point [s]. The built-in
#: kernels reach one within microseconds; a plugin's winner rule that never returns does not.
GRACE_S = 3.0
#: How often the waiting main thread wakes up [s]: a lock wait is not interrupted by a signal
#: on every platform.
_WAKE_S = 0.1


def call(kernel: Dispatcher, *args: Any, argtypes: Sequence[types.Type] | None = None,
         culprit: str = "the compiled kernel") -> Any:
    """``kernel(*args, stop)``, stopped at its next check point by Ctrl-C.

    Parameters
    ----------
    kernel : numba dispatcher
        Compiled with ``nogil=True``; its last parameter is ``stop``, an int8 array of shape (1,)
        it reads at its check points and after which (``stop[0] != 0``) it returns at once.
    *args
        The other arguments.
    argtypes : tuple of numba types, optional
        Types to compile ``kernel`` for (default: as numba types ``args``); given, the kernel
        is always called through that specialisation.
    culprit : str
        What may never return, for the message when the kernel does not stop.

    Returns
    -------
    What the kernel returns.

    Raises
    ------
    KeyboardInterrupt
        On Ctrl-C, once the kernel stopped; if it did not stop within GRACE_S, it is left
        running in its (daemon) thread, and the exception's message says so.
    """
    stop = np.zeros(1, np.int8)
    function = kernel
    if argtypes is not None or not kernel.overloads:
        # Compiled (or loaded from numba's cache) here, in the caller's thread, which Ctrl-C
        # interrupts at once; the kernel's thread then only runs machine code.
        types = tuple(kernel.typeof_pyval(a) for a in args) if argtypes is None else tuple(argtypes)
        function = kernel.compile(types + (kernel.typeof_pyval(stop),))
    if threading.current_thread() is not threading.main_thread() or not callable(signal.getsignal(signal.SIGINT)):
        return function(*args, stop)
    outcome = []
    # An Event, not Thread.join: a join that Ctrl-C interrupts can leave the thread marked as
    # ended while it runs on (Python 3.11).
    done = threading.Event()

    def run():
        try:
            outcome.append((function(*args, stop), None))
        except BaseException as error:  # handed to the caller's thread
            outcome.append((None, error))
        finally:
            done.set()

    threading.Thread(target=run, name="dronefleet-kernel", daemon=True).start()
    try:
        while not done.wait(_WAKE_S):
            pass
    except BaseException:  # KeyboardInterrupt, or whatever else a signal handler raised
        stop[0] = 1
        with deaf():
            stopped = done.wait(GRACE_S)
        if not stopped:
            raise KeyboardInterrupt(f"but {culprit} did not stop within {GRACE_S:g} s "
                                    "(a loop that never ends?) and is left running") from None
        raise
    result, error = outcome[0]
    if error is not None:
        raise error
    return result


def ignore(signum: int, frame: Any) -> None:
    """A signal handler that does nothing: unlike SIG_IGN, which Python meets with "OSError: Signal
    ignored due to race condition" if the signal arrived just before the handler changed."""


@contextlib.contextmanager
def deaf():
    """Ctrl-C and SIGTERM ignored within: once stopping, a second signal (the terminal's Ctrl-C and
    a sweep's forwarded one, SLURM's SIGTERM to every process) would strike inside the lock of a
    wait and leave it broken ("release unlocked lock")."""
    previous = {signum: signal.getsignal(signum) for signum in (signal.SIGINT, signal.SIGTERM)}
    previous = {signum: handler for signum, handler in previous.items() if handler is not None}  # None: not Python's
    for signum in previous:
        signal.signal(signum, ignore)
    try:
        yield
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)
