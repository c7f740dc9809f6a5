"""``python -m dronefleet ...`` and the ``dronefleet`` script: the command line of :mod:`dronefleet.cli`.

The command's modules are imported inside :func:`main`, so that a Ctrl-C while they load (half
a second of numpy, pyarrow and the like) ends like one at any later moment: "interrupted",
exit code 130, no traceback.
"""

import sys


def main() -> int:
    """Run the ``dronefleet`` command with the process's arguments; return its exit code."""
    try:
        from .cli import main as command
    except KeyboardInterrupt:
        print("dronefleet: interrupted", file=sys.stderr)
        return 130
    return command()


if __name__ == "__main__":
    sys.exit(main())
