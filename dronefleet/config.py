"""Config machinery shared by every scenario: errors, TOML files, ``--set`` strings, messages.

Each scenario declares and validates its own schema (:mod:`dronefleet.delivery.config`,
:mod:`dronefleet.replenishment.scenario`); what they have in common is here, so that every
config and sweep file is read the same way and every refusal reads alike:

* :class:`ConfigError`, the one exception for bad input (a one-line message; exit code 2);
* :func:`read_toml`, the one reader of TOML files (regular UTF-8 files of at most
  :data:`MAX_CONFIG_BYTES`, so a pipe or a huge file is refused, not waited on or read,
  nested at most :data:`MAX_DEPTH` deep);
* :func:`check_depth`, the refusal of a value nested deeper than :data:`MAX_DEPTH` (``--set``,
  the Python API), so that no check or message recurses through thousands of levels;
* :data:`SCENARIO_KEY`, the top-level key that names a config's scenario;
* :func:`shipped_config`, the path of a config or sweep file shipped with the package;
  :func:`named_file`, a command's config or sweep argument, a path or a shipped file's name;
  :func:`shipped_files`, their names and one-line descriptions;
* ``_parse_override`` (``--set key=value``), ``_show``, ``_name`` and ``_suggest`` (values,
  names and "did you mean" in messages; ``_show`` shows a few items a few levels deep).
"""

from __future__ import annotations

import difflib
import importlib.resources
import os
import re
import reprlib
import stat
import tempfile
import tomllib
from os import PathLike
from pathlib import Path
from typing import Any
from collections.abc import Callable, Iterable, Mapping

__all__ = ["ConfigError", "SweepError", "MAX_CONFIG_BYTES", "MAX_DEPTH", "SCENARIO_KEY", "check_depth", "read_toml",
           "shipped_config", "shipped_files", "named_file", "too_deep"]

#: Largest config file read [bytes]; real ones are a few KB.
MAX_CONFIG_BYTES = 1_000_000
#: Top-level key naming a config file's scenario (:mod:`dronefleet.scenarios`); absent = delivery.
SCENARIO_KEY = "scenario"


class ConfigError(ValueError):
    """A configuration problem, with a message a user can act on.

    ``keys`` holds the parameter names involved (possibly empty).
    """

    def __init__(self, message: str, keys: Iterable[str] = ()) -> None:
        super().__init__(one_line(message))  # a message quoting a file or a plugin's error stays one line
        self.keys = tuple(keys)


class SweepError(ConfigError):
    """A sweep file, task or results directory that cannot be used; the message says why.

    Here, beside ConfigError, rather than in :mod:`dronefleet.sweeps`: the executors and the
    scenarios' studies raise it too, and they sit below the sweeps (docs/scenario-contract.md).
    """


def one_line(text: str) -> str:
    """``text`` on one line: each line break, with the white space around it, one space; any other
    character that a terminal would act on (tab, escape sequences) written as its Python escape.
    Spaces are kept as they are: a message may quote a value."""
    text = _LINE_BREAK.sub(" ", str(text).strip())
    return text if text.isprintable() else "".join(c if c.isprintable() else repr(c)[1:-1] for c in text)


#: A line break (any of those str.splitlines breaks at) and the white space around it.
_LINE_BREAK = re.compile(r"[ \t]*[\n\r\v\f\x1c\x1d\x1e\x85\u2028\u2029]+\s*")


def brief(error: BaseException) -> str:
    """A dependency's or a plugin's error, to quote in a message: on one line, cut to 200 characters
    (its type's name if it says nothing)."""
    text = one_line(str(error))
    return (text if len(text) <= 200 else text[:197] + "...") or type(error).__name__


#: Deepest nesting of tables and lists in a config or sweep file, or in a value given by ``--set`` or
#: the Python API: a sweep's ``[[grid]]`` tables of sections of lists of values are 5 deep; TOML's
#: dotted keys (``trials.a.a.a...``) and Python lists can nest thousands deep, past what any
#: recursive check or message (``repr``, ``==``, JSON) can take.
MAX_DEPTH = 8


class _Shown(reprlib.Repr):
    """repr for messages: a few items of each container, a few levels deep, so that showing a
    value nested thousands deep, holding itself or of millions of items costs its first characters."""

    def __init__(self) -> None:
        super().__init__()
        self.maxlevel = 4
        self.maxlist = self.maxtuple = self.maxset = self.maxfrozenset = self.maxdeque = self.maxdict = 12
        self.maxstring = self.maxother = self.maxlong = 60

    def repr_int(self, x: int, level: int) -> str:
        try:
            return super().repr_int(x, level)
        except ValueError:  # an int too long to print (sys.get_int_max_str_digits)
            return f"an integer of {x.bit_length()} bits"

    def repr_instance(self, x: Any, level: int) -> str:
        try:
            return super().repr_instance(x, level)
        except RecursionError:  # an object whose own repr recurses without end
            return f"<{type(x).__name__}>"


_SHOWN = _Shown()


def _show(value: Any, limit: int = 60) -> str:
    """repr of a value, cut to ``limit`` characters: a message never prints a whole big value."""
    text = _SHOWN.repr(value)
    return text if len(text) <= limit else text[:limit - 3] + "..."


_SCALARS = frozenset((int, float, str, bool, type(None)))


def too_deep(value: Any, limit: int = MAX_DEPTH) -> str | None:
    """The path (``a.b[3].c``) of the first table or list in ``value`` nested more than ``limit``
    deep (``value`` itself, if a table or list, is 1 deep), or None. Without recursion; stops at
    the first such one, so a value holding itself is answered too."""
    todo = [(value, 0, None)]   # (item, its depth, (its parent's entry, its key or index))
    while todo:
        entry = todo.pop()
        item, depth, _ = entry
        if type(item) in _SCALARS:  # most of a big value: spared the slower Mapping check
            continue
        if isinstance(item, Mapping):
            children = item.items()
        elif isinstance(item, (list, tuple, set, frozenset)):
            children = enumerate(item)
        else:
            continue
        if depth + 1 > limit:
            return _path(entry)
        todo.extend([(child, depth + 1, (entry, key)) for key, child in children][::-1])
    return None


def _path(entry: tuple) -> str:
    """``a.b[3]`` of a :func:`too_deep` entry, from its parents' keys (an index of a list in brackets)."""
    parts = []
    while entry[2] is not None:
        entry, key = entry[2]
        parts.append(f".{_key_text(key)}" if isinstance(entry[0], Mapping) else f"[{key}]")
    return "".join(reversed(parts)).removeprefix(".")


def _key_text(key: Any) -> str:
    return key if isinstance(key, str) and len(key) <= 60 else _show(key)


def check_depth(value: Any, where: str, what: str = "") -> None:
    """ConfigError, naming ``where`` and the key, if ``value`` nests tables and lists deeper than
    :data:`MAX_DEPTH` (``what`` names ``value`` itself in the message, e.g. ``"--set trials"``)."""
    path = too_deep(value)
    if path is not None:
        key = (what + ("." if what and path and not path.startswith("[") else "") + path) or "the value"
        raise ConfigError(f"{where}{_name(key)} nests tables and lists more than {MAX_DEPTH} deep; "
                          "a config value is a number, a string or a list of numbers")


def _name(name: str) -> str:
    """A key or section name for a message: as written if printable and short, else its cut repr."""
    return name if name.isprintable() and len(name) <= 60 else _show(name)


def seed_refusal(word: str, scenario: str, why: str = "") -> ConfigError:
    """The refusal of a seed given as ``word`` (``--seed``, ``seed=3``, ``[sweep] seeds``) to a scenario
    without a root seed (its ``SEED_KEY`` is None): "seed" means the root seed everywhere, never a
    replicate's index; ``why`` says what chooses its replicates instead."""
    return ConfigError(f"{word} does not apply to a {scenario} run, which has no root seed{': ' if why else ''}{why}")


def _suggest(word: str, candidates: Iterable[str]) -> str:
    """' (did you mean 'x'?)' for the closest candidate, or ''.

    A unique candidate that differs from ``word`` in case alone (``gr`` for ``GR``) wins, then
    one that is ``word`` plus a suffix (a key written without its unit, ``speed`` for
    ``speed_m_s``); otherwise difflib's closest.
    """
    candidates = list(candidates)
    cased = [c for c in candidates if c.lower() == word.lower()]
    prefixed = [c for c in candidates if c.startswith(word + "_")]
    close = next((found for found in (cased, prefixed) if len(found) == 1), None) or \
        difflib.get_close_matches(word, candidates, n=1)
    return f" (did you mean {close[0]!r}?)" if close else ""


class Sections:
    """The TOML sections of a scenario whose keys are unique across sections (``[run] trials``,
    read back flat as ``trials``): key resolution, the flattening of a config file, and the
    reading of defaults < file < ``--set``, shared by the replenishment and items configs.

    ``name`` is the scenario's (a file's ``scenario = ...`` must name it); ``schema`` maps each
    key to its :class:`dronefleet.contract.Field` (its ``section``)."""

    def __init__(self, name: str, schema: Mapping[str, Any]) -> None:
        self.name, self.schema = name, schema
        self.keys: dict[str, tuple[str, ...]] = {}  # section -> its keys, in schema order
        for key, field in schema.items():
            self.keys[field.section] = self.keys.get(field.section, ()) + (key,)

    def unknown_key(self, key: str, where: str = "") -> ConfigError:
        schema = self.schema
        return ConfigError(f"{where}unknown key {_show(key)}{_suggest(key.rpartition('.')[2], schema)}. "
                           f"Allowed keys: {', '.join(f'{schema[k].section}.{k}' for k in schema)}")

    def resolve_key(self, key: str) -> str:
        """'section.key' or a bare key -> the key name."""
        section, dot, name = key.rpartition(".")
        if name not in self.schema or (dot and section != self.schema[name].section):
            raise self.unknown_key(key)
        return name

    def flatten(self, document: Any, where: str | None = None, origin: dict | None = None) -> dict:
        """``{scenario, section: {key: value}}`` -> flat ``{key: value}``, checking names; with
        ``origin``, each key's source ``where`` is recorded there."""
        pre = f"{where}: " if where else ""
        if not isinstance(document, dict):
            raise ConfigError(f"{pre}expected a table of sections, got {type(document).__name__}")
        flat = {}
        for section, table in document.items():
            if section == SCENARIO_KEY:
                if table != self.name:
                    raise ConfigError(f"{pre}scenario = {_show(table)}, expected {self.name!r}")
                continue
            if section in self.schema:
                raise ConfigError(f"{pre}key {section!r} is at the top level; put it in section "
                                  f"[{self.schema[section].section}]", [section])
            if section not in self.keys:
                raise ConfigError(f"{pre}unknown section [{_name(section)}]{_suggest(section, self.keys)}. "
                                  f"Allowed sections: {', '.join(self.keys)}")
            if not isinstance(table, dict):
                raise ConfigError(f"{pre}[{section}] must be a table of key = value, got {_show(table)}")
            for key, value in table.items():
                if key not in self.keys[section]:
                    if key in self.schema:
                        raise ConfigError(f"{pre}{section}.{key} belongs in [{self.schema[key].section}]", [key])
                    raise self.unknown_key(f"{section}.{key}", pre)
                flat[key] = value
                if origin is not None and where:
                    origin[key] = where
        return flat

    def read(self, defaults: Mapping[str, Any], path: str | os.PathLike | None,
             overrides: Iterable[str], seed: int | None = None) -> tuple[dict[str, Any], dict[str, str]]:
        """``(values, origin)``: ``defaults`` < the file at ``path`` < ``overrides`` (``"key=value"``,
        in order, all parsed before the file is read) < ``seed`` (the ``seed`` key, when given),
        and where each value that is not a default came from."""
        parsed = parse_overrides(overrides, self.resolve_key, seed)
        values, origin = dict(defaults), {}
        if path is not None:
            values.update(self.flatten(read_toml(path)[1], str(path), origin))
        for name, value, how in parsed:
            values[name], origin[name] = value, how
        return values, origin

    def changed(self, current: Mapping[str, Any], changes: Mapping[str, Any]) -> dict[str, Any]:
        """``current`` (every key's value) with ``changes`` applied; an unknown key in ``changes``
        is refused (ConfigError naming it)."""
        for name in changes:
            if name not in self.schema:
                raise self.unknown_key(str(name))
        return {**current, **changes}


def with_sources(error: ConfigError, origin: Mapping[str, str]) -> ConfigError:
    """``error``, naming where its keys' values were set (``origin``: key -> file or ``--set``), if known."""
    sources = list(dict.fromkeys(origin[k] for k in error.keys if k in origin))
    return ConfigError(f"{error} (set in {'; '.join(sources)})", error.keys) if sources else error


def given_twice(name: str, first: str, second: str) -> ConfigError:
    """The refusal of config key ``name`` given twice, as ``first`` and as ``second`` (how the user
    wrote each: ``--set tau_minutes=20``, ``--seed 3``, ``seed=3``, ``set['run.seed']``): the same
    in every interface, never the last one silently."""
    return ConfigError(f"{name} is given twice (as {first} and as {second}): give each key once", [name])


def parse_overrides(overrides: Iterable[str], resolve: Callable[[str], str],
                    seed: int | None = None) -> list[tuple[str, Any, str]]:
    """``--set`` texts (and ``--seed``) -> ``(name, value, how it was given)``, in order; a key given
    twice is refused (:func:`given_twice`)."""
    parsed, given = [], {}
    for text in overrides:
        name, value = _parse_override(text, resolve)
        parsed.append((name, value, f"--set {text}"))
    if seed is not None:
        parsed.append(("seed", seed, f"--seed {seed}"))
    for name, _, how in parsed:
        if name in given:
            raise given_twice(name, given[name], how)
        given[name] = how
    return parsed


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
    check_depth(value, "", f"--set {key}")
    return name, value


def check_numba_cache_dir(environ: Mapping[str, str] = os.environ) -> None:
    """ConfigError (one line) if numba's ``NUMBA_CACHE_DIR`` is set to a folder that cannot hold the
    compiled kernels (a file, a folder that cannot be made or written): every process would compile
    them again, silently, into a temporary folder (:func:`dronefleet.jit.cache_root`)."""
    value = environ.get("NUMBA_CACHE_DIR", "")
    if not value:
        return
    folder = Path(value)
    try:
        folder.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=folder):
            pass
    except (OSError, ValueError) as error:  # ValueError: a NUL byte in the path
        reason = error.strerror if isinstance(error, OSError) and error.strerror else type(error).__name__
        shown = repr(value) if len(value) <= 300 else _show(value)  # a path is shown whole
        raise ConfigError(f"NUMBA_CACHE_DIR={shown} is not a folder where the compiled kernels can be "
                          f"written ({reason}); allowed: a writable folder, or unset") from None


def read_toml(path: str | PathLike, kind: str = "config file") -> tuple[str, dict[str, Any]]:
    """The text and TOML document of the ``kind`` (config or sweep file) in ``path``.

    ConfigError, naming the file, if it is not a regular file (a pipe would block), cannot be
    read, is larger than :data:`MAX_CONFIG_BYTES`, is not UTF-8, is not TOML or nests tables and
    lists deeper than :data:`MAX_DEPTH`.
    """
    where = f"{kind} {str(path)!r}"
    try:
        # Only a regular file: opening a pipe would wait for a writer for ever.
        regular = stat.S_ISREG(os.stat(path).st_mode)
        if regular:
            with open(path, "rb") as fh:
                data = fh.read(MAX_CONFIG_BYTES + 1)  # read no further: the file may have grown
    except OSError as e:
        raise ConfigError(f"cannot read {where}: {e.strerror or e}{_shipped_hint(path, e)}") from None
    except ValueError:  # a NUL byte in the path, which no file name holds
        raise ConfigError(f"{where} is not a path: it holds a NUL byte") from None
    if not regular:
        raise ConfigError(f"{where} is not a regular file (a folder, pipe or device); give a TOML file")
    if len(data) > MAX_CONFIG_BYTES:
        raise ConfigError(f"{where} is larger than {MAX_CONFIG_BYTES} bytes; a {kind} is a few KB of TOML")
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as e:
        raise ConfigError(f"{where} is not UTF-8 text (byte {data[e.start]:#04x} at offset {e.start}); "
                          "save it as UTF-8") from None
    try:
        document = tomllib.loads(text)
    except ValueError as e:  # TOMLDecodeError, or an integer of too many digits
        raise ConfigError(f"cannot parse {where}: {e}") from None
    except RecursionError:
        raise ConfigError(f"cannot parse {where}: values nested too deeply") from None
    check_depth(document, f"{where}: ")  # dotted keys nest without limit: a.a.a... = 1
    return text, document


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


#: The folders of ``configs/`` by kind: configs at its top, sweep files in ``sweeps/``.
SHIPPED_FOLDERS = {"config": (), "sweep": ("sweeps",)}


def _shipped_root() -> Path:
    try:
        # Path(): installed packages are folders on disk (numba's cache needs one), never zip files
        return Path(importlib.resources.files("dronefleet.configs"))
    except ModuleNotFoundError:  # not installed (or installed before configs were packaged)
        return Path(__file__).resolve().parent.parent / "configs"


def _description(path: Path) -> str:
    """A shipped file's one-line description: its first comment line, up to a colon or an
    opening parenthesis (the shipped files start so: "# Figure 9 of the replenishment study (...")."""
    with open(path, encoding="utf-8") as fh:
        first = fh.readline()
    text = first.lstrip("#").strip() if first.startswith("#") else ""
    return re.split(r":|\s\(", text, maxsplit=1)[0].strip()


def shipped_files(kind: str = "config") -> dict[str, str]:
    """The shipped configs (``kind="config"``) or sweep files (``"sweep"``): name (the file's stem,
    as commands take it) -> one-line description, in name order."""
    folder = _shipped_root().joinpath(*SHIPPED_FOLDERS[kind])
    return {path.stem: _description(path) for path in sorted(folder.glob("*.toml"))}


def named_file(text: str, kind: str = "config") -> str:
    """A command's config (``kind="config"``) or sweep file (``"sweep"``) argument as a path.

    An existing path wins, so a file of the working directory named like a shipped one is read;
    otherwise a bare name (no folder, no ``.toml``) is the shipped file of that name (``dronefleet
    run replenishment``, ``dronefleet sweep run rules``), from the installed package. Anything
    else is returned unchanged, for :func:`read_toml` to read or refuse. ConfigError for a bare
    name that is neither, listing the shipped names.
    """
    if os.path.lexists(text) or not re.fullmatch(r"[\w.-]+", text) or text.endswith(".toml"):
        return text
    names = shipped_files(kind)
    if text not in names:
        what = {"config": "config", "sweep": "sweep file"}[kind]
        raise ConfigError(f"{_show(text)} is neither a file nor a shipped {what}{_suggest(text, names)}: the shipped "
                          f"{what}s are {', '.join(names)} (dronefleet configs describes them)")
    return str(shipped_config(*SHIPPED_FOLDERS[kind], f"{text}.toml"))


def shipped_config(*parts: str) -> Path:
    """The path of a file shipped in the repository's ``configs/``, e.g. ``shipped_config("sweeps",
    "rules.toml")``, whatever the working directory.

    An installed dronefleet (wheel, ``pip install .`` or ``-e .``) has them as the package
    ``dronefleet.configs``; a source tree put on ``sys.path`` without installing has them beside
    the package. ConfigError if the file is not there.
    """
    path = _shipped_root().joinpath(*parts)
    if not path.is_file():
        raise ConfigError(f"the shipped config {'/'.join(parts)} is missing (looked for {path}): "
                          "reinstall dronefleet")
    return path
