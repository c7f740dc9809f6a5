"""configs/lunar-thesis.toml, the reading of issue 28 item 3 (docs/lunar-readings.md): it loads, differs
from the defaults in exactly the keys it documents, cites the text for each, and runs from the CLI."""

import dataclasses
import re
import tomllib
from pathlib import Path

from dronefleet import cli, scenarios
from dronefleet.lunar import LunarParams

ROOT = Path(__file__).resolve().parents[1]
THESIS = ROOT / "configs" / "lunar-thesis.toml"
SCENARIO = scenarios.SCENARIOS["lunar"]
#: The keys the thesis reading changes, and their values (docs/lunar-readings.md).
CHANGED = {"v0": 0.125, "p_move": 5.8, "experience": "leaving"}


def test_it_loads_and_differs_from_the_defaults_exactly_in_the_documented_keys():
    config = SCENARIO.load(THESIS)
    defaults = LunarParams()
    differ = {f.name: getattr(config, f.name) for f in dataclasses.fields(LunarParams)
              if getattr(config, f.name) != getattr(defaults, f.name)}
    assert differ == CHANGED


def test_every_key_is_written_out_and_each_change_cites_the_text():
    sections = tomllib.loads(THESIS.read_text())
    keys = {key for section in sections.values() if isinstance(section, dict) for key in section}
    assert keys == {f.name for f in dataclasses.fields(LunarParams)}
    lines = THESIS.read_text().splitlines()
    for key in CHANGED:
        start = next(i for i, line in enumerate(lines) if line.startswith(f"{key} ="))
        comment = [lines[start]] + [line for line in lines[start + 1:start + 8] if line.startswith(" ")]
        assert re.search(r"\bL\d{3,4}\b", " ".join(comment)), key
        assert not re.search(r"\bA\d+\b|\bspec\b", " ".join(comment)), key  # the thesis, not what a user cannot open


def test_dronefleet_run_takes_it(tmp_path, capsys):
    out = tmp_path / "run"
    code = cli.main(["run", str(THESIS), "--set", "runs=1", "--set", "n_robots=5", "--set", "duration_s=60",
                     "--out", str(out)])
    printed = capsys.readouterr()
    assert code == 0, printed.err
    assert "v0 0.125 m/s" in printed.out and "experience=leaving" in printed.out
    assert (out / "summary.parquet").is_file()
