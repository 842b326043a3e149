"""Shared fixtures: paths into the repository, and running a benchmark as a user would; and
the test tiers: tests that use a fixture which spawns processes, builds firmware or boots
QEMU get that marker here, so `make test-fast` leaves them out without each test saying so."""

from __future__ import annotations

import json
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from spectratac import threads

REPO = Path(__file__).resolve().parents[1]
# The test process trains beside the processes it starts: it follows the thread policy too,
# before any test imports torch.
threads.apply()

Figures = dict[str, dict[str, Any]]

# Fixture -> the markers (pyproject.toml) of every test that uses it, directly or not.
FIXTURE_MARKERS: dict[str, tuple[str, ...]] = {
    "run_bench": ("subprocess",),
    "pty_device": ("subprocess",),
    "tcp_device": ("subprocess",),
    "no_reply_pty": ("subprocess",),
    "image": ("firmware",),
    "native_build": ("firmware",),
    "qemu_port": ("qemu", "subprocess"),
    "press_model": ("train",),  # tests/apps: a decoder trained on scripted presses
}


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    for item in items:
        for fixture in getattr(item, "fixturenames", ()):
            for marker in FIXTURE_MARKERS.get(fixture, ()):
                item.add_marker(marker)


@pytest.fixture(scope="session")
def repo() -> Path:
    return REPO


@pytest.fixture()
def run_bench(repo: Path) -> Callable[..., Figures]:
    """run_bench("ft.py", "--records", "2000") -> --json figures of tools/bench/ft.py by name."""

    def run(script: str, *args: str) -> Figures:
        out = subprocess.run(
            [sys.executable, f"tools/bench/{script}", *args, "--json"],
            cwd=repo,
            capture_output=True,
            text=True,
            check=True,
            timeout=600,
        ).stdout
        return {f["name"]: f for f in map(json.loads, out.splitlines())}

    return run
