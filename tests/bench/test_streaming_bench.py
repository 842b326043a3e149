"""The streaming benchmark runs end to end on a small scale (no timing is asserted)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path


def test_streaming_bench_json(repo: Path) -> None:
    out = subprocess.run(
        [
            sys.executable,
            "tools/bench/streaming.py",
            "--frames",
            "50",
            "--samples",
            "200",
            "--devices",
            "2",
            "--seconds",
            "1",
            "--rounds",
            "1",
            "--json",
        ],
        cwd=repo,
        capture_output=True,
        text=True,
        check=True,
        timeout=300,
    ).stdout
    figures = {f["name"]: f for f in map(json.loads, out.splitlines())}
    assert figures["frame-to-user latency p99"]["extra"]["frames"] == 50
    assert figures["samples/s at speed=max"]["extra"]["lost"] == 0
    cpu = figures["CPU, 2 devices at 20 Hz"]
    assert cpu["extra"]["samples"] >= 0.8 * cpu["extra"]["expected"]
    assert cpu["reference_name"] == "raw reads, one selector thread"
    assert cpu["extra"]["raw_bytes"] > 0  # the reference really read the devices' streams
