"""KiCad's own ERC on the generated schematic, driven headless by kiauto (eeschema under Xvfb)."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import sysconfig
from pathlib import Path

import pytest
from conftest import KICAD_DIR, SYSTEM_PYTHON, pcbnew_missing

pytestmark = pytest.mark.kicad

EESCHEMA_DO = Path(sys.executable).parent / "eeschema_do"


def missing() -> str | None:
    reason = pcbnew_missing()
    if reason:
        return reason
    for tool in ("eeschema", "xvfb-run", "xdotool"):
        if shutil.which(tool) is None:
            return f"{tool} not installed (.ci/run installs kicad, xvfb, xdotool, xclip)"
    if not EESCHEMA_DO.exists():
        return "kiauto is not installed in the venv (hardware extra)"
    return None


@pytest.mark.skipif(missing() is not None, reason=missing() or "")
def test_erc_reports_no_errors_or_warnings(tmp_path: Path) -> None:
    # kiauto needs pcbnew, which only Debian's python3 imports; kiauto itself and its pure
    # Python dependencies come from the venv's site-packages.
    env = dict(os.environ, HOME=str(tmp_path / "home"), PYTHONPATH=sysconfig.get_paths()["purelib"])
    proc = subprocess.run(
        [
            SYSTEM_PYTHON,
            str(EESCHEMA_DO),
            "run_erc",
            str(KICAD_DIR / "spectratac.kicad_sch"),
            str(tmp_path),
        ],
        capture_output=True,
        text=True,
        env=env,
        timeout=120,
    )
    report = tmp_path / "spectratac.erc"
    assert report.exists(), proc.stdout + proc.stderr
    m = re.search(r"ERC messages: (\d+)\s+Errors (\d+)\s+Warnings (\d+)", report.read_text())
    assert m, report.read_text()
    assert (m.group(2), m.group(3)) == ("0", "0"), report.read_text()
    assert proc.returncode == 0, proc.stdout + proc.stderr
