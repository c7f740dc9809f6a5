"""Output paths checked before any work: folders that cannot take a run's files, and output files
that must not be replaced, are refused in one line (:class:`OutputError`), and an OSError while
writing becomes such a line too.

Shared by ``dronefleet run`` (:mod:`dronefleet.cli`) and the sweeps (:mod:`dronefleet.sweeps`);
standard library only, so the command line stays quick to start.
"""

import errno
import os
import stat
import tempfile
from collections.abc import Callable, Iterable, Iterator
from contextlib import contextmanager, suppress
from pathlib import Path

from .config import ConfigError


class OutputError(ConfigError):
    """An output path that cannot take the run's files, or a write that failed (disk full, ...)."""


@contextmanager
def writing(path: str | os.PathLike) -> Iterator[None]:
    """Turn an OSError while writing ``path`` (disk full, read-only, ...) into a one-line OutputError."""
    try:
        yield
    except OSError as error:
        raise OutputError(f"cannot write {str(path)!r}: {error.strerror or error}") from None


#: Prefix of the folder :func:`probe_folders` makes and removes at once: another process (a task of
#: the same job array) may see it, and must not take it for a user's file.
PROBE_PREFIX = ".dronefleet-probe-"


def probe_folders(folders: Iterable[Path]) -> None:
    """Create ``folders`` (and their parents) if needed and check that files can be made in them;
    if one cannot, remove the folders made here and raise OutputError."""
    made = []
    try:
        for folder in folders:
            with writing(folder):
                if folder.exists() and not folder.is_dir():
                    raise NotADirectoryError(errno.ENOTDIR, "Not a directory")
                made += [path for path in (folder, *folder.parents) if not path.exists()]  # deepest first
                folder.mkdir(parents=True, exist_ok=True)
                os.rmdir(tempfile.mkdtemp(prefix=PROBE_PREFIX, dir=folder))
    except OutputError:
        for path in made:
            with suppress(OSError):
                path.rmdir()
        raise


def check_output_file(path: str | os.PathLike, flag: str, allowed: str,
                      replaceable: Callable[[Path], bool] | None = None, kind: str = "") -> None:
    """Refuse (OutputError), before any work, an output file ``path`` that writing it must not replace.

    Files are written by a rename over ``path`` (:func:`dronefleet.records.write_atomic`), which
    replaces whatever is there: so a folder is refused, and so is a special file (a named pipe,
    a device such as ``/dev/null``, a socket), which would become a regular file. With
    ``replaceable``, an existing regular file is replaced only if ``replaceable(path)`` is true
    (an earlier output of the same command, not one of the user's files); ``kind`` says what
    such a file is. A symbolic link is judged by its target. A path that cannot be looked at
    (its folder is missing or a file) passes: :func:`probe_folders` of its folder names the
    problem. ``flag`` names the option in messages, ``allowed`` what it must be.
    """
    path = Path(path)
    try:
        mode = os.stat(path).st_mode
    except (OSError, ValueError):  # ValueError: a NUL byte in the path
        return
    shown = f"{flag} {str(path)!r}"
    if stat.S_ISDIR(mode):
        raise OutputError(f"{shown} is a folder; {allowed}")
    if not stat.S_ISREG(mode):
        special = ("a named pipe (FIFO)" if stat.S_ISFIFO(mode) else "a socket" if stat.S_ISSOCK(mode)
                   else "a device")
        raise OutputError(f"{shown} is {special}, which writing would replace with a regular file; {allowed}")
    if replaceable is not None and not replaceable(path):
        raise OutputError(f"{shown} exists and is not {kind}, so it is not replaced: remove it, or {allowed}")
