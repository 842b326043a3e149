"""The device verbs from the shell, including the conformance suite over a served pty."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest
from spectratac.cli import main
from spectratac.cli.exit_codes import ExitCode
from spectratac.conformance import CHECKS, MODEL_CHECKS

from .conftest import Served

pytestmark = pytest.mark.subprocess

SIM = "sim://?scene=tour&seed=1&speed=max"


def spectratac(*args: str, timeout: float = 120) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "spectratac", *args], capture_output=True, text=True, timeout=timeout
    )


def test_info_json(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["info", SIM, "--json"]) == ExitCode.OK
    info = json.loads(capsys.readouterr().out)
    assert info["board"] == "native-sim" and info["sensors_present"] == [0, 1, 2]
    assert "CAP_SIMULATED" in info["capabilities"]
    # The simulator has no cycle counter: it says so instead of a number.
    assert info["cycles"] == {"measured": False, "why": "no cycle counter"}


def test_info_says_cycle_counts_are_not_measured(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["info", SIM]) == ExitCode.OK
    out = capsys.readouterr().out
    assert "cycle counts     not measured (the device has no cycle counter)" in out
    assert "protocol 1.2" in out


def test_stream_formats(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["stream", SIM, "--count", "5", "--format", "jsonl"]) == ExitCode.OK
    rows = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    assert [r["seq"] for r in rows] == [0, 1, 2, 3, 4] and len(rows[0]["status"]) == 3
    assert main(["stream", SIM, "--count", "3", "--format", "csv"]) == ExitCode.OK
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].startswith("seq,t_ms,step,s0R") and len(lines) == 4


def test_stream_missing_port_exit_code(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["stream", "/dev/ttyNOPE"]) == ExitCode.ERROR
    assert "no device at" in capsys.readouterr().err


def test_conformance_over_pty(pty_device: Served) -> None:
    done = spectratac("conformance", pty_device.url, "--json")
    report = json.loads(done.stdout.splitlines()[-1])
    failed = [c for c in report["checks"] if not c["passed"]]
    assert done.returncode == 0 and report["passed"], failed
    # the 1.0 checks, then the on-device decoding ones (the simulator reports CAP_ESTIMATE and
    # CAP_MODEL_UPLOAD); "model survives a reset" reopens the pty
    assert len(report["checks"]) == len(CHECKS) + len(MODEL_CHECKS)


def test_conformance_on_a_missing_device_is_an_error_not_a_failed_check() -> None:
    done = spectratac("conformance", "/dev/ttyNOPE")
    assert done.returncode == ExitCode.ERROR and "no device at" in done.stderr
