"""Regenerate the PCB with KiCad's own API: DRC must be clean and the result must equal the
committed board (up to KiCad's random UUIDs and item order)."""

from __future__ import annotations

import json
import os
import subprocess
from pathlib import Path

import pytest
from conftest import KICAD_DIR, REPO, SYSTEM_PYTHON, pcbnew_missing, reference
from kiutils.board import Board

REASON = pcbnew_missing()
pytestmark = [pytest.mark.kicad, pytest.mark.skipif(REASON is not None, reason=REASON or "")]


@pytest.fixture(scope="module")
def regenerated(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict[str, object]]:
    out = tmp_path_factory.mktemp("pcb")
    home = tmp_path_factory.mktemp("home")  # KiCad writes settings under HOME
    proc = subprocess.run(
        [SYSTEM_PYTHON, "-m", "tools.hardware.pcb_build", str(out)],
        cwd=REPO,
        capture_output=True,
        text=True,
        env=dict(os.environ, HOME=str(home)),
    )
    summary = [ln for ln in proc.stdout.splitlines() if ln.startswith("{")]
    assert proc.returncode == 0 and summary, proc.stdout + proc.stderr
    return out, json.loads(summary[-1])


def canonical(path: Path) -> dict[str, object]:
    b = Board.from_file(str(path))
    names = {n.number: n.name for n in b.nets}
    fps = sorted(
        (
            reference(fp),
            fp.layer,
            round(fp.position.X, 4),
            round(fp.position.Y, 4),
            round(fp.position.angle or 0.0, 3),
            tuple(sorted((p.number, p.net.name if p.net else "") for p in fp.pads)),
        )
        for fp in b.footprints
    )
    segs, vias = [], []
    for t in b.traceItems:
        if type(t).__name__ == "Via":
            vias.append(
                (round(t.position.X, 4), round(t.position.Y, 4), t.size, t.drill, names[t.net])
            )
        else:
            segs.append(
                (
                    round(t.start.X, 4),
                    round(t.start.Y, 4),
                    round(t.end.X, 4),
                    round(t.end.Y, 4),
                    t.width,
                    t.layer,
                    names[t.net],
                )
            )
    return {"footprints": fps, "segments": sorted(segs), "vias": sorted(vias)}


def test_drc_has_no_violations_and_nothing_unconnected(
    regenerated: tuple[Path, dict[str, object]],
) -> None:
    out, summary = regenerated
    drc = summary["drc"]
    assert drc == {"violations": 0, "unconnected": 0, "footprint_errors": 0, "errors": 0}, (
        out / "drc.rpt"
    ).read_text()


def test_committed_board_is_what_the_generator_makes(
    regenerated: tuple[Path, dict[str, object]],
) -> None:
    out, _ = regenerated
    assert canonical(out / "spectratac.kicad_pcb") == canonical(
        KICAD_DIR / "spectratac.kicad_pcb"
    ), "board drifted: run `make hardware` and commit"
    assert (out / "spectratac.kicad_pro").read_text() == (
        KICAD_DIR / "spectratac.kicad_pro"
    ).read_text(), "design rules drifted"
    for name in ("spectratac-bom.csv", "spectratac-cpl.csv"):
        assert (out / name).read_text() == (KICAD_DIR / name).read_text(), name


def test_every_net_is_routed(regenerated: tuple[Path, dict[str, object]]) -> None:
    out, _ = regenerated
    b = canonical(out / "spectratac.kicad_pcb")
    routed = {s[-1] for s in b["segments"]}  # type: ignore[union-attr]
    multi_pad: dict[str, int] = {}
    for fp in b["footprints"]:  # type: ignore[union-attr]
        for _, net in fp[5]:
            multi_pad[net] = multi_pad.get(net, 0) + 1
    assert {n for n, count in multi_pad.items() if count > 1} <= routed


def test_drill_file_holds_every_via(regenerated: tuple[Path, dict[str, object]]) -> None:
    out, _ = regenerated
    vias = canonical(out / "spectratac.kicad_pcb")["vias"]
    drill = (out / "gerber" / "spectratac.drl").read_text()
    holes = [ln for ln in drill.splitlines() if ln.startswith("X")]
    assert len(holes) == len(vias) > 0  # type: ignore[arg-type]
