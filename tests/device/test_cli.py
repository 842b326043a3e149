"""The device verbs from the shell, including the conformance suite over a served pty."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest
from spectratac.cli import main
from spectratac.cli.exit_codes import ExitCode
from spectratac.conformance import CHECKS, MODEL_CHECKS
from spectratac.protocol.generated import messages as m

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
    assert f"protocol 1.{m.PROTOCOL_MINOR}" in out


def test_stream_formats(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["stream", SIM, "--count", "5", "--format", "jsonl"]) == ExitCode.OK
    rows = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    assert [r["seq"] for r in rows] == [0, 1, 2, 3, 4] and len(rows[0]["status"]) == 3
    assert main(["stream", SIM, "--count", "3", "--format", "csv"]) == ExitCode.OK
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].startswith("seq,t_ms,host_ms,step,s0R") and len(lines) == 4


def test_stream_times_are_the_sensors_with_the_hosts_beside(
    capsys: pytest.CaptureFixture[str],
) -> None:
    """t_ms steps by the integration window on the sensor's clock at any speed; host_ms is
    the arrival (a speed=10 simulation delivers them ten times faster)."""
    url = "sim://?scene=idle&speed=10"
    assert main(["stream", url, "--count", "12", "--format", "jsonl"]) == ExitCode.OK
    rows = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    t = [r["t_ms"] for r in rows]
    assert set(np.diff(t).tolist()) == {50}
    assert rows[0]["host_ms"] == 0.0 and rows[-1]["host_ms"] < t[-1] - t[0]


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


def test_info_prints_a_board_s_own_cycle_counts(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """A board with a cycle counter (DWT at 96 MHz): its figures in cycles and ms, as a person
    reads them and in --json. The simulator has no counter, so its STATUS is replaced here by
    one a board sends."""
    from spectratac.device import Sensor
    from spectratac.protocol.generated import messages as m

    board = m.Status(
        cycle_hz=96_000_000,
        acq_cycles_last=230_400,
        acq_cycles_max=288_000,
        decode_cycles_last=940_800,
        decode_cycles_max=960_000,
    )
    monkeypatch.setattr(Sensor, "status", lambda self: board)
    assert main(["info", SIM]) == ExitCode.OK
    out = capsys.readouterr().out
    assert (
        "acquisition      230,400 cycles a sample (2.400 ms at 96 MHz), max 288,000 (3.000 ms)"
        in out
    )
    assert "decoding         940,800 cycles a decode (9.800 ms), max 960,000 (10.000 ms)" in out
    assert main(["info", SIM, "--json"]) == ExitCode.OK
    cycles = json.loads(capsys.readouterr().out)["cycles"]
    assert cycles["measured"] and cycles["decode"]["last_ms"] == pytest.approx(9.8)
