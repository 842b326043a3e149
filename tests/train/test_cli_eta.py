"""`spectratac train` says how long it will take before it starts (issue 26): a recipe's
time from its rates measured on the dataset's first rows, the auto recipe's from its
budget; then a bar shows the time left. Run as a person runs it: a process and its stderr."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from tests.terminal import assert_estimate_first, run_in_terminal, screen

pytestmark = [pytest.mark.train, pytest.mark.subprocess]


def spectratac(*args: str) -> subprocess.CompletedProcess[str]:
    run = run_in_terminal([sys.executable, "-m", "spectratac", *args], timeout=900)
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
            "--budget", "10s", "--workers", "1"]  # fmt: skip
    run = spectratac(*args)
    line = assert_estimate_first(run.stderr, "train")
    # the work the search plans within the budget, at the rate this machine gives now, and
    # the fixed costs the work leaves out
    assert "search, forward folds and final refit (planned work at this machine's rate)" in line
    assert "fixed cost of each fit and prediction pass" in line
    assert "searching:" in run.stderr


def test_a_bar_that_redraws_long_leaves_the_estimate_on_screen() -> None:
    """On a busy machine the search outlasts its estimate and its bar redraws hundreds of
    times at 99 %; on a terminal that is one line, so the estimate stays in view (captured
    with text=True each redraw became a line and scrolled it off: 1,300 lines seen)."""
    bar = "searching:  99%|#########9| [00:40<00:00]\r"
    script = (
        "import sys; print('train: estimated 30 s', file=sys.stderr); "
        f"sys.stderr.write({bar!r} * 1500)"
    )
    run = run_in_terminal([sys.executable, "-c", script], timeout=60)
    assert "train: estimated 30 s" in screen(run.stderr)
