"""The protocol benchmark runs end to end and reports its figures (no timing is asserted)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path


def test_protocol_bench_json(repo: Path) -> None:
    out = subprocess.run(
        [
            sys.executable,
            "tools/bench/protocol.py",
            "--frames",
            "3000",
            "--corrupt",
            "20000",
            "--json",
        ],
        cwd=repo,
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    figures = {f["name"]: f for f in map(json.loads, out.splitlines())}
    assert set(figures) >= {"incremental decoder", "bulk decoder", "false accepts"}
    assert figures["false accepts"]["value"] == 0
    assert figures["false accepts"]["extra"]["decoder"]["dropped"] >= 20000
    for f in figures.values():
        assert f["ratio"] == f["value"] / f["reference_value"]
