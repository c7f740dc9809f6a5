"""What made a file: the package version, its git commit and the versions of the libraries
that shape the numbers. Every parquet file dronefleet writes carries it in its schema metadata
(:func:`stamp`), beside the data, so fingerprints of the data do not change with it.

Cheap to import: versions come from the installed distributions' metadata, not by importing
the libraries, so ``dronefleet --version`` stays fast.
"""

from __future__ import annotations

import functools
import json
import os
import platform
import subprocess
from importlib import metadata
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import pyarrow

#: The package's version, the one place it is written (``dronefleet.__version__``, pyproject.toml
#: reads it): here, in the shared infrastructure, so that stamping a file needs nothing above it.
__version__ = "0.1.0"

#: Schema metadata key of :func:`provenance` (JSON); ``dronefleet.version`` holds the version alone.
KEY = b"dronefleet.provenance"
VERSION_KEY = b"dronefleet.version"
#: Distributions whose versions decide the bits of a run or of its files.
LIBRARIES = ("numpy", "numba", "scikit-learn", "pyarrow")
#: Seconds allowed to each git command: a hung or slow git must not hold up a run.
GIT_TIMEOUT_S = 5.0


def _git(source, *args):
    """Output of ``git args`` in ``source``, or None if git is missing, fails or times out."""
    try:
        done = subprocess.run(["git", "-C", str(source), *args], capture_output=True, text=True,
                              stdin=subprocess.DEVNULL, timeout=GIT_TIMEOUT_S,
                              env={**os.environ, "GIT_OPTIONAL_LOCKS": "0"})  # never take the index lock
    except (OSError, subprocess.SubprocessError):
        return None
    return done.stdout.strip() if done.returncode == 0 else None


def commit_of(source: str | os.PathLike) -> str | None:
    """The commit checked out in the git tree whose top is ``source``, ``-dirty`` if tracked files
    differ from it (``-unknown`` if that cannot be told); None if ``source`` is not the top of a
    checkout, or git is missing, fails or hangs."""
    source = Path(source).resolve()
    top = _git(source, "rev-parse", "--show-toplevel")
    if top is None or Path(top).resolve() != source:
        return None
    commit = _git(source, "rev-parse", "HEAD")
    if commit is None:
        return None
    changes = _git(source, "status", "--porcelain", "--untracked-files=no")
    return commit + ("-unknown" if changes is None else "-dirty" if changes else "")


@functools.cache
def git_commit() -> str | None:
    """The commit of the source tree this package runs from (:func:`commit_of` its parent folder):
    an installed wheel has none, even inside some other repository. Looked up once per process."""
    return commit_of(Path(__file__).resolve().parent.parent)


def _version(distribution):
    try:
        return metadata.version(distribution)
    except metadata.PackageNotFoundError:
        return None


@functools.cache
def provenance() -> dict[str, str | None]:
    """``{"dronefleet", "git_commit", "python", "numpy", "numba", "scikit-learn", "pyarrow"}``:
    versions as strings, ``git_commit`` None outside a git checkout. Computed once per process."""
    return {"dronefleet": __version__, "git_commit": git_commit(), "python": platform.python_version(),
            **{name: _version(name) for name in LIBRARIES}}


def version_line() -> str:
    """``dronefleet <version>``, plus `` (commit <sha>)`` when running from a git checkout."""
    commit = git_commit()
    return f"dronefleet {__version__}" + (f" (commit {commit})" if commit else "")


def stamp(table: pyarrow.Table) -> pyarrow.Table:
    """``table`` (pyarrow) with :func:`provenance` added to its schema metadata; its data untouched."""
    return table.replace_schema_metadata({**(table.schema.metadata or {}), VERSION_KEY: __version__,
                                          KEY: json.dumps(provenance(), sort_keys=True)})
