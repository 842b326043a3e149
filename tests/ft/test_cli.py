"""`spectratac ft info|stream` and `spectratac sim ft` from the shell."""

from __future__ import annotations

import json
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from spectratac.cli import main
from spectratac.cli.exit_codes import ExitCode
from spectratac.ft import open_ft

pytestmark = pytest.mark.subprocess

SIM = "sim://?scene=calibration&seed=3&speed=10&ft=netft&ft_loss=0"


def test_info_json(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["ft", "info", SIM, "--json", "--count", "100"]) == ExitCode.OK
    report = json.loads(capsys.readouterr().out)
    assert report["info"]["kind"] == "netft" and report["records"] == 100
    assert report["measured_rate_hz"] == pytest.approx(1000.0, rel=0.01)
    assert report["stats"]["lost"] == 0


def test_stream_csv_replays_through_csv_url(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert (
        main(["ft", "stream", SIM.replace("netft", "bota"), "--count", "50", "--format", "csv"])
        == 0
    )
    out = capsys.readouterr().out
    path = tmp_path / "ft.csv"
    path.write_text(out)
    recorded = np.loadtxt(path, delimiter=",", skiprows=1)
    with open_ft(f"csv://{path}") as ft:  # the stream's CSV is a replay file as it stands
        rows = ft.read(100, timeout=1.0)
    assert len(rows) == 50
    np.testing.assert_array_equal(rows["host_time"], recorded[:, 1])  # kept from the file
    np.testing.assert_array_equal(rows["wrench"], recorded[:, 3:9])


def test_stream_jsonl_and_table(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["ft", "stream", SIM, "--count", "3", "--format", "jsonl"]) == ExitCode.OK
    rows = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    assert len(rows) == 3 and set(rows[0]) >= {"sensor_time", "Fz", "sequence", "status"}
    assert main(["ft", "stream", SIM, "--count", "2"]) == ExitCode.OK
    assert "sensor_time" in capsys.readouterr().out


def test_unreachable_and_bad_urls_exit_3(capsys: pytest.CaptureFixture[str]) -> None:
    import socket

    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
        assert (
            main(["ft", "info", f"netft://127.0.0.1:{port}?cpf=1&cpt=1", "--timeout", "0.3"])
            == ExitCode.ERROR
        )
    assert "no RDT reply" in capsys.readouterr().err
    assert main(["ft", "stream", "ftp://x"]) == ExitCode.ERROR
    assert "not an F/T URL" in capsys.readouterr().err
    assert main(["sim", "ft", "--netft", "--speed", "max", "--port", "0"]) == ExitCode.ERROR
    assert "speed=max" in capsys.readouterr().err


def test_sim_ft_serves_other_processes(tmp_path: Path) -> None:
    cmd = [
        sys.executable,
        "-m",
        "spectratac",
        "sim",
        "ft",
        "--netft",
        "--port",
        "0",
        "--json",
        "--speed",
        "5",
    ]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert proc.stdout is not None
        announced = json.loads(proc.stdout.readline())
        assert announced["kind"] == "netft" and announced["url"].startswith("netft://127.0.0.1:")
        with open_ft(announced["url"], timeout=5.0) as ft:
            rows = ft.read(200, timeout=10.0)
        assert len(rows) == 200 and ft.info.serial == "SIM-NETFT"
    finally:
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(timeout=10) == 0
