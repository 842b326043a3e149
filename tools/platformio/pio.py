"""Run PlatformIO for this checkout without ever touching the registry.

Sets PLATFORMIO_CORE_DIR to build/pio-core (prepared by setup_offline.py) and turns off
telemetry and update checks, then runs the venv's `pio` with the given arguments.

    python tools/platformio/pio.py run -e blackpill
    python tools/platformio/pio.py run -e native -t exec
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from setup_offline import REPO, environment


def pio_executable() -> str:
    exe = Path(sys.executable).parent / "pio"
    return str(exe) if exe.exists() else "pio"


def run(args: list[str], timeout: float | None = None) -> subprocess.CompletedProcess[str]:
    """Run pio in the repository root and capture its output (text)."""
    env = {**os.environ, **environment()}
    return subprocess.run(
        [pio_executable(), *args], cwd=REPO, env=env, capture_output=True, text=True,
        timeout=timeout, check=False,
    )


def main() -> int:
    env = {**os.environ, **environment()}
    return subprocess.call([pio_executable(), *sys.argv[1:]], cwd=REPO, env=env)


if __name__ == "__main__":
    sys.exit(main())
