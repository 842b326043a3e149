"""Progress bars only on a terminal: every verb makes its bar through `spectratac.progress`,
which shows it only when stderr is a terminal. A log file or a pipe gets the estimate lines
and the results, never a carriage-return redraw (`model upload` wrote ~1,700 of them)."""

from __future__ import annotations

import ast
import io
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from spectratac.dataset import SPECTRATAC_INPUTS, Dataset
from spectratac.decode import Decoder
from spectratac.progress import bar

from tests.terminal import run_in_terminal, screen

pytestmark = pytest.mark.subprocess  # verbs on a pty and into a log file

PACKAGE = Path(__file__).resolve().parents[2] / "host" / "spectratac"


def test_only_the_progress_module_makes_tqdm_bars() -> None:
    """The one place: a bar made elsewhere would not know whether stderr is a terminal."""
    makers = []
    for path in PACKAGE.rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if (isinstance(node, ast.ImportFrom) and (node.module or "").startswith("tqdm")) or (
                isinstance(node, ast.Import) and any(a.name == "tqdm" for a in node.names)
            ):
                makers.append(str(path.relative_to(PACKAGE)))
    assert makers == ["progress.py"], makers


def test_a_bar_draws_on_a_terminal_only() -> None:
    shown = bar(total=3, file=io.StringIO())
    assert shown.disable
    script = "from spectratac.progress import bar\nb = bar(total=3, desc='work')\nb.update(3)"
    run = run_in_terminal([sys.executable, "-c", script], timeout=120)
    assert run.returncode == 0 and "work: 100%" in run.stderr


def tiny_model(folder: Path) -> Path:
    ds = Dataset.generic(np.arange(1.0, 37.0).reshape(3, 12) * 100.0, np.zeros((3, 1)),
                         list(SPECTRATAC_INPUTS), ["Fz"])  # fmt: skip
    return Decoder.untrained(ds, features="paper33").save(folder / "tiny.stac")


def test_model_upload_to_a_log_file_writes_no_bar(tmp_path: Path) -> None:
    model = tiny_model(tmp_path)
    url = f"sim://?scene=tour&seed=2&speed=max&model_store={tmp_path / 'store.flash'}"
    argv = [sys.executable, "-m", "spectratac", "model", "upload", url, str(model)]
    log = tmp_path / "stderr.log"
    with log.open("w") as err:
        run = subprocess.run(argv, stdout=subprocess.PIPE, stderr=err, text=True, timeout=300)
    assert run.returncode == 0 and "uploaded model" in run.stdout
    assert "\r" not in log.read_text() and "uploading" not in log.read_text()
    # on a terminal the bar is there, redrawn in place: one line on the screen
    on_tty = run_in_terminal(argv, timeout=300)
    assert on_tty.returncode == 0
    assert "\r" in on_tty.stderr
    assert len([line for line in screen(on_tty.stderr) if "uploading" in line]) == 1
