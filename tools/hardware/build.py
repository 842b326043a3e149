"""`make hardware`: regenerate every hardware output from hardware/definitions/params.toml.

    .venv/bin/python -m tools.hardware.build [--out DIR] [--no-render]

Writes (under DIR, default hardware/):
  kicad/   spectratac.kicad_sch (kiutils), spectratac.kicad_pcb + .kicad_pro (pcbnew, routed),
           drc.rpt, gerber/ (Gerbers + Excellon), spectratac-bom.csv, spectratac-cpl.csv
  mould/   params.scad (from params.toml), stl/*.stl (OpenSCAD)
  render/  board_top.png, board_bottom.png (gerbv), mould_*.png (OpenSCAD under xvfb-run)
The PCB step runs in Debian's /usr/bin/python3, the only interpreter that imports pcbnew.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

from . import moulds, schematic
from .params import REPO, load

SYSTEM_PYTHON = "/usr/bin/python3"
# Lines that carry the run's date: dropped so that regenerating changes nothing in git.
DATED = re.compile(r"^(G04 #@! TF\.CreationDate.*|; #@! TF\.CreationDate.*|\*\* Created on .*)\n",
                   re.MULTILINE)


def _undate(folder: Path) -> None:
    for path in folder.rglob("*"):
        if path.suffix in (".gbr", ".drl", ".rpt"):
            path.write_text(DATED.sub("", path.read_text()))


def build_pcb(kicad_dir: Path) -> dict[str, object]:
    """Run the pcbnew generator with a throw-away HOME (KiCad writes settings there)."""
    with tempfile.TemporaryDirectory() as home:
        env = dict(os.environ, HOME=home)
        proc = subprocess.run([SYSTEM_PYTHON, "-m", "tools.hardware.pcb_build",
                               str(kicad_dir.resolve())],
                              capture_output=True, text=True, env=env, cwd=REPO)
    (kicad_dir / "spectratac.kicad_prl").unlink(missing_ok=True)  # per-user view state
    _undate(kicad_dir)
    lines = [ln for ln in proc.stdout.splitlines() if ln.startswith("{")]
    if proc.returncode != 0 or not lines:
        raise SystemExit(f"PCB generation failed ({proc.returncode}):\n{proc.stdout}\n"
                         f"{proc.stderr}")
    result: dict[str, object] = json.loads(lines[-1])
    return result


def render_board(gerber_dir: Path, render_dir: Path) -> list[Path]:
    """Top view of the top side; bottom side mirrored so it reads as seen from below."""
    from PIL import Image

    render_dir.mkdir(parents=True, exist_ok=True)
    stem = "spectratac-"
    views = {
        "board_top.png": [("F_Cu", "#c89b3c"), ("F_Silkscreen", "#ffffff"),
                          ("Edge_Cuts", "#000000")],
        "board_bottom.png": [("B_Cu", "#c89b3c"), ("B_Silkscreen", "#ffffff"),
                             ("Edge_Cuts", "#000000")],
    }
    paths = []
    for name, layers in views.items():
        args = ["gerbv", "--export=png", "--dpi=900", f"--output={render_dir / name}",
                "--background=#1f5f3a"]
        for layer, colour in reversed(layers):
            args += [f"--foreground={colour}", str(gerber_dir / f"{stem}{layer}.gbr")]
        subprocess.run(args, check=True, capture_output=True)
        if name == "board_bottom.png":
            img = Image.open(render_dir / name)
            img.transpose(Image.Transpose.FLIP_LEFT_RIGHT).save(render_dir / name)
        paths.append(render_dir / name)
    return paths


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=REPO / "hardware")
    ap.add_argument("--no-render", action="store_true", help="skip the PNG renders")
    args = ap.parse_args(argv)
    out: Path = args.out.resolve()
    geo = load()
    kicad_dir, mould_dir, render_dir = out / "kicad", out / "mould", out / "render"
    for d in (kicad_dir, mould_dir):
        d.mkdir(parents=True, exist_ok=True)
    schematic.write(geo, kicad_dir / "spectratac.kicad_sch")
    pcb = build_pcb(kicad_dir)
    if mould_dir != moulds.SCAD.parent:
        shutil.copy(moulds.SCAD, mould_dir / moulds.SCAD.name)
    moulds.write_params(geo, mould_dir)
    stls = moulds.export_stls(mould_dir, mould_dir / "stl")
    renders: list[Path] = []
    if not args.no_render:
        renders = render_board(kicad_dir / "gerber", render_dir)
        renders += moulds.render_pngs(mould_dir, render_dir)
    print(json.dumps({"drc": pcb["drc"], "stl": [p.name for p in stls],
                      "renders": [p.name for p in renders]}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
