"""The replay page of a run: one self-contained HTML file that plays it in a browser.

``dronefleet replay RUN_DIR --out FILE.html`` and ``dronefleet run --replay`` (which writes
``replay.html`` beside the tables) come here. The page is the template ``replay.html`` with
the run's data embedded as JSON and its scenario's drawing script (``replay.js`` in the
scenario's subpackage) inline: no file or address outside the page is ever fetched. A
scenario provides the page through the contract of :mod:`dronefleet.scenarios`
(``replay_data(run_dir) -> dict``); the page's player gives it play/pause, speed, a time
slider, the counters, an overview chart and ``#t=SECONDS`` (open paused at that time).
"""

import json
import math
import os
import re
from importlib import resources
from pathlib import Path
from typing import Any

from . import scenarios
from .config import SCENARIO_KEY, ConfigError
from .datafiles import DataError, parquet_schema
from .outputs import check_output_file, writing
from .records import CONFIG_KEY, REPLAY_FILE, read_config_dict, run_dir_state, write_atomic

__all__ = ["scenario_of_run", "page", "write"]

TEMPLATE = "replay.html"  # in this package: the page around the data and the scene script


def _config_text(table_path: Path) -> bytes | None:
    """The config a run's table carries (JSON bytes), or None: absent, not parquet, cut short."""
    try:
        return (parquet_schema(table_path).metadata or {}).get(CONFIG_KEY)
    except DataError:
        return None


def scenario_of_run(run_dir: str | os.PathLike) -> scenarios.Scenario:
    """The scenario whose complete run folder ``run_dir`` is; ConfigError (one line) otherwise."""
    run_dir = Path(run_dir)
    if not run_dir.is_dir():
        raise ConfigError(f"RUN_DIR {str(run_dir)!r} is {'a file' if run_dir.exists() else 'missing'}; "
                          "give a folder that dronefleet run wrote")
    try:
        config = read_config_dict(run_dir / "summary.parquet")
    except DataError:  # no config, or JSON that is no config
        raise ConfigError(f"RUN_DIR {str(run_dir)!r} is not a run folder: it has no summary.parquet "
                          "written by dronefleet run") from None
    scenario = scenarios.get(config.get(SCENARIO_KEY, "delivery"), f"RUN_DIR {str(run_dir)!r}: ")
    if run_dir_state(run_dir, scenario.tables) != "complete":
        raise ConfigError(f"RUN_DIR {str(run_dir)!r} is not a complete {scenario.name} run folder: it must "
                          f"hold exactly {', '.join(f'{name}.parquet' for name in scenario.tables)}")
    # every table of a run carries its config: a table of another run (or cut short) has another or none
    text = _config_text(run_dir / "summary.parquet")
    strays = [f"{name}.parquet" for name in scenario.tables if _config_text(run_dir / f"{name}.parquet") != text]
    if strays:
        raise ConfigError(f"RUN_DIR {str(run_dir)!r}: {', '.join(strays)} not of the run in summary.parquet "
                          "(another run's config, or unreadable); write the run again with dronefleet run")
    return scenario


def _json_ready(value):
    """``value`` with NaN and infinities as null: JSON has no such numbers."""
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {key: _json_ready(item) for key, item in value.items()}
    if isinstance(value, list):
        return [_json_ready(item) for item in value]
    return value


#: Characters of the embedded JSON written as \uXXXX escapes (the same string to JSON): with
#: no ``<`` nothing in the data can open a comment (``<!--``, which would make the parser
#: look past ``</script>``), open or close a script element; ``>`` and ``&`` for good
#: measure; U+2028/9 end a line in old JavaScript parsers.
_SCRIPT_SAFE = str.maketrans({char: f"\\u{ord(char):04x}" for char in "<>&\u2028\u2029"})


def page(data: dict[str, Any], scene_script: str) -> str:
    """The HTML page of ``data`` (a scenario's ``replay_data``) drawn by ``scene_script``."""
    template = resources.files(__package__).joinpath(TEMPLATE).read_text(encoding="utf-8")
    embedded = json.dumps(_json_ready(data), allow_nan=False, separators=(",", ":")).translate(_SCRIPT_SAFE)
    parts = {"/*DATA*/": embedded, "/*SCENE*/": scene_script}
    # one pass: a placeholder's text inside the data (a config string) is never filled in
    return re.sub(r"/\*(?:DATA|SCENE)\*/", lambda match: parts.pop(match[0], match[0]), template)


def write(run_dir: str | os.PathLike, out: str | os.PathLike, trial: int | None = None) -> Path:
    """Write the replay page of the run in ``run_dir`` (of its trial ``trial`` if its runs hold
    several; None: the first) to ``out`` (atomically); return ``out``.

    Raises ConfigError (one line) if ``run_dir`` is not a complete run folder, does not hold
    ``trial``, would make a page too large, or holds a
    table that is another run's, cannot be read or holds a value the page cannot draw (a
    DataError naming the file and column), or if ``out`` cannot be written (a folder, a special
    file such as a named pipe or a device, a missing or read-only parent, a file in a run folder
    other than ``run_dir``'s own ``replay.html``, ...).
    """
    run_dir, out = Path(run_dir), Path(out)
    scenario = scenario_of_run(run_dir)
    if out.is_dir():
        raise ConfigError(f"--out {str(out)!r} is a folder; give the page's file name, e.g. {out / REPLAY_FILE}")
    check_output_file(out, "--out", "give the path of a file for the page")  # /dev/null stays a device
    if not out.parent.is_dir():
        raise ConfigError(f"--out {str(out)!r}: folder {str(out.parent)!r} does not exist")
    # in a run folder, any other file would overwrite a table, make the folder no longer a run,
    # or pass for that run's page
    own_page = out.name == REPLAY_FILE and out.parent.resolve() == run_dir.resolve()
    if not own_page and any(run_dir_state(out.parent, s.tables) in ("complete", "partial")
                            for s in scenarios.loading().values()):
        raise ConfigError(f"--out {str(out)!r} lies in a run folder, where only that run's own page may go: "
                          f"give {str(run_dir / REPLAY_FILE)!r} or a file outside any run folder")
    # every table is read through dronefleet.datafiles: a damaged one is a DataError naming it
    html = page(scenario.replay_data(run_dir, trial), scenario.replay_script)
    with writing(out):
        return write_atomic(out, lambda tmp: tmp.write_text(html, encoding="utf-8"))
