"""Command line: ``dronefleet run [CONFIG] [--set key=value ...] [--seed N] [--out DIR]
[--overwrite] [--fleet FILE] [--save-fleet FILE]``; ``dronefleet bounds [CONFIG] [--set key=value ...]``;
``dronefleet configs``; ``dronefleet sweep plan|run|status|collect SWEEP``; ``dronefleet analyze
sensitivity SWEEP --metric M``; ``dronefleet reproduce
FIGURE...|all [--quick]``, ``--list``; ``dronefleet replay RUN_DIR|DATASET [--run KEY=VALUE ...] [--out FILE.html]
[--trial K]``.
Four scenarios: delivery (UAV delivery with auctions and online learning), replenishment (energy
replenishment by fixed and mobile chargers), items (item delivery and foraging), lunar (lunar foraging
with recharging). A config names its scenario (:mod:`dronefleet.scenarios`); without ``scenario = ...``
it is delivery. CONFIG and SWEEP are paths, or the names of shipped files (``replenishment``, ``items``,
``lunar``, ``rules``: ``dronefleet configs``).
``-q`` prints warnings and errors only, ``-v`` adds debugging detail (before or after the command)."""

import argparse
import hashlib
import logging
import os
import re
import stat
import sys
import time
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from . import analyze, console, provenance, scenarios, sweeps
from .config import (SHIPPED_FOLDERS, ConfigError, _show, _suggest, check_numba_cache_dir, named_file,
                     shipped_config, shipped_files)
from .delivery.config import SECONDS_PER_WEEK, load_config
from .outputs import OutputError, check_output_file, probe_folders, writing

log = logging.getLogger("dronefleet.cli")  # not __name__: python -m dronefleet.cli runs it as __main__


def default_out(name: str, config: Any, tag: str | None = None) -> Path:
    """``results/runs/<name>-<tag>-<8 hex>`` (``tag`` by default ``seed<N>``): the hex digits start
    the SHA-256 of the resolved config's JSON, so runs of different configs (``--set``, ``--fleet``)
    never share a folder."""
    digest = hashlib.sha256(config.to_json().encode()).hexdigest()[:8]
    return Path("results") / "runs" / f"{name}-{tag or f'seed{config.seed}'}-{digest}"


def check_outputs(out: Path, save_fleet: Path | None, overwrite: bool, tables: Iterable[str] | None = None) -> None:
    """Refuse, before any work, outputs that the run could not write or would silently replace.

    ``out`` must be absent, an empty folder, or (with ``overwrite``) a run folder (of the table
    names ``tables``, by default delivery's), and lie in no sweep dataset; its parent and
    ``save_fleet``'s folder must be writable; ``save_fleet`` must not exist unless ``overwrite``,
    and never be a folder or a special file (a named pipe, a device).
    """
    from .delivery.records import TABLES
    from .records import clean_leftovers, run_dir_state

    if out.name in ("", ".."):  # "." and "/" normalised have no name: no sibling to write first
        raise OutputError(f"--out {str(out)!r} must name a folder of its own, e.g. results/runs/mine")
    try:
        link = stat.S_ISLNK(os.lstat(out).st_mode)
    except (FileNotFoundError, NotADirectoryError):
        link = False
    except (OSError, ValueError) as error:  # a name too long, a NUL byte: no folder can be called that
        reason = getattr(error, "strerror", None) or "it holds a NUL byte"
        raise OutputError(f"--out {_show(str(out))} cannot name a folder: {reason}") from None
    if link:  # the folder is replaced by a rename, which would replace the link, not its target
        raise OutputError(f"--out {str(out)!r} is a symbolic link; give the folder itself")
    if save_fleet is not None and Path(os.path.abspath(save_fleet)).is_relative_to(os.path.abspath(out)):
        raise OutputError(f"--save-fleet {str(save_fleet)!r} lies inside --out {str(out)!r}, which is written "
                          "(and replaced) whole; save the fleet outside it")
    dataset = sweeps.dataset_holding(out)
    if dataset is not None:
        raise OutputError(f"--out {str(out)!r} lies in the sweep dataset {str(dataset)!r}, whose readers would "
                          "take the run for rows of the sweep: give a folder outside it")
    with writing(out):
        clean_leftovers(out)  # first: it may put back a run that a killed --overwrite had set aside
        state = run_dir_state(out, tables or TABLES)
    if state == "file":
        raise OutputError(f"--out {str(out)!r} is a file; it must be a folder (absent, empty or a run)")
    if state == "other":
        raise OutputError(f"--out {str(out)!r} holds files other than a run's tables; choose another --out")
    if state in ("complete", "partial") and not overwrite:
        held = "a complete run" if state == "complete" else "part of a run"
        raise OutputError(f"{out} exists and holds {held}; pass --overwrite to replace it or choose another --out")
    if save_fleet is not None:
        check_output_file(save_fleet, "--save-fleet", "it must be a file")
        if save_fleet.exists() and not overwrite:
            raise OutputError(f"--save-fleet {str(save_fleet)!r} exists; pass --overwrite to replace it "
                              "or choose another --save-fleet")
    probe_folders([out.parent, *([save_fleet.parent] if save_fleet is not None else [])])


def run(args: argparse.Namespace) -> int:
    """``dronefleet run``: a delivery run here (fleet files, the bar in simulated weeks), any other
    scenario through :func:`run_scenario`; returns the exit code."""
    if args.config is not None:
        args.config = named_file(args.config)
    scenario = scenarios.scenario_of(args.config)
    if scenario.name != "delivery":
        return run_scenario(scenario, args)
    overrides = args.set + ([f"run.fleet_file={args.fleet}"] if args.fleet else [])
    config = load_config(args.config, overrides, args.seed)  # refuses bad input before any work
    _check_replay(scenario, config, args)
    name = Path(args.config).stem if args.config else "paper"
    out = Path(os.path.normpath(args.out)) if args.out else default_out(name, config)

    from .delivery.fleet import load_fleet, save_fleet, seeded_path
    from .delivery.metrics import run_metrics
    from .delivery.records import write_run
    from .delivery.scenario import format_metrics
    from .delivery.simulation import InvalidStateError, RunTooLargeError, simulate
    from .supervisor import SupervisorError

    fleet = load_fleet(config.fleet_file, config) if config.fleet_file else None  # refused before any work
    fleet_out = seeded_path(args.save_fleet, config.seed) if args.save_fleet else None
    check_outputs(out, fleet_out, args.overwrite)

    log.info(f"dronefleet run: {name}, seed {config.seed}, rule {config.rule}, tau {config.tau_minutes:g} min, "
             f"{console.counted(config.n_uavs, 'UAV')}, {console.counted(config.horizon_weeks, 'week')}")
    log.debug(f"  config {config.to_json()}")
    start = time.perf_counter()
    weeks = console.progress(config.horizon_weeks, "week", "  simulated")
    try:
        with weeks, console.compile_notice("the delivery engine"):
            result = simulate(config, fleet=fleet,
                              progress=lambda t_s: weeks.update(t_s / SECONDS_PER_WEEK - weeks.n))
    except (SupervisorError, InvalidStateError, RunTooLargeError) as error:  # nothing written: tables come after
        raise ConfigError(f"the run stopped: {error}") from None
    wall = time.perf_counter() - start
    # The fleet file first: if either write fails, neither output is left behind.
    if fleet_out is not None:
        with writing(fleet_out):
            saved = save_fleet(result, fleet_out)
    try:
        with writing(out):
            write_run(result, out, overwrite=args.overwrite)
    except BaseException:
        if fleet_out is not None:
            fleet_out.unlink(missing_ok=True)
        raise
    log.info(format_metrics(run_metrics(result), wall))
    log.info(f"  {'tables':<22}{out}/{{orders,attempts,fleet,timeseries,summary}}.parquet")
    if fleet_out is not None:
        log.info(f"  {'saved fleet':<22}{saved}")
    _write_replay(args, out)
    return 0


def _check_replay(scenario: scenarios.Scenario, config: Any, args: argparse.Namespace) -> None:
    """``run --replay [--trial K]``: refuse, before the run, a page that would be refused after it."""
    if args.trial is not None and not args.replay:
        raise ConfigError(f"--trial {args.trial} chooses the trial of the replay page: give it with --replay")
    if args.replay:
        scenario.check_replayable(config, args.trial)


def _write_replay(args, out):
    """``run --replay``: the replay page beside the run's tables (of trial ``--trial``, if given)."""
    if args.replay:
        from . import replay
        from .records import REPLAY_FILE

        log.info(f"  {'replay':<22}{replay.write(out, out / REPLAY_FILE, args.trial)}")


def replay_command(args: argparse.Namespace) -> int:
    """``dronefleet replay RUN_DIR [--out FILE.html] [--trial K]``: the run's replay page;
    ``dronefleet replay DATASET [--run KEY=VALUE ...]``: that of one run of a sweep's dataset
    (:mod:`dronefleet.replay`)."""
    from . import replay
    from .records import REPLAY_FILE

    run_folder = (Path(args.run_dir) / "summary.parquet").exists()
    if replay.is_dataset(args.run_dir) or (args.run is not None and not run_folder):
        written = replay.write_dataset_run(args.run_dir, args.run or [], args.out, args.trial)
    elif args.run is not None:
        raise ConfigError(f"--run chooses a run of a sweep's dataset; {str(args.run_dir)!r} is a run folder "
                          "itself: leave --run out")
    else:
        out = Path(args.out) if args.out else Path(args.run_dir) / REPLAY_FILE
        written = replay.write(args.run_dir, out, args.trial)
    log.info(f"dronefleet replay: {written} ({written.stat().st_size / 1e6:.1f} MB)")
    return 0


def run_scenario(scenario: scenarios.Scenario, args: argparse.Namespace) -> int:
    """``dronefleet run`` through the scenario contract: load (refusing bad input), check the
    output folder, simulate, write the tables (complete or absent), print the summary."""
    for flag, value in (("--fleet", args.fleet), ("--save-fleet", args.save_fleet)):
        if value:
            raise ConfigError(f"{flag} applies to delivery runs only, not to scenario {scenario.name!r}")
    config = scenario.load(args.config, args.set, args.seed)
    _check_replay(scenario, config, args)
    name = Path(args.config).stem
    out = Path(os.path.normpath(args.out)) if args.out else default_out(name, config, scenario.label(config))
    check_outputs(out, None, args.overwrite, scenario.tables)

    from .records import write_tables

    log.info(f"dronefleet run: {name}, {scenario.describe(config)}")
    log.debug(f"  config {config.to_json()}")
    start = time.perf_counter()
    with console.compile_notice(f"the {scenario.name} kernel"):
        tables = sweeps.simulate(scenario, config)  # an installed scenario's in a process of its own
    wall = time.perf_counter() - start
    summary = scenario.format_summary(tables)  # before the write: a hook that fails leaves no run folder
    with writing(out):
        write_tables(tables, out, config, overwrite=args.overwrite)
    log.info(summary)
    log.info(f"  {'wall time':<22}{wall:.2f} s")
    log.info(f"  {'tables':<22}{out}/{{{','.join(tables)}}}.parquet")
    _write_replay(args, out)
    return 0


def bounds(args: argparse.Namespace) -> int:
    """``dronefleet bounds [CONFIG]``: the scenario's analytic bounds (docs/replenishment-model.md section 9)."""
    args.config = named_file(args.config)
    scenario, config = scenarios.load(args.config, args.set)
    if scenario.format_bounds is None:
        having = [s.name for s in scenarios.loading().values() if s.format_bounds is not None]
        raise ConfigError(f"{args.config!r} is a {scenario.name} config: analytic bounds exist only for "
                          f"{', '.join(having)}")
    text = scenario.format_bounds(config)  # refuses parameters where a bound does not exist
    print(f"dronefleet bounds: {Path(args.config).stem}, {scenario.describe(config)}")
    print(text)
    return 0


def export_command(args: argparse.Namespace) -> int:
    """``dronefleet export SOURCE [--out DIR] [--overwrite]``: its tables as CSV (:mod:`dronefleet.export`)."""
    from .export import export

    out = export(args.source, args.out, args.overwrite)
    log.info(f"dronefleet export: {', '.join(sorted(p.name for p in out.glob('*.csv')))} in {out}")
    return 0


def configs_command(args: argparse.Namespace) -> int:
    """``dronefleet configs``: the shipped configs and sweep files, a line each, by the name commands take;
    ``dronefleet configs show NAME``: the text of one (to copy and edit: a wheel install has no configs/)."""
    if args.show:
        if args.show[0] != "show" or len(args.show) != 2:
            raise ConfigError(f"configs {' '.join(args.show)}: expected 'configs' alone or 'configs show NAME'")
        name = args.show[1]
        kinds = [kind for kind in ("config", "sweep") if name in shipped_files(kind)]
        if not kinds:
            every = [*shipped_files("config"), *shipped_files("sweep")]
            raise ConfigError(f"{_show(name)} is not a shipped config or sweep file{_suggest(name, every)}; "
                              "dronefleet configs lists them")
        print(shipped_config(*SHIPPED_FOLDERS[kinds[0]], f"{name}.toml").read_text(encoding="utf-8"), end="")
        return 0
    for kind, heading in (("config", "configs: dronefleet run NAME, dronefleet bounds NAME"),
                          ("sweep", "sweep files: dronefleet sweep plan|run|status|collect NAME")):
        files = shipped_files(kind)
        print(f"{heading} (in {shipped_config(*SHIPPED_FOLDERS[kind], next(iter(files)) + '.toml').parent})")
        for name, description in files.items():
            print(f"  {name:<22}{description}")
    print("A path names a file first: a file of the working directory called like a shipped one is read instead.")
    return 0


def _verbosity(default):
    """A parent parser of ``-q``/``-v`` (the ``logging`` level in ``level``); subcommands get it with
    ``default=argparse.SUPPRESS``, so that a flag given before the command is not reset after it."""
    parent = argparse.ArgumentParser(add_help=False)
    flags = parent.add_mutually_exclusive_group()
    flags.add_argument("-q", "--quiet", dest="level", action="store_const", const=logging.WARNING, default=default,
                       help="print warnings and errors only (no progress lines, summaries or bars)")
    flags.add_argument("-v", "--verbose", dest="level", action="store_const", const=logging.DEBUG, default=default,
                       help="also print debugging detail (resolved configs, files read, each run done)")
    return parent


class _Commands(argparse._SubParsersAction):
    """Subcommands that all take ``-q``/``-v``."""

    def add_parser(self, name, **kwargs):
        kwargs["parents"] = [*kwargs.get("parents", ()), _verbosity(argparse.SUPPRESS)]
        return super().add_parser(name, **kwargs)

    def __call__(self, parser, namespace, values, option_string=None):
        # the command's flags replace those before it: -q before and -v after (or the reverse)
        # would pass each parser's own check, and one of them would be dropped unsaid
        before = getattr(namespace, "level", None)
        super().__call__(parser, namespace, values, option_string)
        if before not in (None, logging.INFO) and namespace.level != before:  # INFO: no flag given
            raise argparse.ArgumentError(None, "-q/--quiet and -v/--verbose are not allowed together "
                                               "(before the command or after it)")


# reST in the docstrings and help texts shown by --help: ``literal`` and :role:`target` (~: its last name)
_LITERAL = re.compile(r"``(.+?)``", re.DOTALL)  # a literal may span lines
_ROLE = re.compile(r":[\w:.-]+:`(~?)([^`<]*?)\s*(?:<[^`>]*>)?`")


def _plain(text: str) -> str:
    """``text`` without reST markup: ``dronefleet run`` -> dronefleet run, :mod:`dronefleet.scenarios`
    -> dronefleet.scenarios, :func:`~a.b` -> b."""
    text = _ROLE.sub(lambda m: m[2].rsplit(".", 1)[-1] if m[1] else m[2], text)
    return _LITERAL.sub(r"\1", text)


class _Formatter(argparse.HelpFormatter):
    """argparse's help with the docstrings' reST markup stripped (:func:`_plain`)."""

    def _format_text(self, text):
        return super()._format_text(_plain(text))

    def _expand_help(self, action):
        return _plain(super()._expand_help(action))


class _Parser(argparse.ArgumentParser):
    """argparse with usage errors on one line, like every other refusal (exit code 2), subcommands
    (of any depth) that take ``-q``/``-v``, and help texts without reST markup."""

    def __init__(self, *args, **kwargs):
        kwargs.setdefault("formatter_class", _Formatter)
        super().__init__(*args, **kwargs)
        self.register("action", "parsers", _Commands)

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


class _Version(argparse.Action):
    """``--version``: ``dronefleet <version> (commit <sha>)``; the commit is looked up only when asked."""

    def __init__(self, option_strings, dest, **kwargs):
        super().__init__(option_strings, dest, nargs=0, help="print the version (and git commit) and exit")

    def __call__(self, parser, namespace, values, option_string=None):
        print(provenance.version_line())
        parser.exit()


class _ListStudies(argparse.Action):
    """``reproduce --list``: every study and its figures (:func:`dronefleet.reproduce.list_studies`)."""

    def __init__(self, option_strings, dest, **kwargs):
        super().__init__(option_strings, dest, nargs=0, help="list every study and its figures, and exit")

    def __call__(self, parser, namespace, values, option_string=None):
        from .reproduce import list_studies

        print(list_studies())
        parser.exit()


def build_parser(reproduce_arguments: bool = True) -> argparse.ArgumentParser:
    """The parser; without ``reproduce_arguments`` the reproduce command is only listed, so that
    ``dronefleet --help`` and ``--version`` do not import pandas and numba (:mod:`dronefleet.reproduce`)."""
    parser = _Parser(prog="dronefleet", description=__doc__, parents=[_verbosity(logging.INFO)])
    parser.add_argument("--version", action=_Version)
    commands = parser.add_subparsers(dest="command", required=True)
    p = commands.add_parser("run", help="simulate one run and write its tables as parquet")
    p.add_argument("config", nargs="?", help="TOML config file, any scenario, or a shipped config's name "
                                             "(dronefleet configs lists them), e.g. replenishment; default: "
                                             "the paper's delivery scenario")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="override a config key, e.g. --set tau_minutes=20 or --set auction.rule=random")
    p.add_argument("--seed", type=int, help="seed of the run (overrides run.seed)")
    p.add_argument("--out", type=_path, metavar="DIR",
                   help="output folder, written complete or not at all (default: results/runs/<config>-seed<N>-<H>, "
                        "H the first 8 hex digits of the SHA-256 of the resolved config as JSON, so runs of "
                        "different configs never share a folder)")
    p.add_argument("--overwrite", action="store_true",
                   help="replace the run already in --out (and the file --save-fleet names); without it, "
                        "the run is refused before any work")
    p.add_argument("--fleet", type=_path, metavar="FILE",
                   help="start from a saved fleet (parquet, '{seed}' is replaced by the seed); "
                        "same as --set run.fleet_file=FILE")
    p.add_argument("--save-fleet", type=_path, metavar="FILE",
                   help="save the fleet at the end of the run (parquet, '{seed}' is replaced by the seed)")
    p.add_argument("--replay", action="store_true",
                   help="also write replay.html beside the tables: a page that plays the run in a browser")
    p.add_argument("--trial", type=_at_least(1), metavar="K",
                   help="with --replay: the trial the page plays, of a run holding several (default: its first)")
    p.set_defaults(func=run)
    p = commands.add_parser("replay", help="write a run's replay page: one self-contained HTML file",
                            description="A page that plays a run folder, or one run of a sweep's dataset, in any "
                                        "browser, offline: delivery flights, or one trial's robots of a "
                                        "replenishment or items run.")
    p.add_argument("run_dir", metavar="RUN_DIR|DATASET",
                   help="a run folder that dronefleet run wrote, or a sweep's dataset (<results>/<sweep name>)")
    p.add_argument("--run", action="append", metavar="KEY=VALUE",
                   help="the run of DATASET to play, by its grid values and seed, e.g. --run rule=random "
                        "--run seed=3 (repeat for each key that tells its runs apart); a run whose tables were "
                        "not kept is simulated again from its stored config and seed")
    p.add_argument("--out", type=_path, metavar="FILE.html",
                   help="the page to write (default: RUN_DIR/replay.html, DATASET/_replay/<run>.html)")
    p.add_argument("--trial", type=_at_least(1), metavar="K",
                   help="the trial to play, of a run holding several (default: its first)")
    p.set_defaults(func=replay_command)
    p = commands.add_parser("bounds", help="print the analytic upper bounds of a replenishment config",
                            description="Work and efficiency bounds of docs/replenishment-model.md section 9, both "
                                        "strategies; refused (exit 2) where a bound does not exist.")
    p.add_argument("config", nargs="?", default="replenishment",
                   help="TOML config file with scenario = \"replenishment\", or a shipped config's name "
                        "(default: replenishment, the shipped configs/replenishment.toml)")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="override a config key, e.g. --set transfer_loss=0.2 or --set energy.work_ratio=2")
    p.set_defaults(func=bounds)
    p = commands.add_parser("configs", help="list the shipped configs and sweep files, by the names commands take",
                            description="The configs and sweep files installed with dronefleet, a line each; "
                                        "run, bounds and sweep take their names as well as paths. "
                                        "'configs show NAME' prints one, e.g. to save as a config of your own: "
                                        "dronefleet configs show paper > mine.toml")
    p.add_argument("show", nargs="*", metavar="show NAME",
                   help="print the shipped config or sweep file NAME")
    p.set_defaults(func=configs_command)
    p = commands.add_parser("export", help="write tables as CSV: a parquet file, a run folder or a sweep's dataset",
                            description="Every table of SOURCE as <table>.csv in one folder, for tools that "
                                        "read no parquet (a spreadsheet, R's read.csv).")
    p.add_argument("source", metavar="SOURCE", help="a parquet file, a run folder or a sweep's dataset")
    p.add_argument("--out", type=_path, metavar="DIR", help="the folder of the CSV files (default: SOURCE-csv)")
    p.add_argument("--overwrite", action="store_true", help="replace the CSV files of an earlier export in --out")
    p.set_defaults(func=export_command)
    _add_sweep_commands(commands)
    _add_analyze_commands(commands)
    _add_reproduce_command(commands, reproduce_arguments)
    return parser


def _at_least(least):
    """argparse type: an integer >= ``least``, in ASCII digits."""
    def integer(text):
        # isdigit() alone takes '²' and other Unicode digits, which int() refuses; a number of
        # thousands of digits is refused by int() too, and is no count or task anyway
        if not (text.isascii() and text.isdigit() and len(text) < 19) or int(text) < least:
            shown = repr(text) if len(text) <= 40 else f"{text[:40]!r}... ({len(text)} characters)"
            raise argparse.ArgumentTypeError(f"expected an integer >= {least} (at most 18 digits), got {shown}")
        return int(text)
    return integer


def _figure(names: tuple[str, ...]):
    """argparse type: one of the figure ``names``; otherwise the closest one suggested, not all of them listed."""
    def figure(text):
        if text not in names:
            raise argparse.ArgumentTypeError(f"{_show(text)} is not a figure{_suggest(text, names)}; "
                                             f"dronefleet reproduce --list shows all {len(names) - 1}")
        return text
    return figure


def _path(text: str) -> str:
    """argparse type: a path, not empty (an empty one would mean the default, or the current folder)."""
    if not text:
        raise argparse.ArgumentTypeError("expected a path, got an empty one ''")
    return text


def _add_sweep_commands(commands):
    """``dronefleet sweep plan|run|status|collect SWEEP``; the handlers are in :mod:`dronefleet.sweeps`."""
    parser = commands.add_parser("sweep", help="parameter sweeps: plan a job array, run, status, collect",
                                 description="Grids of conditions times seeds; see docs/guide/sweeps.md.")
    actions = parser.add_subparsers(dest="action", required=True)
    common = argparse.ArgumentParser(add_help=False)
    common.add_argument("sweep", help="sweep file (TOML), or a shipped sweep file's name (dronefleet configs "
                                      "lists them), e.g. configs/sweeps/rules.toml or rules")
    common.add_argument("--results", type=_path, default="results", metavar="DIR",
                        help="results root; the sweep's dataset is DIR/<name>/ (default: results)")
    p = actions.add_parser("plan", parents=[common], help="print the runs and tasks, write a SLURM job-array script")
    p.add_argument("--out", type=_path, help="where to write the script (default: DIR/<name>/<name>.sbatch)")
    p.add_argument("--time", help="#SBATCH --time of each task, e.g. 00:30:00 (default: none, the partition's)")
    p.add_argument("--mem", default=sweeps.DEFAULT_MEM,
                   help=f"#SBATCH --mem of each task, e.g. 4G (default: {sweeps.DEFAULT_MEM})")
    p.add_argument("--partition", help="#SBATCH --partition")
    p.add_argument("--account", help="#SBATCH --account")
    p.set_defaults(func=sweeps.plan_command)
    p = actions.add_parser("run", parents=[common], help="run one task's runs, or all runs; skip those done")
    p.add_argument("--task-id", type=_at_least(0), metavar="N",
                   help="run job-array task N (0-based); default: from SLURM_ARRAY_TASK_ID, PBS_ARRAY_INDEX, "
                        "SGE_TASK_ID or LSB_JOBINDEX, else all runs")
    p.add_argument("--jobs", type=_at_least(1), metavar="J",
                   help="local processes (default: all CPUs, or 1 for a task)")
    p.add_argument("--executor", choices=("local", "dask"), default="local",
                   help="local processes (default) or a Dask cluster (needs --scheduler)")
    p.add_argument("--scheduler", metavar="ADDRESS", help="Dask scheduler address, e.g. tcp://10.0.0.1:8786")
    p.set_defaults(func=sweeps.run_command)
    p = actions.add_parser("status", parents=[common], help="done, missing and failed runs (with their errors)")
    p.set_defaults(func=sweeps.status_command)
    p = actions.add_parser("collect", parents=[common],
                           help="one summary table, a row per run, as DIR/<name>/collected.parquet")
    p.set_defaults(func=sweeps.collect_command)


def _add_analyze_commands(commands):
    """``dronefleet analyze sensitivity SWEEP --metric M ...``; the work is in :mod:`dronefleet.analyze`."""
    parser = commands.add_parser("analyze", help="analyses of a sweep's dataset: sensitivity indices of a design",
                                 description="See docs/guide/sweeps.md, section Designs.")
    actions = parser.add_subparsers(dest="action", required=True)
    p = actions.add_parser("sensitivity", help="Sobol' indices (or Morris screening) of a [design] sweep's metrics",
                           description="First-, second- and total-order Sobol' indices of a sobol design, or "
                                       "Morris's mu*, mu and sigma of a morris design, with 95 % bootstrap "
                                       "intervals: printed, written to DIR/<name>/sensitivity.parquet and drawn "
                                       "(DIR/<name>/sensitivity.png, .pdf, .svg).")
    p.add_argument("sweep", help="sweep file (TOML) with a [design], or a shipped sweep file's name")
    p.add_argument("--metric", action="append", required=True, metavar="M",
                   help="a numeric column of the scenario's summary table, e.g. delivered; repeat for more")
    p.add_argument("--results", type=_path, default="results", metavar="DIR",
                   help="results root; the sweep's dataset is DIR/<name>/ (default: results)")
    p.add_argument("--resamples", type=_at_least(10), default=analyze.RESAMPLES, metavar="N",
                   help=f"bootstrap resamples of the intervals (default: {analyze.RESAMPLES})")
    p.set_defaults(func=analyze.command)


def _add_reproduce_command(commands, arguments):
    """``dronefleet reproduce FIGURE``; the work is in :mod:`dronefleet.reproduce`."""
    p = commands.add_parser("reproduce", help="reproduce a figure of the studies (runs what is missing)",
                            description="See results/README.md for what each figure runs and shows.")
    if not arguments:
        return
    from . import reproduce

    studies = reproduce.studies()
    p.add_argument("figure", nargs="+", type=_figure((*reproduce.all_figures(), "all")), metavar="FIGURE",
                   help="one or more figures (reproduce --list shows them), or all (figures asked for together "
                        "share their runs)")
    p.add_argument("--list", action=_ListStudies)
    p.add_argument("--quick", action="store_true",
                   help="a check in seconds, under <out>/quick/: " + ", ".join(
                       f"{name} figures with {study.QUICK}" for name, study in studies.items()))
    p.add_argument("--jobs", type=_at_least(1), metavar="J", help="local processes for the sweeps (default: all CPUs)")
    root = p.add_mutually_exclusive_group()
    root.add_argument("--out", type=lambda text: Path(_path(text)), metavar="DIR",
                      help=f"results root: the sweeps' runs in DIR/<sweep>/, each figure's tables and drawings in "
                           f"DIR/<figure>/ (default: {reproduce.DEFAULT_OUT}; with --check: "
                           f"{reproduce.COMMITTED_RESULTS})")
    root.add_argument("--update-results", action="store_true",
                      help=f"write into the committed {reproduce.COMMITTED_RESULTS}/ (from the repository's root), "
                           "refreshing its figures")
    p.add_argument("--redraw", action="store_true",
                   help="only redraw the figures (PNG, PDF, SVG) from their parquet tables in the results root")
    p.add_argument("--theta", type=float, metavar="N",
                   help="Figure 19's threshold theta (%%), one of its sweep's (default: the one the study's "
                        "criterion picks, most deliveries and shortest delivery time; see results/README.md)")
    p.add_argument("--check", action="store_true",
                   help="re-run a few of the figure's runs (seconds) and compare them with its runs.parquet "
                        f"(default: the committed {reproduce.COMMITTED_RESULTS}/); "
                        "exit 1 and list the differences if any")
    p.set_defaults(func=reproduce.command)


def main(argv: list[str] | None = None) -> int:
    """The ``dronefleet`` command with the arguments ``argv`` (default: the process's); returns the
    exit code: 0 done, 1 failed runs or differences found, 2 bad input, 130 interrupted."""
    argv = sys.argv[1:] if argv is None else argv
    try:
        # within the try: building the parser of reproduce imports pandas and numba (a second)
        args = build_parser(reproduce_arguments="reproduce" in argv).parse_args(argv)
        console.configure(args.level)
        check_numba_cache_dir()  # an environment the kernels cannot be cached in: before any work
        return args.func(args)
    # bad input (config, sweep, fleet file), refused before any work; a scenario's hook that broke its contract
    except (ConfigError, scenarios.HookError) as error:
        print(f"dronefleet: error: {error}", file=sys.stderr)
        return 2
    except KeyboardInterrupt as interrupted:  # Ctrl-C: outputs are complete or absent (see records.write_run)
        # its message, if any, says where (a plugin's import) or what did not stop (dronefleet.interrupt)
        print(f"dronefleet: interrupted{f' {interrupted}' if str(interrupted) else ''}", file=sys.stderr)
        return 130
    except BrokenPipeError:  # the reader of stdout went away (| head): stop quietly
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())  # so the exit flush cannot fail
        return 141


if __name__ == "__main__":
    console.exit_now(main())
