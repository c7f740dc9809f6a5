"""Progress as a user sees it on a terminal: ``dronefleet`` run in a pseudo-terminal, its screen read.

A sweep's bar counts what its runs hold (two configurations of three lunar runs: 6 runs), and
while numba compiles the notice stands alone: the bar is drawn after it, never as a 0 % bar
with the notice printed under it, and is cleared when done.
"""

import fcntl  # a pseudo-terminal: POSIX, as the CI machines are
import os
import pty
import struct
import subprocess
import sys
import termios



def on_terminal(args, cwd, env=None):
    """``python -m dronefleet ARGS`` with a pseudo-terminal as stdout and stderr: (exit code, all it wrote)."""
    leader, follower = pty.openpty()
    fcntl.ioctl(follower, termios.TIOCSWINSZ, struct.pack("HHHH", 24, 120, 0, 0))  # 24 lines of 120 columns
    process = subprocess.Popen([sys.executable, "-m", "dronefleet", *args], cwd=cwd, stdout=follower,
                               stderr=follower, stdin=subprocess.DEVNULL, env={**os.environ, **(env or {})})
    os.close(follower)
    screen = b""
    while True:
        try:
            chunk = os.read(leader, 4096)
        except OSError:  # the process closed the terminal
            break
        if not chunk:
            break
        screen += chunk
    os.close(leader)
    return process.wait(timeout=900), screen.decode(errors="replace")


def test_a_sweeps_bar_counts_the_lunar_runs_its_configurations_hold(tmp_path):
    (tmp_path / "tiny.toml").write_text('[sweep]\nname = "tiny"\nscenario = "lunar"\n[set]\nruns = 3\n'
                                        'n_robots = 5\nduration_s = 20.0\n[grid]\nlayout = ["OPEN", "SOFT-RT"]\n')
    code, screen = on_terminal(["sweep", "run", "tiny.toml", "--jobs", "1"], tmp_path)
    assert code == 0, screen
    assert "2 layout x 1 seed = 2 runs" in screen
    # lunar runs, not the 2 configurations (sweep runs), drawn from the first progress on, then cleared
    assert "  runs:  50%" in screen and "3/6 [" in screen and "/2 [" not in screen and "0/6 [" not in screen
    assert screen.rstrip("\x1b[0m").endswith("dataset results/tiny\r\n") and "\r" + " " * 100 in screen


def test_the_compile_notice_stands_alone_and_the_bar_comes_after_it(tmp_path):
    code, screen = on_terminal(["run", "--set", "horizon_weeks=0.05", "--set", "n_uavs=3", "--out", "run"], tmp_path,
                               env={"NUMBA_CACHE_DIR": str(tmp_path / "cache")})  # an empty cache: it compiles
    assert code == 0, screen
    notice = screen.index("compiling the delivery engine")
    assert "%|" not in screen[:notice]  # no bar at 0 % above the notice
    assert screen.index("delivered") > notice
