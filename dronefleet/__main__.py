"""``python -m dronefleet ...`` and the ``dronefleet`` script: the command line of :mod:`dronefleet.cli`.

The command's modules are imported inside :func:`main`, so that a Ctrl-C while they load (half
a second of numpy, pyarrow and the like) ends like one at any later moment: "interrupted",
exit code 130, no traceback. Once the command has ended, Ctrl-C is ignored: the interpreter's
exit (up to half a second of tearing down numba and pyarrow) has nothing left to stop, and a
Ctrl-C there would end the process by the signal, without a word, after its work was done.
"""

import signal
import sys


def main() -> int:
    """Run the ``dronefleet`` command with the process's arguments; return its exit code."""
    try:
        from .cli import main as command

        return command()
    except KeyboardInterrupt:  # while the command's modules load, or as it returns
        print("dronefleet: interrupted", file=sys.stderr)
        return 130
    finally:
        signal.signal(signal.SIGINT, signal.SIG_IGN)


if __name__ == "__main__":
    sys.exit(main())
