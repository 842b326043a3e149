"""Expensive test inputs made once per test run, also when pytest-xdist runs it in several
workers: the first worker to ask makes the input in a folder every worker of the run shares
(under a file lock); the others wait, then read what it made."""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path

import pytest
from filelock import FileLock

LOCK_TIMEOUT_S = 1800  # generous: the slowest input (a trained decoder) takes about a minute


def run_folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """This run's folder: the workers' common basetemp parent under xdist, else basetemp."""
    base = tmp_path_factory.getbasetemp()
    return base.parent if os.environ.get("PYTEST_XDIST_WORKER") else base


def made_once(
    tmp_path_factory: pytest.TempPathFactory, name: str, make: Callable[[Path], None]
) -> Path:
    """Folder `name` of this run, filled by `make(folder)` exactly once per run."""
    root = run_folder(tmp_path_factory)
    folder = root / name
    with FileLock(str(root / f"{name}.lock"), timeout=LOCK_TIMEOUT_S):
        done = folder / ".made"
        if not done.exists():
            folder.mkdir(exist_ok=True)
            make(folder)
            done.touch()
    return folder
