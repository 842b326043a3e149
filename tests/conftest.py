"""Shared fixtures: paths into the repository, and running a benchmark as a user would."""

from __future__ import annotations

import json
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

REPO = Path(__file__).resolve().parents[1]

Figures = dict[str, dict[str, Any]]


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
