"""Importing code that other packages install: winner-rule plugins and scenarios (entry points).

Shared by :mod:`dronefleet.delivery.auction` and :mod:`dronefleet.scenarios`, so that an
installed package's import misbehaves the same way for both: an import that calls
``sys.exit`` is an ImportError (refused in one line, not the end of the process), Ctrl-C
names the module being imported (an import may hang), and a slow import is said.
"""

import contextlib
import logging
import threading
from collections.abc import Iterator

from .config import _show

logger = logging.getLogger(__name__)

#: After how long a plugin module still importing is said to be [s] (it may hang: Ctrl-C stops it).
IMPORT_NOTICE_S = 10.0


@contextlib.contextmanager
def importing(module_name: str, what: str, notice_s: float = IMPORT_NOTICE_S) -> Iterator[None]:
    """Around the import of module ``module_name`` of a plugin, ``what`` (``"winner rule 'x'"``):
    ``sys.exit`` becomes an ImportError, Ctrl-C a KeyboardInterrupt naming the module, and an
    import still going after ``notice_s`` seconds is logged as a warning."""
    notice = threading.Timer(notice_s, lambda: logger.warning(
        f"dronefleet: still importing module {module_name!r} of {what} after {notice_s:g} s (Ctrl-C stops)"))
    notice.daemon = True
    notice.start()
    try:
        yield
    except SystemExit as e:  # not an Exception: it would end the process, silently
        raise ImportError(f"it calls sys.exit({_show(e.code)})") from None
    except KeyboardInterrupt:
        raise KeyboardInterrupt(f"while importing module {module_name!r} of {what}") from None
    finally:
        notice.cancel()
