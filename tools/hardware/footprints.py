"""Footprints of the sensor board, built with the pcbnew API (Debian's /usr/bin/python3 only).

Debian's KiCad package ships no footprint libraries, and the sensor needs only five land
patterns, so they are described here as data. Pad numbering follows the package drawings as
transcribed in hardware/datasheet_facts.toml (pads 1-4 counter-clockwise from the top left seen
from above; tests/hardware/test_datasheet_facts.py checks each pad's corner and net).

The VEML3328 pads come from that table's [[veml3328.terminals]], the OPLGA4 package's bottom
terminals as Vishay's own 3D model of the package (document 80216, linked from datasheet 84968)
places them: lands equal to terminals, because an LGA's terminals have no side faces for a toe
fillet to wet (pins 1, 2, 4: 0.45 x 0.35 mm at x = +-0.775, y = +-0.35 mm; pin 3: 0.55 mm wide).
The datasheet's own recommended land pattern was not reachable: compare before ordering. The
1615 LED's pads (+-0.55 / +-0.45 mm, 0.5 x 0.5 mm) are not checked against its datasheet, which
was not reachable either.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass
from pathlib import Path

import pcbnew  # type: ignore[import-not-found]

from .circuit import Part, connector_layout
from .params import Geometry, load_pinmap

LIB = "SpectraTac"
FACTS = Path(__file__).resolve().parents[2] / "hardware" / "datasheet_facts.toml"


@dataclass(frozen=True)
class PadSpec:
    number: str
    x: float
    y: float
    w: float
    h: float
    angle: float = 0.0


@dataclass(frozen=True)
class Land:
    pads: tuple[PadSpec, ...]
    body: tuple[float, float]  # fab outline, full size
    courtyard: tuple[float, float]  # full size
    pin1_mark: tuple[float, float] | None  # silk dot next to pad 1


def _quad(px: float, py: float, w: float, h: float) -> tuple[PadSpec, ...]:
    """Four corner pads numbered counter-clockwise on screen from the top-left one."""
    return (
        PadSpec("1", -px, -py, w, h),
        PadSpec("2", -px, py, w, h),
        PadSpec("3", px, py, w, h),
        PadSpec("4", px, -py, w, h),
    )


def sensor_pads() -> tuple[PadSpec, ...]:
    """The VEML3328's lands: its package terminals, one to one, from the datasheet facts."""
    with FACTS.open("rb") as f:
        terminals = tomllib.load(f)["veml3328"]["terminals"]
    return tuple(
        PadSpec(t["number"], t["center"][0], t["center"][1], t["size"][0], t["size"][1])
        for t in terminals
    )


def lands(geo: Geometry) -> dict[str, Land]:
    sb, lb = geo.sensor_body, geo.led_body
    two = (PadSpec("1", -0.5, 0.0, 0.55, 0.6), PadSpec("2", 0.5, 0.0, 0.55, 0.6))
    sensor = sensor_pads()
    pin1 = next(p for p in sensor if p.number == "1")
    return {
        "VEML3328": Land(
            sensor, (sb[0], sb[1]), (sb[0] + 0.3, sb[1] + 0.3), (-sb[0] / 2 - 0.25, pin1.y)
        ),
        "LED_RGB_1615": Land(
            _quad(0.55, 0.45, 0.5, 0.5),
            (lb[0], lb[1]),
            (lb[0] + 0.3, lb[1] + 0.3),
            (-lb[0] / 2 - 0.25, -0.45),
        ),
        "R_0402": Land(two, (1.0, 0.5), (1.9, 1.0), None),
        "C_0402": Land(two, (1.0, 0.5), (1.9, 1.0), None),
        "SensorLink_18pad": Land(_connector_pads(geo), (0.0, 0.0), (0.0, 0.0), None),
    }


def _connector_pads(geo: Geometry) -> tuple[PadSpec, ...]:
    """Radial 1.2 x 0.9 mm pads on the connector ring, in pre-flip (mirrored) coordinates.

    The footprint is flipped to the bottom about its own origin, which mirrors y; placing each
    pad at the mirrored angle puts it at its top-view angle after the flip.
    """
    angles = connector_layout(geo)
    out = []
    for pad, row in sorted(load_pinmap().items()):
        a = math.radians(angles[row["signal"]])
        r = geo.connector_radius
        out.append(
            PadSpec(str(pad), r * math.cos(a), r * math.sin(a), 1.2, 0.9, -angles[row["signal"]])
        )
    return tuple(out)


def _mm(x: float, y: float) -> pcbnew.wxPoint:
    return pcbnew.wxPointMM(x, y)


def _rect(fp: pcbnew.FOOTPRINT, w: float, h: float, layer: int, width: float) -> None:
    s = pcbnew.FP_SHAPE(fp)
    s.SetShape(pcbnew.SHAPE_T_RECT)
    s.SetStart0(_mm(-w / 2, -h / 2))
    s.SetEnd0(_mm(w / 2, h / 2))
    s.SetLayer(layer)
    s.SetWidth(pcbnew.FromMM(width))
    s.SetDrawCoord()
    fp.Add(s)


def make(
    board: pcbnew.BOARD, part: Part, geo: Geometry, nets: dict[str, pcbnew.NETINFO_ITEM]
) -> pcbnew.FOOTPRINT:
    land = lands(geo)[part.footprint]
    fp = pcbnew.FOOTPRINT(board)
    fp.SetFPID(pcbnew.LIB_ID(LIB, part.footprint))
    fp.SetReference(part.ref)
    fp.SetValue(part.value)
    for text in (fp.Reference(), fp.Value()):
        text.SetLayer(pcbnew.F_Fab)
        text.SetTextSize(pcbnew.wxSizeMM(0.4, 0.4))
        text.SetTextThickness(pcbnew.FromMM(0.06))
        text.SetPos0(_mm(0, 0))
        text.SetDrawCoord()
    fp.Value().SetVisible(False)
    fp.SetAttributes(pcbnew.FP_SMD)
    for spec in land.pads:
        pad = pcbnew.PAD(fp)
        pad.SetNumber(spec.number)
        pad.SetAttribute(pcbnew.PAD_ATTRIB_SMD)
        pad.SetShape(pcbnew.PAD_SHAPE_RECT)
        pad.SetSize(pcbnew.wxSizeMM(spec.w, spec.h))
        pad.SetLayerSet(pad.SMDMask())
        pad.SetPos0(_mm(spec.x, spec.y))
        pad.SetPosition(_mm(spec.x, spec.y))
        pad.SetOrientationDegrees(spec.angle)
        pad.SetNet(nets[part.pins[spec.number]])
        fp.Add(pad)
    if land.body[0] > 0:
        _rect(fp, land.body[0], land.body[1], pcbnew.F_Fab, 0.05)
        _rect(fp, land.courtyard[0], land.courtyard[1], pcbnew.F_CrtYd, 0.05)
    if land.pin1_mark is not None:
        dot = pcbnew.FP_SHAPE(fp)
        dot.SetShape(pcbnew.SHAPE_T_CIRCLE)
        dot.SetStart0(_mm(*land.pin1_mark))
        dot.SetEnd0(_mm(land.pin1_mark[0] + 0.05, land.pin1_mark[1]))
        dot.SetLayer(pcbnew.F_SilkS)
        dot.SetWidth(pcbnew.FromMM(0.1))
        dot.SetDrawCoord()
        fp.Add(dot)
    x, y = geo.to_kicad(part.radius, part.angle)
    fp.SetPosition(_mm(x, y))
    if part.side == "bottom":
        # Flipping mirrors y about the footprint origin and negates the rotation, so rotate
        # by the negated angle first: the flipped part then points the intended way.
        fp.SetOrientationDegrees(-part.rotation % 360.0)
        fp.Flip(fp.GetPosition(), False)
    else:
        fp.SetOrientationDegrees(part.rotation % 360.0)
    return fp
