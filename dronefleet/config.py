"""Config machinery shared by every scenario: errors, TOML files, ``--set`` strings, messages.

Each scenario declares and validates its own schema (:mod:`dronefleet.delivery.config`,
:mod:`dronefleet.replenishment.scenario`); what they have in common is here, so that every
config and sweep file is read the same way and every refusal reads alike:

* :class:`ConfigError`, the one exception for bad input (a one-line message; exit code 2);
* :func:`read_toml`, the one reader of TOML files (regular UTF-8 files of at most
  :data:`MAX_CONFIG_BYTES`, so a pipe or a huge file is refused, not waited on or read);
* :data:`SCENARIO_KEY`, the top-level key that names a config's scenario;
* :func:`shipped_config`, the path of a config or sweep file shipped with the package;
* ``_parse_override`` (``--set key=value``), ``_show``, ``_name`` and ``_suggest`` (values,
  names and "did you mean" in messages).
"""

from __future__ import annotations

import difflib
import importlib.resources
import os
import stat
import tomllib
from os import PathLike
from pathlib import Path
from typing import Any
from collections.abc import Callable, Iterable

__all__ = ["ConfigError", "MAX_CONFIG_BYTES", "SCENARIO_KEY", "read_toml", "shipped_config"]

#: Largest config file read [bytes]; real ones are a few KB.
MAX_CONFIG_BYTES = 1_000_000
#: Top-level key naming a config file's scenario (:mod:`dronefleet.scenarios`); absent = delivery.
SCENARIO_KEY = "scenario"


class ConfigError(ValueError):
    """A configuration problem, with a message a user can act on.

    ``keys`` holds the parameter names involved (possibly empty).
    """

    def __init__(self, message: str, keys: Iterable[str] = ()) -> None:
        super().__init__(message)
        self.keys = tuple(keys)


def _show(value: Any) -> str:
    """repr of a value, cut to 60 characters: a message never prints a whole big value."""
    try:
        text = repr(value)
    except ValueError:  # an int too long to print (sys.get_int_max_str_digits)
        return f"an integer of {value.bit_length()} bits"
    return text if len(text) <= 60 else text[:57] + "..."


def _name(name: str) -> str:
    """A key or section name for a message: as written if printable and short, else its cut repr."""
    return name if name.isprintable() and len(name) <= 60 else _show(name)


def _suggest(word: str, candidates: Iterable[str]) -> str:
    """' (did you mean 'x'?)' for the closest candidate, or ''.

    A unique candidate that is ``word`` plus a suffix (a key written without
    its unit, ``speed`` for ``speed_m_s``) wins; otherwise difflib's closest.
    """
    candidates = list(candidates)
    prefixed = [c for c in candidates if c.startswith(word + "_")]
    close = prefixed if len(prefixed) == 1 else difflib.get_close_matches(word, candidates, n=1)
    return f" (did you mean {close[0]!r}?)" if close else ""


def _parse_override(text: Any, resolve: Callable[[str], str]) -> tuple[str, Any]:
    """'key=value' (a ``--set``) -> (parameter name by the scenario's ``resolve``, value); value read
    as TOML, else a bare string (``rule=random``)."""
    if not isinstance(text, str) or "=" not in text:
        raise ConfigError(f"--set needs key=value, got {_show(text)}")
    key, _, raw = text.partition("=")
    key, raw = key.strip(), raw.strip()
    if not key:
        raise ConfigError(f"--set needs key=value, got {_show(text)}")
    name = resolve(key)
    try:
        doc = tomllib.loads(f"v = {raw}")
        value = doc["v"] if list(doc) == ["v"] else raw
    except (ValueError, RecursionError):  # not a TOML value (TOMLDecodeError, huge int): a bare string
        value = raw
    return name, value


def read_toml(path: str | PathLike, kind: str = "config file") -> tuple[str, dict[str, Any]]:
    """The text and TOML document of the ``kind`` (config or sweep file) in ``path``.

    ConfigError, naming the file, if it is not a regular file (a pipe would block), cannot be
    read, is larger than :data:`MAX_CONFIG_BYTES`, is not UTF-8 or is not TOML.
    """
    where = f"{kind} {str(path)!r}"
    try:
        # Only a regular file: opening a pipe would wait for a writer for ever.
        if not stat.S_ISREG(os.stat(path).st_mode):
            raise ConfigError(f"{where} is not a regular file (a folder, pipe or device); give a TOML file")
        with open(path, "rb") as fh:
            data = fh.read(MAX_CONFIG_BYTES + 1)  # read no further: the file may have grown
    except OSError as e:
        raise ConfigError(f"cannot read {where}: {e.strerror or e}{_shipped_hint(path, e)}") from None
    if len(data) > MAX_CONFIG_BYTES:
        raise ConfigError(f"{where} is larger than {MAX_CONFIG_BYTES} bytes; a {kind} is a few KB of TOML")
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as e:
        raise ConfigError(f"{where} is not UTF-8 text (byte {data[e.start]:#04x} at offset {e.start}); "
                          "save it as UTF-8") from None
    try:
        return text, tomllib.loads(text)
    except ValueError as e:  # TOMLDecodeError, or an integer of too many digits
        raise ConfigError(f"cannot parse {where}: {e}") from None
    except RecursionError:
        raise ConfigError(f"cannot parse {where}: values nested too deeply") from None


def _shipped_hint(path: str | PathLike, error: OSError) -> str:
    """For a missing ``configs/...`` path (the README's, typed away from the repository): where
    the file of that name shipped with the package is, if there is one; else ''."""
    parts = Path(path).parts
    if not isinstance(error, FileNotFoundError) or len(parts) < 2 or parts[0] != "configs":
        return ""
    try:
        return f" (the one shipped with dronefleet is {shipped_config(*parts[1:])})"
    except ConfigError:
        return ""


def shipped_config(*parts: str) -> Path:
    """The path of a file shipped in the repository's ``configs/``, e.g. ``shipped_config("sweeps",
    "rules.toml")``, whatever the working directory.

    An installed dronefleet (wheel, ``pip install .`` or ``-e .``) has them as the package
    ``dronefleet.configs``; a source tree put on ``sys.path`` without installing has them beside
    the package. ConfigError if the file is not there.
    """
    try:
        # Path(): installed packages are folders on disk (numba's cache needs one), never zip files
        root = Path(importlib.resources.files("dronefleet.configs"))
    except ModuleNotFoundError:  # not installed (or installed before configs were packaged)
        root = Path(__file__).resolve().parent.parent / "configs"
    path = root.joinpath(*parts)
    if not path.is_file():
        raise ConfigError(f"the shipped config {'/'.join(parts)} is missing (looked for {path}): "
                          "reinstall dronefleet")
    return path
