"""``python -m dronefleet ...`` and the ``dronefleet`` script: the command line of :mod:`dronefleet.cli`.

The command's modules are imported inside :func:`main`, so that a Ctrl-C while they load (half
a second of numpy, pyarrow and the like) ends like one at any later moment: "interrupted",
exit code 130, no traceback. SIGTERM (a scheduler ending a job at its time limit, ``kill``)
stops the command the same way, and it ends with exit code 143 (128 + 15) instead. Once the
command has ended, both are ignored: the process's exit has nothing left to stop, and the
signal would end the process by its default action, without a word, after its work was done.
The script then ends the process at once (:func:`script`), without the interpreter's teardown.
"""

import signal
import sys
from typing import NoReturn

#: The exit code of a command ended by SIGTERM, as a shell reports a process the signal killed.
TERMINATED = 128 + signal.SIGTERM


def _terminate(signum, frame):
    global _terminated
    _terminated = True
    raise KeyboardInterrupt("by SIGTERM")


_terminated = False


def main() -> int:
    """Run the ``dronefleet`` command with the process's arguments; return its exit code."""
    signal.signal(signal.SIGTERM, _terminate)
    try:
        from .cli import main as command

        code = command()
    except KeyboardInterrupt as interrupted:  # while the command's modules load, or as it returns
        print(f"dronefleet: interrupted{f' {interrupted}' if str(interrupted) else ''}", file=sys.stderr)
        code = 130
    finally:  # a handler that does nothing, not SIG_IGN: Python meets a signal that came just before
        # the change to SIG_IGN with "OSError: Signal ignored due to race condition"
        for signum in (signal.SIGINT, signal.SIGTERM):
            signal.signal(signum, lambda signum, frame: None)
    return TERMINATED if _terminated and code == 130 else code


def script() -> NoReturn:
    """The ``dronefleet`` script and ``python -m dronefleet``: :func:`main`, then the process ends at
    once, without the interpreter's teardown (:func:`dronefleet.console.exit_now`)."""
    from .console import exit_now

    exit_now(main())


if __name__ == "__main__":
    script()
