"""The firmware benchmark runs and reports its figures (no timing is asserted)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path


def test_firmware_bench_json(repo: Path, native_build: object) -> None:
    out = subprocess.run(
        [sys.executable, "tools/bench/firmware.py", "--json", "--no-image"],
        cwd=repo,
        capture_output=True,
        text=True,
        check=True,
        timeout=600,
    ).stdout
    figures = {f["name"]: f for f in map(json.loads, out.splitlines())}
    encode = next(f for name, f in figures.items() if name.startswith("SAMPLE frame encode"))
    assert encode["value"] > 0 and encode["reference_value"] > 0
    latency = figures["integration end -> frame to UART"]
    assert latency["extra"]["passes"] == 1 and latency["value"] > 0
