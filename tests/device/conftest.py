"""Fixtures that run simulated devices as separate processes, the way users run them."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest


@dataclass
class Served:
    url: str
    process: subprocess.Popen[str]

    def signal(self, sig: int) -> None:
        self.process.send_signal(sig)


def serve(tmp_path: Path, *args: str) -> Served:
    """Start `spectratac sim serve …` and wait (bounded) for it to announce its address."""
    cmd = [sys.executable, "-m", "spectratac", "sim", "serve", "--json", *args]
    proc = subprocess.Popen(
        cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=tmp_path
    )
    assert proc.stdout is not None
    line = proc.stdout.readline()  # the server prints one line once it is ready
    if not line:
        proc.kill()
        raise AssertionError(
            f"sim serve did not start: {proc.stderr.read() if proc.stderr else ''}"
        )
    return Served(json.loads(line)["url"], proc)


def stop(served: Served) -> None:
    if served.process.poll() is None:
        served.process.send_signal(signal.SIGTERM)
        try:
            served.process.wait(timeout=10)
        except subprocess.TimeoutExpired:
            served.process.kill()
            served.process.wait(timeout=10)


@pytest.fixture
def pty_device(tmp_path: Path) -> Iterator[Served]:
    served = serve(tmp_path, "--pty", "--link", str(tmp_path / "ttySPECTRA"), "--scene", "tour")
    yield served
    stop(served)


@pytest.fixture
def tcp_device(tmp_path: Path) -> Iterator[Served]:
    served = serve(tmp_path, "--tcp", "0", "--scene", "tour")
    yield served
    stop(served)


@pytest.fixture
def no_reply_pty() -> Iterator[str]:
    """A real pty that nobody answers on: a device that is plugged in but silent."""
    master, slave = os.openpty()
    path = os.ttyname(slave)
    yield path
    os.close(slave)
    os.close(master)
