"""The twin's long verbs say how long they will take before they start, then show the time
left (issue 26: `twin report`, listed among the quick commands, ran ~14 minutes unannounced).
Run as a person runs them: a process, its stderr played through a terminal."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from tests.terminal import assert_estimate_first, run_in_terminal

pytestmark = pytest.mark.subprocess

REPORT = ["twin", "report", "--duration", "60", "--epochs", "3", "--oracle-samples", "20"]


def spectratac(*args: str) -> subprocess.CompletedProcess[str]:
    run = run_in_terminal([sys.executable, "-m", "spectratac", *args], timeout=900)
    assert run.returncode in (0, 1), run.stderr
    return run


@pytest.mark.train
def test_twin_report_says_its_time_first_and_json_carries_it() -> None:
    run = spectratac(*REPORT)
    line = assert_estimate_first(run.stderr, "twin report")
    assert "generate" in line and "train" in line and "oracle" in line
    assert "measured on this machine" in line
    assert "estimated" not in run.stdout  # the report itself stays on stdout, clean
    rep = json.loads(spectratac(*REPORT, "--json").stdout)
    est = rep["estimate"]
    assert est["total_s"] > 0 and set(est["parts_s"]) == {"generate", "train", "oracle"}
    assert est["rates"]["twin s/scene s"] > 0 and est["calibration_s"] > 0


def test_twin_population_says_its_time_first(tmp_path: Path) -> None:
    out = tmp_path / "pop.npz"
    args = ["twin", "population", "--units", "0,1", "--sessions", "2", "--duration", "30",
            "-o", str(out)]  # fmt: skip
    run = spectratac(*args)
    line = assert_estimate_first(run.stderr, "twin population (4 sessions of 30 s)")
    assert "generate" in line
    summary = json.loads(spectratac(*args, "--force", "--json").stdout)
    assert summary["estimate"]["parts_s"]["generate"] > 0


def test_twin_generate_says_its_time_first(tmp_path: Path) -> None:
    args = ["twin", "generate", "--scene", "calibration", "--duration", "600",
            "-o", str(tmp_path / "s.npz")]  # fmt: skip
    run = spectratac(*args)
    assert_estimate_first(run.stderr, "twin generate (600 s of 'calibration')")
