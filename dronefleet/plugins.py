"""Importing code that other packages install: winner-rule plugins and scenarios (entry points).

Shared by :mod:`dronefleet.delivery.auction` and :mod:`dronefleet.scenarios`, so that an
installed package's import misbehaves the same way for both: an import that calls
``sys.exit`` is an ImportError (refused in one line, not the end of the process), Ctrl-C
names the module being imported (an import may hang), and a slow import is said. Before a
plugin module is imported here, its import is tried once in a child process: one that does
not end within :data:`IMPORT_LIMIT_S`, or that ends the process (``os._exit``, a signal), is
an ImportError too, never a hang or a silent end of dronefleet.
"""

import contextlib
import functools
import logging
import os
import secrets
import signal
import subprocess
import sys
import tempfile
import threading
from collections.abc import Iterator

from .config import _show
from .console import PLUGIN_THREADS

logger = logging.getLogger(__name__)

#: After how long a plugin module still importing is said to be [s] (it may hang: Ctrl-C stops it).
IMPORT_NOTICE_S = 10.0
#: How long a plugin module's import may take in the child process that tries it first [s]
#: (docs/guide/limits.md); read at each check: tests shorten it.
IMPORT_LIMIT_S = 30.0

#: The child's program: import the module, then write the token, which only an import that ended
#: (returned or raised: its error is reported where it is imported for use) lets it write.
_TRY_IMPORT = """\
import importlib, os, sys
token, module_name, sys.path[:] = sys.argv[1], sys.argv[2], sys.argv[3:]
try:
    importlib.import_module(module_name)
except (Exception, SystemExit):
    pass
os.write(1, token.encode())
os._exit(0)
"""


@functools.cache  # once per module, path and process: a hanging import costs its limit once, not per list
def _import_problem(module_name: str, path: tuple[str, ...], limit_s: float) -> str | None:
    """Why importing ``module_name`` (with ``sys.path`` ``path``) would hang or end this process, or None."""
    token = secrets.token_hex(16)
    with tempfile.TemporaryFile() as out:  # not a pipe: a process the import starts may hold it open
        # a session of its own: Ctrl-C reaches this process only, which ends the child and what it started
        child = subprocess.Popen([sys.executable, "-c", _TRY_IMPORT, token, module_name, *path],
                                 stdin=subprocess.DEVNULL, stdout=out, stderr=subprocess.DEVNULL,
                                 start_new_session=True)
        try:
            child.wait(limit_s)
        except subprocess.TimeoutExpired:
            return f"its import does not end within {limit_s:g} s (docs/guide/limits.md)"
        finally:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(child.pid, signal.SIGKILL)
            child.wait()
        out.seek(0)
        if token.encode() in out.read():
            return None
    if child.returncode < 0:
        return f"its import kills the process ({signal.Signals(-child.returncode).name})"
    return f"its import ends the process (exit status {child.returncode})"


@contextlib.contextmanager
def importing(module_name: str, what: str, notice_s: float = IMPORT_NOTICE_S) -> Iterator[None]:
    """Around the import of module ``module_name`` of a plugin, ``what`` (``"winner rule 'x'"``):
    an import that hangs or ends the process when tried in a child process first (not if the
    module is imported already), and ``sys.exit``, become an ImportError, Ctrl-C a
    KeyboardInterrupt naming the module, and an import still going after ``notice_s`` seconds
    is logged as a warning."""
    notice = threading.Timer(notice_s, lambda: logger.warning(
        f"dronefleet: still importing module {module_name!r} of {what} after {notice_s:g} s (Ctrl-C stops)"))
    notice.daemon = True
    notice.start()
    working_directory = os.getcwd()  # relative paths of the command (--out, a config) mean what they meant
    threads = set(threading.enumerate())
    try:
        problem = None if module_name in sys.modules else _import_problem(module_name, tuple(sys.path),
                                                                          IMPORT_LIMIT_S)
        if problem is not None:
            raise ImportError(problem)
        yield
    except SystemExit as e:  # not an Exception: it would end the process, silently
        raise ImportError(f"it calls sys.exit({_show(e.code)})") from None
    except KeyboardInterrupt:
        raise KeyboardInterrupt(f"while importing module {module_name!r} of {what}") from None
    finally:
        notice.cancel()
        PLUGIN_THREADS.update(thread for thread in threading.enumerate() if thread not in threads and not thread.daemon)
        if os.getcwd() != working_directory:
            logger.warning(f"dronefleet: warning: module {module_name!r} of {what} changed the working directory "
                           f"on import; changed back to {working_directory!r}")
            os.chdir(working_directory)
