"""A process a test starts and never stops does not outlive the run: tests/conftest.py kills
whatever is left when a test process ends (serially, and in each pytest-xdist worker) and names
it in the summary."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

pytestmark = pytest.mark.subprocess  # runs pytest itself

REPO = Path(__file__).resolve().parents[2]
LEAKY_TEST = """
import subprocess, sys
from pathlib import Path

def test_starts_a_server_and_forgets_it():
    sleeper = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(900)"])
    Path({pidfile!r}).write_text(str(sleeper.pid))
"""


def alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (OSError, IndexError):
        return False
    return state != "Z"


@pytest.mark.parametrize("workers", ["0", "1"])
def test_a_process_left_by_a_test_is_killed_and_named(tmp_path: Path, workers: str) -> None:
    pidfile = tmp_path / "pid"
    test = tmp_path / "test_leaky.py"
    test.write_text(LEAKY_TEST.format(pidfile=str(pidfile)))
    run = subprocess.run(
        [sys.executable, "-m", "pytest", "-p", "tests.conftest", "-p", "no:cacheprovider",
         "-n", workers, str(test)],
        cwd=REPO, capture_output=True, text=True, timeout=600,
    )  # fmt: skip
    pid = int(pidfile.read_text())
    try:
        assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-3000:]
        deadline = time.monotonic() + 30  # generous: SIGKILL is delivered at once
        while alive(pid) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert not alive(pid), f"pid {pid} outlived the pytest run that started it"
        assert "processes left running by the tests (killed)" in run.stdout, run.stdout[-3000:]
        assert f"pid {pid}: " in run.stdout and "time.sleep(900)" in run.stdout
    finally:
        if alive(pid):
            os.kill(pid, 9)
