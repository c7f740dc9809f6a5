"""Where ``dronefleet run`` writes: outputs probed before any work, run folders complete or absent,
``--overwrite``, default folders per config, provenance in every file, ``--version``.

Read-only folders and full disks are simulated by making the write raise the OSError the system
would raise (as root, chmod does not stop writes); folders that are files are real.
"""

import errno
import hashlib
import json
import os
import platform
import re
import signal
import subprocess
import sys
import tempfile
from importlib import metadata
from pathlib import Path

import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

import dronefleet
from dronefleet import cli, provenance, records, reproduce
from dronefleet.delivery import simulation, records as delivery_records
from dronefleet.delivery.config import default_config, load_config, replace

SHORT = ["--set", "horizon_weeks=0.05", "--set", "n_uavs=5"]


def _tree(root):
    """Every path under ``root`` with the SHA-256 of each file: equal trees, nothing written."""
    return {str(p.relative_to(root)): hashlib.sha256(p.read_bytes()).hexdigest() if p.is_file() else None
            for p in sorted(Path(root).rglob("*"))}


def _run(argv, capsys):
    """``cli.main(["run", *argv])``: (exit code, stdout, stderr)."""
    code = cli.main(["run", *argv])
    printed = capsys.readouterr()
    return code, printed.out, printed.err


def _assert_refused(code, err, fragment):
    assert code == 2
    assert fragment in err
    assert err.startswith("dronefleet: error: ") and err.count("\n") == 1, err  # one line
    assert "Traceback" not in err


def _seed_of(run_dir):
    return pq.read_table(Path(run_dir) / "summary.parquet")["seed"][0].as_py()


@pytest.fixture
def no_simulation(monkeypatch):
    """Refusals must come before any work: simulating fails the test."""
    def simulate(*args, **kwargs):
        raise AssertionError("simulated although the outputs are unusable")
    monkeypatch.setattr(simulation, "simulate", simulate)


@pytest.fixture(scope="module")
def old_run(tmp_path_factory):
    """A complete run of seed 1 (the 'older run' that hostile cases must leave untouched)."""
    out = tmp_path_factory.mktemp("old") / "run"
    assert cli.main(["run", *SHORT, "--seed", "1", "--out", str(out)]) == 0
    return out


def _copy_run(source, target):
    target.mkdir(parents=True)
    for path in source.iterdir():
        (target / path.name).write_bytes(path.read_bytes())
    return target


# ---------------------------------------------------------------------------- refused before any work


def _file(root):
    (root / "a-file").write_text("not a folder")


def _other_files(root):
    (root / "run").mkdir()
    (root / "run" / "notes.txt").write_text("mine")


def _part_of_a_run(root):
    (root / "run").mkdir()
    (root / "run" / "orders.parquet").write_bytes(b"left by an older dronefleet")


def _hidden_only(root):
    (root / "run").mkdir()
    (root / "run" / ".DS_Store").write_bytes(b"")


def _save_fleet_folder(root):
    (root / "fleet.parquet").mkdir()


def _save_fleet_exists(root):
    (root / "fleet.parquet").write_bytes(b"an older fleet")


def _save_fleet_fifo(root):
    os.mkfifo(root / "fleet.parquet")


def _sweep_dataset(root):
    (root / "d" / "summary" / "rule=random" / "seed=1").mkdir(parents=True)
    (root / "d" / "_layout.json").write_text('{"keys": ["rule", "seed"], "scenario": "delivery"}')


def _older_dataset(root):  # written before datasets had a layout file: its partitions tell
    (root / "d" / "summary" / "rule=random" / "seed=1").mkdir(parents=True)
    (root / "d" / "summary" / "rule=random" / "seed=1" / "part-0.parquet").write_bytes(b"PAR1")


HOSTILE = [  # (what is already there, run arguments, message fragment)
    # readers take a dataset's folders whole: a run among them would be rows of the sweep
    (_sweep_dataset, ["--out", "{root}/d/summary/rule=greedy"], "lies in the sweep dataset '{root}/d'"),
    (_sweep_dataset, ["--out", "{root}/d/notes/run"], "lies in the sweep dataset '{root}/d'"),
    (_older_dataset, ["--out", "{root}/d/summary/rule=greedy/seed=1"], "lies in the sweep dataset '{root}/d'"),
    (_older_dataset, ["--out", "{root}/d/timeseries/rule=greedy"], "lies in the sweep dataset '{root}/d'"),
    (_file, ["--out", "{root}/a-file"], "is a file; it must be a folder"),
    (_file, ["--out", "{root}/a-file/run"], "Not a directory"),
    (_file, ["--out", "{root}/run", "--save-fleet", "{root}/a-file/fleet.parquet"], "Not a directory"),
    (_other_files, ["--out", "{root}/run"], "holds files other than a run's tables; choose another --out"),
    (_other_files, ["--out", "{root}/run", "--overwrite"], "holds files other than a run's tables"),
    (_part_of_a_run, ["--out", "{root}/run"], "exists and holds part of a run; pass --overwrite"),
    (_hidden_only, ["--out", "{root}/run", "--overwrite"], "holds files other than a run's tables"),
    (_save_fleet_folder, ["--out", "{root}/run", "--save-fleet", "{root}/fleet.parquet"], "is a folder"),
    (_save_fleet_exists, ["--out", "{root}/run", "--save-fleet", "{root}/fleet.parquet"],
     "exists; pass --overwrite to replace it or choose another --save-fleet"),
    # --overwrite replaces a fleet file, never a special one with a regular file
    (_save_fleet_fifo, ["--out", "{root}/run", "--save-fleet", "{root}/fleet.parquet", "--overwrite"],
     "--save-fleet '{root}/fleet.parquet' is a named pipe (FIFO), which writing would replace with a regular file"),
    (None, ["--out", ".."], "must name a folder of its own"),
    (None, ["--out", "/"], "must name a folder of its own"),
]


@pytest.mark.parametrize("prepare, argv, fragment", HOSTILE)
def test_unusable_outputs_are_refused_before_any_work(tmp_path, capsys, no_simulation, prepare, argv, fragment):
    if prepare is not None:
        prepare(tmp_path)
    before = _tree(tmp_path)
    code, out, err = _run([*SHORT, *(a.format(root=tmp_path) for a in argv)], capsys)
    _assert_refused(code, err, fragment.format(root=tmp_path))
    assert out == ""
    assert _tree(tmp_path) == before


def test_a_complete_run_is_not_replaced_without_overwrite(old_run, tmp_path, capsys, no_simulation):
    out = _copy_run(old_run, tmp_path / "run")
    before = _tree(tmp_path)
    code, _, err = _run([*SHORT, "--seed", "2", "--out", str(out)], capsys)
    _assert_refused(code, err, f"{out} exists and holds a complete run; pass --overwrite to replace it "
                               "or choose another --out")
    assert _tree(tmp_path) == before


@pytest.mark.parametrize("where, error", [
    ("mkdir", PermissionError(errno.EACCES, "Permission denied")),
    ("mkdtemp", OSError(errno.EROFS, "Read-only file system")),
    ("mkdtemp", OSError(errno.ENOSPC, "No space left on device")),
])
def test_an_unwritable_output_folder_is_refused_before_any_work(tmp_path, capsys, monkeypatch, no_simulation,
                                                                  where, error):
    def fail(*args, **kwargs):
        raise error
    monkeypatch.setattr(*{"mkdir": (Path, "mkdir"), "mkdtemp": (tempfile, "mkdtemp")}[where], fail)
    code, out, err = _run([*SHORT, "--out", str(tmp_path / "new" / "run")], capsys)
    _assert_refused(code, err, error.strerror)
    assert out == "" and list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("argv, fragment", [
    (["--seed", "x"], "invalid int value"),
    (["--seed", "1.5"], "invalid int value"),
    (["--overwrite=yes"], "ignored explicit argument"),
])
def test_bad_arguments_end_with_exit_code_2(tmp_path, capsys, argv, fragment):
    with pytest.raises(SystemExit) as exit_:
        cli.main(["run", *argv, "--out", str(tmp_path / "run")])
    assert exit_.value.code == 2
    err = capsys.readouterr().err
    assert fragment in err and "Traceback" not in err
    assert err.splitlines()[-1].startswith("dronefleet run: error: ")
    assert list(tmp_path.iterdir()) == []


# ---------------------------------------------------------------------------- failures while writing


def _failing_after(monkeypatch, calls, error):
    """Make pq.write_table raise ``error`` after ``calls`` good calls (a disk that fills up)."""
    real, done = pq.write_table, []

    def write(*args, **kwargs):
        if len(done) == calls:
            raise error
        done.append(args[1])
        return real(*args, **kwargs)
    monkeypatch.setattr(pq, "write_table", write)
    return done


@pytest.mark.parametrize("existing", [False, True])
@pytest.mark.parametrize("calls, error", [
    (0, OSError(errno.EROFS, "Read-only file system")),
    (2, OSError(errno.ENOSPC, "No space left on device")),
    (4, OSError(errno.EIO, "Input/output error")),
])
def test_a_failed_write_leaves_the_folder_as_it_was(old_run, tmp_path, capsys, monkeypatch, existing, calls, error):
    out = _copy_run(old_run, tmp_path / "run") if existing else tmp_path / "run"
    before = _tree(tmp_path)
    done = _failing_after(monkeypatch, calls, error)
    code, _, err = _run([*SHORT, "--seed", "2", "--out", str(out), *(["--overwrite"] if existing else [])], capsys)
    _assert_refused(code, err, f"cannot write {str(out)!r}: {error.strerror}")
    assert len(done) == calls
    assert _tree(tmp_path) == before  # the old run, or nothing; no hidden temporary


def test_a_failed_fleet_save_leaves_no_fleet_file_and_no_run(tmp_path, capsys, monkeypatch):
    # The fleet file is written first, so a disk that is full then leaves neither output.
    _failing_after(monkeypatch, 0, OSError(errno.ENOSPC, "No space left on device"))
    fleet = tmp_path / "fleets" / "fleet.parquet"
    code, _, err = _run([*SHORT, "--out", str(tmp_path / "run"), "--save-fleet", str(fleet)], capsys)
    _assert_refused(code, err, f"cannot write {str(fleet)!r}: No space left on device")
    assert list(fleet.parent.iterdir()) == []
    assert not (tmp_path / "run").exists()


def test_a_failed_run_write_after_the_fleet_removes_the_fleet_file(tmp_path, capsys, monkeypatch):
    _failing_after(monkeypatch, 2, OSError(errno.ENOSPC, "No space left on device"))  # fleet, 1 table, full
    fleet = tmp_path / "fleets" / "fleet.parquet"
    code, _, err = _run([*SHORT, "--out", str(tmp_path / "run"), "--save-fleet", str(fleet)], capsys)
    _assert_refused(code, err, "No space left on device")
    assert list(fleet.parent.iterdir()) == [] and not (tmp_path / "run").exists()


# ---------------------------------------------------------------------------- --overwrite, SIGKILL


@pytest.mark.parametrize("partial", [False, True])
def test_overwrite_replaces_a_run_and_leaves_nothing_beside_it(old_run, tmp_path, capsys, partial):
    out = _copy_run(old_run, tmp_path / "run")
    if partial:  # as an older dronefleet left an interrupted run
        (out / "summary.parquet").unlink()
    (tmp_path / "fleet.parquet").write_bytes(b"an older fleet")
    code, _, _ = _run([*SHORT, "--seed", "2", "--out", str(out), "--overwrite",
                       "--save-fleet", str(tmp_path / "fleet.parquet")], capsys)
    assert code == 0
    assert _seed_of(out) == 2 and delivery_records.read_config(tmp_path / "fleet.parquet").seed == 2
    assert sorted(p.name for p in tmp_path.iterdir()) == ["fleet.parquet", "run"]
    assert records.run_dir_state(out, delivery_records.TABLES) == "complete"


# Run in a subprocess: dies by SIGKILL at a chosen point of writing the run folder.
KILLED_RUN = """
import os, signal, sys
from dronefleet import cli, records
point, argv = sys.argv[1], sys.argv[2:]
out = os.path.abspath(argv[argv.index("--out") + 1])
die = lambda: os.kill(os.getpid(), signal.SIGKILL)
write_table, replace, written = records.write_table, os.replace, []

def write_two(*args, **kwargs):  # point "tables": two of the tables written, in the temporary folder
    written.append(write_table(*args, **kwargs))
    if len(written) == 2:
        die()
    return written[-1]

def rename(src, dst):  # "aside": the old run moved aside, the new one not in; "swapped": new in, old not deleted
    replace(src, dst)
    if os.path.abspath({"aside": src, "swapped": dst}[point]) == out:
        die()

if point == "tables":
    records.write_table = write_two
else:
    os.replace = rename
sys.exit(cli.main(argv))
"""


@pytest.mark.parametrize("point, survivor", [("tables", 1), ("aside", 1), ("swapped", 2)])
def test_a_run_killed_while_writing_leaves_a_complete_run(old_run, tmp_path, capsys, point, survivor):
    out = _copy_run(old_run, tmp_path / "run")
    old = _tree(out)
    env = {**os.environ, "PYTHONPATH": str(Path(dronefleet.__file__).parent.parent)}
    killed = subprocess.run([sys.executable, "-c", KILLED_RUN, point, "run", *SHORT, "--seed", "2",
                             "--out", str(out), "--overwrite"], env=env, capture_output=True, text=True, timeout=600)
    assert killed.returncode == -signal.SIGKILL, killed.stderr
    # What the kill left: the old run or the new one, complete, or (between the two renames)
    # the old one aside; at most hidden leftovers beside it.
    assert [p.name for p in tmp_path.iterdir() if not p.name.startswith(".")] == (["run"] if point != "aside" else [])
    # The next run into the folder first cleans up (putting an old run aside back), then refuses.
    code, _, err = _run([*SHORT, "--seed", "3", "--out", str(out)], capsys)
    _assert_refused(code, err, "holds a complete run; pass --overwrite")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run"]
    assert records.run_dir_state(out, delivery_records.TABLES) == "complete" and _seed_of(out) == survivor
    if survivor == 1:
        assert _tree(out) == old


# ---------------------------------------------------------------------------- default folders


def test_default_folders_differ_when_the_resolved_config_differs():
    base = default_config()
    folders = {cli.default_out("paper", c) for c in (
        base, replace(base, tau_minutes=20.0), replace(base, seed=1), replace(base, fleet_file="f.parquet"))}
    assert len(folders) == 4
    for folder in folders:
        assert re.fullmatch(r"results/runs/paper-seed[01]-[0-9a-f]{8}", folder.as_posix())
    # The same config however it was spelled: the same folder.
    assert cli.default_out("paper", load_config(None, ["orders.tau_minutes=20"])) == \
        cli.default_out("paper", replace(base, tau_minutes=20.0))


def test_run_with_set_does_not_write_over_the_plain_run(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert _run(SHORT, capsys)[0] == 0
    assert _run([*SHORT, "--set", "tau_minutes=20"], capsys)[0] == 0
    folders = sorted((tmp_path / "results" / "runs").iterdir())
    assert len(folders) == 2
    assert {delivery_records.read_config(f / "summary.parquet").tau_minutes for f in folders} == {15.0, 20.0}
    code, _, err = _run(SHORT, capsys)  # the same config again: refused, not overwritten
    _assert_refused(code, err, "holds a complete run")


# ---------------------------------------------------------------------------- provenance, --version


def _expected_provenance():
    return {"dronefleet": dronefleet.__version__, "python": platform.python_version(),
            "git_commit": provenance.commit_of(Path(dronefleet.__file__).parent.parent),
            **{name: metadata.version(name) for name in ("numpy", "numba", "scikit-learn", "pyarrow")}}


def test_every_file_of_a_run_and_a_saved_fleet_records_its_provenance(tmp_path, capsys):
    import numba
    import numpy
    import sklearn

    expected = _expected_provenance()
    assert (expected["numpy"], expected["numba"], expected["scikit-learn"], expected["pyarrow"]) == (
        numpy.__version__, numba.__version__, sklearn.__version__, pa.__version__)
    assert _run([*SHORT, "--out", str(tmp_path / "run"), "--save-fleet", str(tmp_path / "fleet.parquet")],
                capsys)[0] == 0
    files = [*(tmp_path / "run").iterdir(), tmp_path / "fleet.parquet"]
    assert len(files) == len(delivery_records.TABLES) + 1
    for path in files:
        meta = pq.read_schema(path).metadata
        assert json.loads(meta[provenance.KEY]) == expected, path.name
        assert meta[provenance.VERSION_KEY] == dronefleet.__version__.encode()
        assert delivery_records.read_config(path).n_uavs == 5  # the config is still there


def test_provenance_leaves_the_data_and_other_metadata_alone(tmp_path):
    table = pa.table({"x": [1.5, 2.5]}).replace_schema_metadata({b"mine": b"kept"})
    stamped = provenance.stamp(table)
    assert stamped.equals(table) and stamped.schema.metadata[b"mine"] == b"kept"
    # The figure tables of `reproduce` carry it too, beside pandas' own metadata.
    path = reproduce._write_parquet(pd.DataFrame({"x": [1.5, 2.5]}), tmp_path / "t.parquet")
    meta = pq.read_schema(path).metadata
    assert json.loads(meta[provenance.KEY]) == _expected_provenance() and b"pandas" in meta


def _git(repo, *args):
    subprocess.run(["git", "-C", str(repo), "-c", "user.name=t", "-c", "user.email=t@t", *args], check=True,
                   capture_output=True)


def test_the_commit_is_that_of_a_checkout_whose_top_holds_the_package(tmp_path):
    (tmp_path / "pkg").mkdir()
    assert provenance.commit_of(tmp_path / "pkg") is None  # not a checkout
    try:
        _git(tmp_path, "init", "-q")
    except FileNotFoundError:  # no git here: then no commit, and no error
        assert provenance.commit_of(tmp_path) is None
        return
    (tmp_path / "pkg" / "a.py").write_text("x = 1\n")
    _git(tmp_path, "add", "-A")
    _git(tmp_path, "commit", "-qm", "one")
    head = subprocess.run(["git", "-C", str(tmp_path), "rev-parse", "HEAD"], capture_output=True,
                          text=True).stdout.strip()
    assert provenance.commit_of(tmp_path) == head
    assert provenance.commit_of(tmp_path / "pkg") is None  # inside someone else's checkout
    (tmp_path / "untracked.txt").write_text("ignored")
    assert provenance.commit_of(tmp_path) == head
    (tmp_path / "pkg" / "a.py").write_text("x = 2\n")
    assert provenance.commit_of(tmp_path) == head + "-dirty"


@pytest.mark.parametrize("error", [FileNotFoundError(errno.ENOENT, "No such file", "git"),
                                   subprocess.TimeoutExpired("git", provenance.GIT_TIMEOUT_S)])
def test_a_missing_or_hanging_git_gives_no_commit(tmp_path, monkeypatch, error):
    def run(*args, **kwargs):
        assert kwargs["timeout"] == provenance.GIT_TIMEOUT_S
        raise error
    monkeypatch.setattr(subprocess, "run", run)
    assert provenance.commit_of(Path(dronefleet.__file__).parent.parent) is None


def test_version_and_help_exit_0_without_loading_the_engine():
    env = {**os.environ, "PYTHONPATH": str(Path(dronefleet.__file__).parent.parent)}
    code = ("import sys; from dronefleet import cli\n"
            "try:\n    cli.main(sys.argv[1:])\nexcept SystemExit as e:\n"
            "    print(e.code, sorted({'numpy', 'pandas', 'numba', 'pyarrow'} & set(sys.modules)))")
    printed = {flag: subprocess.run([sys.executable, "-c", code, flag], env=env, capture_output=True, text=True,
                                    timeout=60).stdout.splitlines() for flag in ("--version", "--help")}
    for flag, lines in printed.items():
        assert lines[-1] == "0 []", (flag, lines)  # exit code 0, none of the heavy libraries imported
    commit = provenance.commit_of(Path(dronefleet.__file__).parent.parent)
    assert printed["--version"][0] == f"dronefleet {dronefleet.__version__}" + (f" (commit {commit})" if commit else "")
    assert any("--version" in line for line in printed["--help"]) and any("reproduce" in line
                                                                           for line in printed["--help"])
