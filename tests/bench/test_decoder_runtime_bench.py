"""The decoder runtime benchmark runs end to end on a small scale (no timing is asserted)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path


def test_decoder_runtime_bench_json(repo: Path) -> None:
    out = subprocess.run(
        [
            sys.executable,
            "tools/bench/decoder_runtime.py",
            "--calls",
            "200",
            "--samples",
            "1000",
            "--epochs",
            "1",
            "--json",
        ],
        cwd=repo,
        capture_output=True,
        text=True,
        check=True,
        timeout=600,
    ).stdout
    figures = {f["name"]: f for f in map(json.loads, out.splitlines())}
    p99 = figures["paper decoder single sample p99 (NumPy)"]
    assert p99["extra"]["torch_imported"] is False and p99["extra"]["params"] == 106_383
    assert p99["value"] > 0 and p99["reference_value"] > 0
    train = figures["paper recipe training, 1000 samples x 1 epochs"]
    assert train["extra"]["samples"] == 1000 and train["ratio"] > 0
