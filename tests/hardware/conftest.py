"""Fixtures for the hardware tests: the generator modules, parsed KiCad files, tool probes."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest
from kiutils.board import Board
from kiutils.schematic import Schematic

from tools.hardware.params import Geometry, load

REPO = Path(__file__).resolve().parents[2]
KICAD_DIR = REPO / "hardware" / "kicad"
SYSTEM_PYTHON = "/usr/bin/python3"


def pcbnew_missing() -> str | None:
    """Why the pcbnew tests cannot run here, or None when they can."""
    if not Path(SYSTEM_PYTHON).exists():
        return f"{SYSTEM_PYTHON} not found (KiCad's Python API lives in Debian's python3)"
    probe = subprocess.run(
        [SYSTEM_PYTHON, "-c", "import pcbnew"],
        capture_output=True,
        text=True,
        env={"HOME": "/tmp", "PATH": "/usr/bin:/bin"},
    )
    if probe.returncode != 0:
        return "KiCad 6 is not installed (apt-get install kicad): pcbnew does not import"
    return None


def openscad_missing() -> str | None:
    return None if shutil.which("openscad") else "OpenSCAD is not installed (apt install openscad)"


@pytest.fixture(scope="session")
def geo() -> Geometry:
    return load()


@pytest.fixture(scope="session")
def board() -> Board:
    return Board.from_file(str(KICAD_DIR / "spectratac.kicad_pcb"))


@pytest.fixture(scope="session")
def sch() -> Schematic:
    return Schematic.from_file(str(KICAD_DIR / "spectratac.kicad_sch"))


def reference(fp: object) -> str:
    for item in fp.graphicItems:  # type: ignore[attr-defined]
        if getattr(item, "type", None) == "reference":
            return str(item.text)
    raise AssertionError(f"footprint {fp} has no reference")


def pad_nets(board: Board) -> dict[tuple[str, str], str]:
    """(reference, pad number) -> net name, as the PCB file says."""
    out = {}
    for fp in board.footprints:
        ref = reference(fp)
        for pad in fp.pads:
            out[(ref, pad.number)] = pad.net.name if pad.net is not None else ""
    return out
