"""Generate, route, check and plot the sensor PCB. Run with Debian's /usr/bin/python3.

    HOME=$(mktemp -d) /usr/bin/python3 -m tools.hardware.pcb_build OUT_DIR   # from the repo root

writes OUT_DIR/spectratac.kicad_pcb (+ .kicad_pro with the design rules), drc.rpt,
gerber/ (Gerbers + Excellon drill), spectratac-bom.csv and spectratac-cpl.csv, and prints a JSON
summary. Exits non-zero if routing fails or DRC reports anything.
"""

from __future__ import annotations

import csv
import json
import re
import sys
from pathlib import Path

import pcbnew  # type: ignore[import-not-found]

from . import footprints
from .circuit import Part, connector_layout, nets, parts
from .params import Geometry, load
from .router import Router, Rules, Shape, route_all

RULES = Rules()
NAME = "spectratac"
# Route the supplies first (they branch to many pads), then the short signal nets.
PRIORITY = ("GND", "VDD", "VLED")
GERBER_LAYERS = (
    (pcbnew.F_Cu, "F_Cu"), (pcbnew.B_Cu, "B_Cu"), (pcbnew.F_Mask, "F_Mask"),
    (pcbnew.B_Mask, "B_Mask"), (pcbnew.F_Paste, "F_Paste"), (pcbnew.B_Paste, "B_Paste"),
    (pcbnew.F_SilkS, "F_Silkscreen"), (pcbnew.B_SilkS, "B_Silkscreen"),
    (pcbnew.Edge_Cuts, "Edge_Cuts"),
)


def _mm(x: float, y: float) -> pcbnew.wxPoint:
    return pcbnew.wxPointMM(x, y)


def set_rules(board: pcbnew.BOARD) -> None:
    """Rules a low-cost 2-layer fab (JLCPCB / PCBWay standard process) accepts."""
    ds = board.GetDesignSettings()
    nc = ds.GetNetClasses().GetDefault()
    nc.SetClearance(pcbnew.FromMM(RULES.clearance))
    nc.SetTrackWidth(pcbnew.FromMM(RULES.track))
    nc.SetViaDiameter(pcbnew.FromMM(RULES.via_diameter))
    nc.SetViaDrill(pcbnew.FromMM(RULES.via_drill))
    ds.m_MinClearance = pcbnew.FromMM(0.127)
    ds.m_TrackMinWidth = pcbnew.FromMM(0.127)
    ds.m_ViasMinSize = pcbnew.FromMM(0.5)
    ds.m_ViasMinAnnularWidth = pcbnew.FromMM(0.13)
    ds.m_MinThroughDrill = pcbnew.FromMM(0.3)
    ds.m_HoleToHoleMin = pcbnew.FromMM(0.25)
    ds.m_CopperEdgeClearance = pcbnew.FromMM(RULES.edge_clearance)
    ds.SetBoardThickness(pcbnew.FromMM(load().board_thickness))


def outline(board: pcbnew.BOARD, geo: Geometry) -> None:
    circle = pcbnew.PCB_SHAPE(board)
    circle.SetShape(pcbnew.SHAPE_T_CIRCLE)
    circle.SetLayer(pcbnew.Edge_Cuts)
    circle.SetCenter(_mm(*geo.centre))
    circle.SetEnd(_mm(geo.centre[0] + geo.board_radius, geo.centre[1]))
    circle.SetWidth(pcbnew.FromMM(0.1))
    board.Add(circle)


def pad_labels(board: pcbnew.BOARD, geo: Geometry, j1: Part) -> list[Shape]:
    """Pad numbers in bottom silkscreen, inboard of each connector pad, for wiring by hand.

    Returns the labels' areas, which the router keeps free of vias.
    """
    angles = connector_layout(geo)
    areas = []
    for pad, signal in j1.pins.items():
        text = pcbnew.PCB_TEXT(board)
        text.SetText(pad)
        text.SetLayer(pcbnew.B_SilkS)
        text.SetMirrored(True)
        text.SetTextSize(pcbnew.wxSizeMM(0.5, 0.5))
        text.SetTextThickness(pcbnew.FromMM(0.1))
        x, y = geo.to_kicad(geo.connector_radius - 1.3, angles[signal])
        text.SetPosition(_mm(x, y))
        board.Add(text)
        areas.append(Shape("", (1,), "rect", x, y, 0.3 * len(pad), 0.3))
    return areas


def route(board: pcbnew.BOARD, geo: Geometry, names: list[str],
          netinfo: dict[str, pcbnew.NETINFO_ITEM], no_via: list[Shape]) -> Router:
    pads = []
    for fp in sorted(board.GetFootprints(), key=lambda f: f.GetReference()):
        for pad in sorted(fp.Pads(), key=lambda p: int(p.GetNumber())):
            layer = 0 if pad.IsOnLayer(pcbnew.F_Cu) else 1
            pos, size = pad.GetPosition(), pad.GetSize()
            pads.append(Shape(pad.GetNetname(), (layer,), "rect", pcbnew.ToMM(pos.x),
                              pcbnew.ToMM(pos.y), pcbnew.ToMM(size.x) / 2,
                              pcbnew.ToMM(size.y) / 2, pad.GetOrientationDegrees()))
    order = [n for n in PRIORITY if n in names] + [n for n in names if n not in PRIORITY]
    router = route_all(geo.centre[0], geo.centre[1], geo.board_radius, RULES, pads, order,
                       no_via)
    for r in router.routes:
        for x1, y1, x2, y2, layer in r.segments:
            t = pcbnew.PCB_TRACK(board)
            t.SetStart(_mm(x1, y1))
            t.SetEnd(_mm(x2, y2))
            t.SetWidth(pcbnew.FromMM(RULES.track))
            t.SetLayer(pcbnew.F_Cu if layer == 0 else pcbnew.B_Cu)
            t.SetNet(netinfo[r.net])
            board.Add(t)
        for x, y in r.vias:
            v = pcbnew.PCB_VIA(board)
            v.SetPosition(_mm(x, y))
            v.SetViaType(pcbnew.VIATYPE_THROUGH)
            v.SetLayerPair(pcbnew.F_Cu, pcbnew.B_Cu)
            v.SetWidth(pcbnew.FromMM(RULES.via_diameter))
            v.SetDrill(pcbnew.FromMM(RULES.via_drill))
            v.SetNet(netinfo[r.net])
            board.Add(v)
    return router


def build_board(out: Path) -> Path:
    geo = load()
    board = pcbnew.BOARD()
    set_rules(board)
    names = nets(geo)
    netinfo = {}
    for name in names:
        netinfo[name] = pcbnew.NETINFO_ITEM(board, name)
        board.Add(netinfo[name])
    outline(board, geo)
    all_parts = parts(geo)
    for part in all_parts:
        board.Add(footprints.make(board, part, geo, netinfo))
    labels = pad_labels(board, geo, next(p for p in all_parts if p.ref == "J1"))
    route(board, geo, names, netinfo, labels)
    path = out / f"{NAME}.kicad_pcb"
    pcbnew.SaveBoard(str(path), board)
    return path


def drc(path: Path, report: Path) -> dict[str, int]:
    board = pcbnew.LoadBoard(str(path))
    pcbnew.WriteDRCReport(board, str(report), pcbnew.EDA_UNITS_MILLIMETRES, True)
    # KiCad names the board by its absolute path: keep the committed report free of the
    # checkout's location (it changed with every worktree that regenerated it).
    text = report.read_text().replace(str(path.resolve().parent) + "/", "")
    text = text.replace(str(path.parent) + "/", "")
    report.write_text(text)
    counts = {}
    for key, pattern in (("violations", r"Found (\d+) DRC violations"),
                         ("unconnected", r"Found (\d+) unconnected pads"),
                         ("footprint_errors", r"Found (\d+) Footprint errors")):
        m = re.search(pattern, text)
        counts[key] = int(m.group(1)) if m else -1
    counts["errors"] = len(re.findall(r"Severity: error", text))
    return counts


def plot(path: Path, gerber_dir: Path) -> list[str]:
    board = pcbnew.LoadBoard(str(path))
    gerber_dir.mkdir(parents=True, exist_ok=True)
    pc = pcbnew.PLOT_CONTROLLER(board)
    po = pc.GetPlotOptions()
    po.SetOutputDirectory(str(gerber_dir))
    po.SetPlotFrameRef(False)
    po.SetUseGerberProtelExtensions(False)
    po.SetUseGerberX2format(False)  # X2 attributes carry a creation date: keep output stable
    po.SetIncludeGerberNetlistInfo(False)
    po.SetCreateGerberJobFile(False)
    po.SetSubtractMaskFromSilk(True)
    po.SetExcludeEdgeLayer(True)
    for layer, suffix in GERBER_LAYERS:
        pc.SetLayer(layer)
        pc.OpenPlotfile(suffix, pcbnew.PLOT_FORMAT_GERBER, suffix)
        pc.PlotLayer()
    pc.ClosePlot()
    writer = pcbnew.EXCELLON_WRITER(board)
    writer.SetFormat(True)  # metric
    writer.SetOptions(False, False, pcbnew.wxPoint(0, 0), True)
    writer.CreateDrillandMapFilesSet(str(gerber_dir), True, False)
    return sorted(p.name for p in gerber_dir.iterdir())


def assembly_files(path: Path, out: Path) -> None:
    """BOM grouped by value and JLCPCB-style pick-and-place, origin at the board centre."""
    geo = load()
    board = pcbnew.LoadBoard(str(path))
    by_ref = {p.ref: p for p in parts(geo)}
    with (out / f"{NAME}-cpl.csv").open("w", newline="") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(["Designator", "Mid X", "Mid Y", "Layer", "Rotation"])
        fps = sorted(board.GetFootprints(), key=lambda fp: fp.GetReference())
        for fp in fps:
            if by_ref[fp.GetReference()].footprint.startswith("SensorLink"):
                continue  # bare solder pads, nothing to place
            pos = fp.GetPosition()
            x = pcbnew.ToMM(pos.x) - geo.centre[0]
            y = geo.centre[1] - pcbnew.ToMM(pos.y)
            side = "Bottom" if fp.IsFlipped() else "Top"
            w.writerow([fp.GetReference(), f"{x:.3f}mm", f"{y:.3f}mm", side,
                        f"{fp.GetOrientationDegrees() % 360:.1f}"])
    groups: dict[tuple[str, str, str], list[str]] = {}
    for p in parts(geo):
        if p.footprint.startswith("SensorLink"):
            continue
        groups.setdefault((p.value, p.footprint, p.mpn), []).append(p.ref)
    with (out / f"{NAME}-bom.csv").open("w", newline="") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(["Comment", "Designator", "Footprint", "Quantity", "MPN"])
        for (value, fpname, mpn), refs in sorted(groups.items(), key=lambda kv: kv[1][0]):
            w.writerow([value, ",".join(refs), fpname, len(refs), mpn])


def main(argv: list[str]) -> int:
    out = Path(argv[1]).resolve()
    out.mkdir(parents=True, exist_ok=True)
    path = build_board(out)
    counts = drc(path, out / "drc.rpt")
    files = plot(path, out / "gerber")
    assembly_files(path, out)
    print(json.dumps({"board": str(path), "drc": counts, "gerber": files}))
    clean = counts["violations"] == 0 and counts["unconnected"] == 0
    return 0 if clean and counts["footprint_errors"] == 0 else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv))
