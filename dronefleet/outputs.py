"""Output paths checked before any work: folders that cannot take a run's files are refused in
one line (:class:`OutputError`), and an OSError while writing becomes such a line too.

Shared by ``dronefleet run`` (:mod:`dronefleet.cli`) and the sweeps (:mod:`dronefleet.sweeps`);
standard library only, so the command line stays quick to start.
"""

import errno
import os
import tempfile
from collections.abc import Iterable, Iterator
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
                os.rmdir(tempfile.mkdtemp(prefix=".dronefleet-probe-", dir=folder))
    except OutputError:
        for path in made:
            with suppress(OSError):
                path.rmdir()
        raise
