"""Run PlatformIO for this checkout without ever touching the registry.

Sets PLATFORMIO_CORE_DIR to build/pio-core (prepared by setup_offline.py) and turns off
telemetry and update checks, then runs the venv's `pio` with the given arguments.

    python -m tools.platformio.pio run -e blackpill
    python -m tools.platformio.pio run -e native -t exec

One pio at a time per checkout (an advisory lock on build/pio.lock): every environment shares
the core directory and build/pio, and two runs of one environment at once (pytest-xdist workers)
would compile into the same object files.
"""

from __future__ import annotations

import contextlib
import fcntl
import os
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

from .setup_offline import REPO, environment

LOCK = REPO / "build" / "pio.lock"


def pio_executable() -> str:
    exe = Path(sys.executable).parent / "pio"
    return str(exe) if exe.exists() else "pio"


def run(args: list[str], timeout: float | None = None) -> subprocess.CompletedProcess[str]:
    """Run pio in the repository root and capture its output (text)."""
    with exclusive():
        env = {**os.environ, **environment()}
        return subprocess.run(
            [pio_executable(), *args],
            cwd=REPO,
            env=env,
            capture_output=True,
            text=True,
            timeout=timeout,
            check=False,
        )


def main() -> int:
    with exclusive():
        env = {**os.environ, **environment()}
        return subprocess.call([pio_executable(), *sys.argv[1:]], cwd=REPO, env=env)


@contextlib.contextmanager
def exclusive() -> Iterator[None]:
    """Wait until no other pio of this checkout runs, and hold that for the block."""
    LOCK.parent.mkdir(parents=True, exist_ok=True)
    with open(LOCK, "a") as handle:
        fcntl.flock(handle, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)


if __name__ == "__main__":
    sys.exit(main())
