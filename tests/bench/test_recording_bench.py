"""The recording benchmark runs end to end on a small scale (no timing is asserted)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path


def test_recording_bench_json(repo: Path) -> None:
    out = subprocess.run(
        [
            sys.executable,
            "tools/bench/recording.py",
            "--samples",
            "2000",
            "--ft-rate",
            "100",
            "--rounds",
            "1",
            "--live-samples",
            "100",
            "--json",
        ],
        cwd=repo,
        capture_output=True,
        text=True,
        check=True,
        timeout=300,
    ).stdout
    figures = {f["name"]: f for f in map(json.loads, out.splitlines())}
    assert set(figures) == {"recorder write", "dataset build", "live record, speed=max"}
    build = figures["dataset build"]
    assert build["extra"]["samples"] == 2000 and build["extra"]["ft_samples"] >= 100 * 99
    assert build["value"] > 0 and build["reference_value"] > 0 and build["ratio"] > 0
    assert figures["live record, speed=max"]["extra"]["lost"] == 0
