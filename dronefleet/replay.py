"""The replay page of a run: one self-contained HTML file that plays it in a browser.

``dronefleet replay RUN_DIR --out FILE.html`` and ``dronefleet run --replay`` (which writes
``replay.html`` beside the tables) come here. The page is the template ``replay.html`` with
the run's data embedded as JSON and its scenario's drawing script (``replay.js`` in the
scenario's subpackage) inline: no file or address outside the page is ever fetched. A
scenario provides the page through the contract of :mod:`dronefleet.scenarios`
(``replay_data(run_dir) -> dict``); the page's player gives it play/pause, speed, a time
slider, the counters, an overview chart and ``#t=SECONDS`` (open paused at that time).

``dronefleet replay DATASET --run KEY=VALUE ...`` plays one run of a sweep's dataset
(:func:`write_dataset_run`): its parts, or, if its tables were not kept, the run simulated
again from the config its summary part holds (the seed included).
"""

import json
import logging
import math
import os
import re
import tempfile
from importlib import resources
from pathlib import Path
from typing import Any

from . import scenarios, sweeps
from .config import SCENARIO_KEY, ConfigError, _show, one_line
from .datafiles import DataError, parquet_schema
from .outputs import check_output_file, writing
from .records import CONFIG_KEY, REPLAY_FILE, read_config_dict, run_dir_state, write_atomic, write_tables

__all__ = ["scenario_of_run", "page", "write", "is_dataset", "select_run", "write_dataset_run"]

log = logging.getLogger(__name__)

#: Folder of a dataset where its runs' pages go by default (``_``: dataset readers skip it).
DATASET_PAGES = sweeps.PAGES_FOLDER
#: At most this many values of a key are listed when a --run selection is refused.
SHOWN_VALUES = 20

TEMPLATE = "replay.html"  # in this package: the page around the data and the scene script
#: The line of :data:`TEMPLATE`'s head that marks a page as dronefleet's: --out replaces only such a file.
GENERATOR = '<meta name="generator" content="dronefleet replay">'
#: Bytes of a file read to find :data:`GENERATOR` (the template's head; the data comes after it).
PAGE_HEAD = 1024


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


def write(run_dir: str | os.PathLike, out: str | os.PathLike, trial: int | None = None,
          source: str | None = None) -> Path:
    """Write the replay page of the run in ``run_dir`` (of its trial ``trial`` if its runs hold
    several; None: the first) to ``out`` (atomically); return ``out``. ``source``, if given, says
    where the run comes from (a sweep's run): the page's data holds it and its title ends with it.

    Raises ConfigError (one line) if ``run_dir`` is not a complete run folder, does not hold
    ``trial``, would make a page too large, or holds a
    table that is another run's, cannot be read or holds a value the page cannot draw (a
    DataError naming the file and column), or if ``out`` cannot be written (a folder, a special
    file such as a named pipe or a device, a symbolic link, a file that is not a replay page
    dronefleet wrote, a missing or read-only parent, a file in a run folder other than
    ``run_dir``'s own ``replay.html``, ...).
    """
    run_dir, out = Path(run_dir), Path(out)
    scenario = scenario_of_run(run_dir)
    _check_out(out, run_dir)
    # every table is read through dronefleet.datafiles: a damaged one is a DataError naming it
    data = scenario.replay_data(run_dir, trial)
    if source is not None:
        data = {**data, "source": source, "title": f"{data['title']} ({source})"}
    html = page(data, scenario.replay_script)
    with writing(out):
        return write_atomic(out, lambda tmp: tmp.write_text(html, encoding="utf-8"))


def is_page(path: Path) -> bool:
    """Whether the file ``path`` is a replay page dronefleet wrote: its head holds :data:`GENERATOR`
    (only the head is read: the file may be large, or not a page at all)."""
    try:
        with open(path, "rb") as file:
            return GENERATOR.encode() in file.read(PAGE_HEAD)
    except OSError:
        return False


def _check_out(out: Path, run_dir: Path) -> None:
    """Refuse (ConfigError, one line) a page file ``out`` that cannot be written or would spoil a
    run folder: only ``run_dir``'s own :data:`REPLAY_FILE` may go into one."""
    if out.is_dir():
        raise ConfigError(f"--out {str(out)!r} is a folder; give the page's file name, e.g. {out / REPLAY_FILE}")
    if out.is_symlink():  # the page's rename would replace the link; writing through it, another file
        raise ConfigError(f"--out {str(out)!r} is a symbolic link; give the path of the page itself")
    if not out.parent.is_dir():
        raise ConfigError(f"--out {str(out)!r}: folder {str(out.parent)!r} does not exist")
    # in a run folder, any other file would overwrite a table, make the folder no longer a run,
    # or pass for that run's page
    own_page = out.name == REPLAY_FILE and out.parent.resolve() == run_dir.resolve()
    if not own_page and any(run_dir_state(out.parent, s.tables) in ("complete", "partial")
                            for s in scenarios.loading().values()):
        raise ConfigError(f"--out {str(out)!r} lies in a run folder, where only that run's own page may go: "
                          f"give {str(run_dir / REPLAY_FILE)!r} or a file outside any run folder")
    # only a page dronefleet wrote is replaced, never a user's file (/dev/null stays a device)
    check_output_file(out, "--out", "give the path of another file for the page", replaceable=is_page,
                      kind="a replay page that dronefleet wrote")


def is_dataset(folder: str | os.PathLike) -> bool:
    """Whether ``folder`` is a sweep's dataset (its layout file, or a ``summary`` folder of parts),
    not a run folder."""
    folder = Path(folder)
    return not (folder / "summary.parquet").exists() and (
        (folder / sweeps.LAYOUT_FILE).exists() or (folder / "summary").is_dir())


def _shown_values(values) -> str:
    """Distinct ``values`` (texts of folder names), each on one line and cut, the first :data:`SHOWN_VALUES`."""
    values = list(dict.fromkeys(values))
    shown = ", ".join(_short(value) for value in values[:SHOWN_VALUES])
    return shown + (f", ... ({len(values)} values)" if len(values) > SHOWN_VALUES else "")


def _short(text: str) -> str:
    text = one_line(text)
    return text if len(text) <= 60 else text[:57] + "..."


def _matches(value: str, text: str) -> bool:
    """Whether a run's ``value`` (as its path spells it) is the one ``text`` names: the same
    text, or the same number (``15`` names ``15.0``)."""
    if value == text:
        return True
    try:
        return float(value) == float(text)
    except ValueError:
        return False


def select_run(dataset: Path, selection: list[str]) -> sweeps.Run:
    """The one run of the sweep dataset ``dataset`` whose partition values the ``KEY=VALUE`` texts
    of ``selection`` name (:func:`dronefleet.sweeps.dataset_parts`); ConfigError (one line)
    listing what is allowed if a text is malformed or names another key, or if no run or several
    runs match. Only the chosen run's part is read."""
    keys, parts = sweeps.dataset_parts(dataset)
    if not parts:
        raise ConfigError(f"no run of the dataset {dataset} is done: nothing to replay (dronefleet sweep run)")
    chosen, given = parts, {}
    for text in selection:
        key, equals, value = text.partition("=")
        key, value = key.strip(), value.strip()
        if not equals:
            raise ConfigError(f"--run {_show(text)}: expected KEY=VALUE, one of the keys {', '.join(keys)}, "
                              f"e.g. --run {keys[0]}={parts[0][0][keys[0]]}")
        name = key if key in keys else key.rpartition(".")[2]  # section.key, as everywhere
        if name not in keys and sweeps.ROOT_SEED in keys and name == "seed":  # the config's word for it
            name = sweeps.ROOT_SEED
        if name not in keys:
            raise ConfigError(f"--run {_show(text)}: the runs of the dataset {dataset} are told apart by "
                              f"{', '.join(keys)}; choose with those")
        if name in given:
            raise ConfigError(f"--run {name} is given twice ({_show(given[name])} and {_show(value)}); "
                              "give each key once")
        given[name] = value
        matching = [(values, part) for values, part in chosen if _matches(values[name], value)]
        if not matching:
            among = "" if len(given) == 1 else " among the runs of " + ", ".join(
                f"{k}={_short(v)}" for k, v in given.items() if k != name)
            raise ConfigError(f"--run {name}={_short(value)}: no run of the dataset {dataset} has it; allowed{among}: "
                              f"{name} = {_shown_values(values[name] for values, _ in chosen)}")
        chosen = matching
    if len(chosen) > 1:
        open_keys = [key for key in keys if len({values[key] for values, _ in chosen}) > 1]
        choices = "; ".join(f"{key} = {_shown_values(values[key] for values, _ in chosen)}" for key in open_keys)
        which = f"--run {' --run '.join(f'{k}={_short(v)}' for k, v in given.items())} matches" if given else "it holds"
        raise ConfigError(f"the dataset {dataset}: {which} {len(chosen)} runs; choose one with --run KEY=VALUE "
                          f"for {', '.join(open_keys)} ({choices})")
    return sweeps.dataset_run(dataset, keys, chosen[0][1])


def _run_folder(run: sweeps.Run, dataset: Path, folder: Path) -> Path:
    """A run folder (``folder``/run) of ``run``'s tables in ``dataset``: its parts if all were
    kept (with the partition keys a table's schema holds put back as its columns), else the run
    simulated again from its config, whose summary must be the part's."""
    import pyarrow.parquet as pq

    from .datafiles import DataError, read_parquet

    scenario, run_dir = run.scenario, folder / "run"
    if all(os.path.lexists(run.path(dataset, table)) for table in scenario.tables):
        problem = sweeps.damage(run, dataset)
        if problem is not None:
            raise ConfigError(f"{problem}: run {run.partition} cannot be replayed (dronefleet sweep run redoes it)")
        run_dir.mkdir()
        schemas = scenario.table_schemas()
        for table in scenario.tables:
            if any(key in schemas[table].names for key in run.keys):  # e.g. lunar's summary holds its layout
                pq.write_table(sweeps.read_part(run, dataset, table), run_dir / f"{table}.parquet")
            else:
                (run_dir / f"{table}.parquet").symlink_to(run.path(dataset, table).absolute())
        return run_dir
    log.info(f"dronefleet replay: the tables of run {run.partition} were not kept; simulating it again from "
             "its config")
    tables = sweeps.simulate(scenario, run.config)
    part = run.path(dataset, "summary")
    again = tables["summary"].drop_columns([key for key in run.keys if key in tables["summary"].column_names])
    stored = read_parquet(part, dict(zip(again.column_names, again.schema.types)), "part", exact=True)
    if not stored.to_pandas().equals(again.to_pandas()):  # pandas: NaN (no such metric) equals NaN
        raise DataError(f"part {str(part)!r}: its run simulated again from its config gives another summary "
                        "(a part of another dronefleet version, or tampered with)")
    write_tables(tables, run_dir, run.config)
    return run_dir


def write_dataset_run(dataset: str | os.PathLike, selection: list[str], out: str | os.PathLike | None = None,
                      trial: int | None = None) -> Path:
    """Write the replay page of the run of the sweep dataset ``dataset`` that ``selection``
    (``KEY=VALUE`` texts, :func:`select_run`) names, of its trial ``trial`` (None: its first), to
    ``out`` (default ``dataset/_replay/<run id>.html``); return the page's path.

    The run's parts are played if all its tables were kept, else the run is simulated again
    from the config its summary part holds (and refused if that gives another summary).
    ConfigError (one line, before any simulation or write) for a selection that names no run
    or several, an ``out`` that cannot be written or lies among the dataset's tables, a page
    the scenario would refuse, or a damaged part (named).
    """
    dataset = Path(dataset)
    run = select_run(dataset, selection)
    default = out is None
    out = dataset / DATASET_PAGES / f"{run.id}.html" if default else Path(out)
    inside = [table for table in run.scenario.tables if Path(os.path.abspath(out)).is_relative_to(
        os.path.abspath(dataset / table))]
    if inside:
        raise ConfigError(f"--out {str(out)!r} lies in the dataset's {inside[0]} files, which readers take whole: "
                          f"give a file outside {dataset / inside[0]}")
    if out.parent.is_dir() or not default:  # the default folder is made only once the page can be written
        _check_out(out, dataset)
    run.scenario.check_replayable(run.config, trial)
    with tempfile.TemporaryDirectory(prefix="dronefleet-replay-") as folder:
        run_dir = _run_folder(run, dataset, Path(folder))
        if default:
            with writing(out.parent):
                out.parent.mkdir(exist_ok=True)
        try:
            return write(run_dir, out, trial, f"sweep dataset {dataset.name}, run {run.partition}")
        except ConfigError as error:  # name the dataset's files, not the temporary folder's
            text = str(error)
            for table in run.scenario.tables:
                text = text.replace(str(run_dir / f"{table}.parquet"), str(run.path(dataset, table)))
            raise ConfigError(text.replace(str(run_dir), f"{dataset} run {run.partition}")) from None
