"""Files are data: reading a run's tables, a sweep's dataset or a saved fleet back never runs code.

A config read back from a file's metadata may name a plugin rule (``auction.rule =
"module:function"``); only a config the user wrote (TOML file, ``--set``, API argument) or an
installed entry point may make dronefleet import it. Here every file names ``evilmod:x``, and an
``evilmod.py`` that would leave a marker file sits in the working directory and on ``sys.path``:
no command that reads the file may import it.
"""

import json
import subprocess
import sys

import pyarrow.parquet as pq
import pytest

from dronefleet import cli
from dronefleet.config import ConfigError
from dronefleet.delivery import config as delivery_config
from dronefleet.delivery.records import read_config
from dronefleet.records import CONFIG_KEY

EVIL_RULE = "evilmod:x"


def tamper(path, rule=EVIL_RULE):
    """Rewrite the parquet file ``path`` with its embedded config's ``auction.rule`` set to ``rule``."""
    table = pq.read_table(path)
    metadata = dict(table.schema.metadata)
    config = json.loads(metadata[CONFIG_KEY])
    config["auction"]["rule"] = rule
    metadata[CONFIG_KEY] = json.dumps(config, sort_keys=True).encode()
    pq.write_table(table.replace_schema_metadata(metadata), path)


@pytest.fixture
def evil(tmp_path, monkeypatch):
    """A working directory holding ``evilmod.py``, which creates ``marker`` when imported; yields the marker."""
    marker = tmp_path / "marker"
    (tmp_path / "evilmod.py").write_text(f"open({str(marker)!r}, 'w').close()\nx = 1\n")
    monkeypatch.chdir(tmp_path)
    monkeypatch.syspath_prepend(str(tmp_path))
    sys.modules.pop("evilmod", None)
    yield marker
    sys.modules.pop("evilmod", None)


@pytest.fixture(scope="module")
def delivery_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("delivery") / "run"
    assert cli.main(["run", "--set", "horizon_weeks=0.05", "--set", "n_uavs=3", "--seed", "1", "--out", str(out),
                     "--save-fleet", str(out.parent / "fleet.parquet")]) == 0
    return out


def _ran_or_refused(code, capsys):
    """The command worked (exit 0) or refused in one line (exit 2); returns what it printed."""
    captured = capsys.readouterr()
    assert code in (0, 2), captured
    if code == 2:
        assert captured.err.startswith("dronefleet: error: ") and captured.err.count("\n") == 1, captured.err
    return captured


def test_a_rule_path_read_from_a_table_is_kept_as_a_name(tmp_path, evil, delivery_run):
    path = tmp_path / "summary.parquet"
    path.write_bytes((delivery_run / "summary.parquet").read_bytes())
    tamper(path)
    assert read_config(path).rule == EVIL_RULE
    assert not evil.exists()


def test_the_same_rule_from_the_user_is_imported(evil):
    # the user's own config may name code: the plugin is loaded (and refused: x is no rule)
    with pytest.raises(ConfigError, match="is a int, not a numba @njit function"):
        delivery_config.config_from_dict({"auction": {"rule": EVIL_RULE}})
    assert evil.exists()


def test_a_malformed_rule_read_from_a_table_is_refused_in_one_line(tmp_path, evil, delivery_run):
    path = tmp_path / "summary.parquet"
    path.write_bytes((delivery_run / "summary.parquet").read_bytes())
    tamper(path, "os.system('touch marker'):x")
    with pytest.raises(ConfigError, match="auction.rule") as error:
        read_config(path)
    assert "\n" not in str(error.value) and not evil.exists()


def test_replay_of_a_tampered_run_folder_imports_nothing(tmp_path, evil, delivery_run, capsys):
    run = tmp_path / "run"
    run.mkdir()
    for table in delivery_run.glob("*.parquet"):
        (run / table.name).write_bytes(table.read_bytes())
        tamper(run / table.name)
    code = cli.main(["replay", str(run), "--out", str(tmp_path / "page.html")])
    _ran_or_refused(code, capsys)
    assert not evil.exists()
    assert code == 0 and EVIL_RULE in (tmp_path / "page.html").read_text()  # shown as the name it is


def test_python_dash_m_dronefleet_replay_of_a_tampered_run_folder_imports_nothing(tmp_path, evil, delivery_run):
    run = tmp_path / "run"
    run.mkdir()
    for table in delivery_run.glob("*.parquet"):
        (run / table.name).write_bytes(table.read_bytes())
        tamper(run / table.name)
    # python -m puts the working directory first on sys.path, where evilmod.py is
    done = subprocess.run([sys.executable, "-m", "dronefleet", "replay", "run", "--out", "page.html"],
                          capture_output=True, text=True, cwd=tmp_path, timeout=600)
    assert done.returncode in (0, 2), done.stderr
    assert not evil.exists()


def test_a_fleet_file_naming_a_rule_path_imports_nothing(tmp_path, evil, delivery_run, capsys):
    fleet = tmp_path / "fleet.parquet"
    fleet.write_bytes((delivery_run.parent / "fleet.parquet").read_bytes())
    tamper(fleet)
    code = cli.main(["run", "--set", "horizon_weeks=0.05", "--set", "n_uavs=3", "--fleet", str(fleet),
                     "--out", str(tmp_path / "warm")])
    _ran_or_refused(code, capsys)
    assert not evil.exists()
    assert code == 0  # the run's rule is the user's config's; the saved one is only compared where it must agree


def test_sweep_status_of_a_tampered_dataset_imports_nothing(tmp_path, evil, capsys):
    sweep = tmp_path / "tiny.toml"
    sweep.write_text('[sweep]\nname = "tiny"\nseeds = [0]\n[set]\nhorizon_weeks = 0.05\nn_uavs = 3\n'
                     '[grid]\ntau_minutes = [15.0]\n')
    assert cli.main(["sweep", "run", str(sweep), "--results", str(tmp_path), "--jobs", "1"]) == 0
    (summary,) = (tmp_path / "tiny" / "summary").rglob("*.parquet")
    tamper(summary)
    capsys.readouterr()
    code = cli.main(["sweep", "status", str(sweep), "--results", str(tmp_path)])
    captured = _ran_or_refused(code, capsys)
    assert not evil.exists()
    assert code == 2 and f"rule {EVIL_RULE!r} vs 'least_confident'" in captured.err
