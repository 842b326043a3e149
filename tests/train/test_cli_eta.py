"""`spectratac train` says how long it will take before it starts (issue 26): a recipe's
time from its rates measured on the dataset's first rows, the auto recipe's from its
budget; then a bar shows the time left. Run as a person runs it: a process and its stderr."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from tests.terminal import assert_estimate_first

pytestmark = [pytest.mark.train, pytest.mark.subprocess]


def spectratac(*args: str) -> subprocess.CompletedProcess[str]:
    run = subprocess.run(
        [sys.executable, "-m", "spectratac", *args], capture_output=True, text=True, timeout=900
    )
    assert run.returncode == 0, run.stderr
    return run


@pytest.fixture(scope="module")
def data(twin_ds, tmp_path_factory) -> Path:
    return twin_ds.save(tmp_path_factory.mktemp("d") / "d.npz")


def test_a_recipe_says_its_time_then_counts_epochs_down(data: Path, tmp_path: Path) -> None:
    args = ["train", str(data), "-o", str(tmp_path / "m.stac"), "--epochs", "6", "--threads", "1"]
    run = spectratac(*args)
    line = assert_estimate_first(run.stderr, "train")
    assert "measured on this machine" in line
    summary = json.loads(spectratac(*args, "--force", "--json", "--no-progress").stdout)
    assert summary["estimate"]["parts_s"]["train"] > 0
    assert summary["estimate"]["rates"]["s/row-epoch"] > 0


def test_the_auto_recipe_says_its_budget_then_runs_it_down(data: Path, tmp_path: Path) -> None:
    args = ["train", str(data), "-o", str(tmp_path / "a.stac"), "--recipe", "auto",
            "--budget", "30s", "--workers", "1"]  # fmt: skip
    run = spectratac(*args)
    line = assert_estimate_first(run.stderr, "train")
    assert "search + final refit (--budget) 30 s" in line
    assert "searching:" in run.stderr
