"""Every shell command of the README runs as written, in order, in a fresh copy of the repository.

A user pastes the README's ```bash blocks one after the other; a command that only works alone
(an output folder an earlier command already made, a stray line) fails them. The commands run
with this test's environment first on PATH. The only change made to them: the Quickstart's
set-up (creating ``.venv`` and installing into it), which this environment already did.
"""

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

#: The Quickstart's two commands, as the README and .ci/run write them, and what runs instead:
#: the same command without the set-up. The second runs the whole suite, this test among it, so
#: here it only collects it (pytest finds the suite from the repository root).
QUICKSTART = {
    "python3 -m venv .venv && .venv/bin/pip install -e . && .venv/bin/dronefleet run": "dronefleet run",
    "python3 -m venv .venv && .venv/bin/pip install -e '.[test]' && .venv/bin/pytest":
        "pytest --collect-only -q tests/test_docs.py",
}


def shell_commands(markdown):
    """The commands of the ```bash and ```sh blocks of ``markdown``, in order: one per line, a
    line ending in a backslash joined with the next, comment-only and blank lines left out."""
    commands = []
    for block in re.findall(r"^```(?:bash|sh)\n(.*?)^```", markdown, re.MULTILINE | re.DOTALL):
        for command in block.replace("\\\n", " ").splitlines():
            if command.strip() and not command.lstrip().startswith("#"):
                commands.append(command.strip())
    return commands


def test_shell_commands_are_found_in_order_and_joined():
    text = "```bash\n# set up\na --x\nb \\\n  --y\n```\n```python\nnot = 1\n```\n```sh\nc\n```\n"
    assert shell_commands(text) == ["a --x", "b    --y", "c"]


def test_the_readme_is_short():
    # A page to start from; the rest is the user guide (docs/guide/).
    assert len((ROOT / "README.md").read_text(encoding="utf-8").splitlines()) < 250


def test_the_quickstart_is_what_ci_runs():
    commands = shell_commands((ROOT / "README.md").read_text(encoding="utf-8"))
    assert commands[:2] == list(QUICKSTART)
    ci = (ROOT / ".ci" / "run").read_text(encoding="utf-8")
    assert all(command in ci for command in QUICKSTART)  # verbatim, as a fresh clone runs them


def fresh_copy(folder):
    """The repository's committed files (a fresh clone) copied into ``folder``: from git when it is
    a checkout, else the tree without virtual environments, caches and outputs."""
    listed = subprocess.run(["git", "-C", str(ROOT), "ls-files", "-z"], capture_output=True, check=False)
    if listed.returncode == 0 and listed.stdout:
        for name in listed.stdout.decode().split("\0"):
            if name and (ROOT / name).is_file():
                (folder / name).parent.mkdir(parents=True, exist_ok=True)
                shutil.copy2(ROOT / name, folder / name)
    else:
        shutil.copytree(ROOT, folder, dirs_exist_ok=True, ignore=shutil.ignore_patterns(
            ".venv*", ".git", "__pycache__", ".pytest_cache", "*.egg-info", "dronefleet-results", "runs"))
    return folder


def test_every_shell_command_of_the_readme_runs_in_order(tmp_path):
    clone = fresh_copy(tmp_path / "clone")
    commands = [QUICKSTART.get(command, command)
                for command in shell_commands((ROOT / "README.md").read_text(encoding="utf-8"))]
    env = {**os.environ, "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ.get('PATH', '')}"}
    failed = []
    for command in commands:
        done = subprocess.run(["bash", "-c", command], cwd=clone, env=env, capture_output=True, text=True,
                              timeout=600, check=False)
        if done.returncode != 0:
            failed.append(f"{command}\n  exit {done.returncode}: {done.stderr.strip()[-500:]}")
    assert not failed, "\n".join(failed)
