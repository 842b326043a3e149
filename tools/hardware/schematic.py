"""Write the board's KiCad 6 schematic from tools/hardware/circuit.py with kiutils (venv only).

Every pin end carries a net label, so the schematic's connectivity is exactly the netlist the
PCB generator uses; tests/hardware reads both files back and compares them. UUIDs are derived
from names (uuid5), so regenerating gives a byte-identical file.
"""

from __future__ import annotations

import uuid
from dataclasses import dataclass
from pathlib import Path

from kiutils.items.common import Effects, Fill, Font, Justify, Position, Property, Stroke
from kiutils.items.schitems import LocalLabel, SchematicSymbol, SymbolInstance
from kiutils.items.syitems import SyRect
from kiutils.libraries import Library, LibTable
from kiutils.schematic import Schematic
from kiutils.symbol import Symbol, SymbolLib, SymbolPin

from .circuit import Part, parts
from .params import Geometry

LIB = "SpectraTac"
NS = uuid.UUID("5e3c7a2a-8f1d-4c55-9b9e-3d1f0a6c2b10")
GRID = 2.54
KICAD6_SCH_VERSION = 20211123
KICAD6_SYM_VERSION = 20211014


def _uuid(*names: str) -> str:
    return str(uuid.uuid5(NS, "/".join(names)))


@dataclass(frozen=True)
class PinDef:
    number: str
    name: str
    etype: str
    side: str  # "L" or "R": which side of the body the pin sticks out of
    row: int  # 0 = top row


# Symbol pin types: J1's supply pins are where power enters the board, so they are the
# power outputs the ERC expects to drive the sensors' power inputs.
SYMBOLS: dict[str, tuple[PinDef, ...]] = {
    "VEML3328": (PinDef("4", "VDD", "power_in", "L", 0), PinDef("3", "SCL", "input", "L", 1),
                 PinDef("2", "SDA", "bidirectional", "L", 2),
                 PinDef("1", "GND", "power_in", "L", 3)),
    "LED_RGB_CA": (PinDef("1", "A", "passive", "L", 0), PinDef("2", "RK", "passive", "R", 0),
                   PinDef("3", "GK", "passive", "R", 1), PinDef("4", "BK", "passive", "R", 2)),
    "R": (PinDef("1", "~", "passive", "L", 0), PinDef("2", "~", "passive", "R", 0)),
    "C": (PinDef("1", "~", "passive", "L", 0), PinDef("2", "~", "passive", "R", 0)),
    "SensorLink": tuple(
        PinDef(str(n), f"P{n}", "power_out" if n <= 3 else "passive", "L", n - 1)
        for n in range(1, 19)),
}
REF_PREFIX = {"VEML3328": "U", "LED_RGB_CA": "D", "R": "R", "C": "C", "SensorLink": "J"}
BODY_HALF_WIDTH = 5.08
PIN_LENGTH = 2.54


def symbol_of(part: Part) -> str:
    if part.footprint == "VEML3328":
        return "VEML3328"
    if part.footprint.startswith("LED"):
        return "LED_RGB_CA"
    if part.footprint.startswith("SensorLink"):
        return "SensorLink"
    return "R" if part.ref.startswith("R") else "C"


def _rows(pins: tuple[PinDef, ...]) -> int:
    return max(p.row for p in pins) + 1


def pin_offset(pin: PinDef, pins: tuple[PinDef, ...]) -> tuple[float, float]:
    """Pin end relative to the symbol origin, in library coordinates (y up)."""
    x = -(BODY_HALF_WIDTH + PIN_LENGTH) if pin.side == "L" else BODY_HALF_WIDTH + PIN_LENGTH
    top = (_rows(pins) - 1) * GRID / 2
    return x, round(top - pin.row * GRID, 4)


def _effects(size: float = 1.27, hide: bool = False) -> Effects:
    return Effects(font=Font(width=size, height=size), hide=hide)


def lib_symbol(name: str) -> Symbol:
    pins = SYMBOLS[name]
    half_h = _rows(pins) * GRID / 2 + GRID / 2
    sym = Symbol(libraryNickname=LIB, entryName=name, inBom=True, onBoard=True)
    sym.pinNamesOffset = 0.508
    sym.properties = [
        Property("Reference", REF_PREFIX[name], 0,
                 Position(0, half_h + 1.27, 0), _effects()),
        Property("Value", name, 1, Position(0, -half_h - 1.27, 0), _effects()),
        Property("Footprint", "", 2, Position(0, 0, 0), _effects(hide=True)),
        Property("Datasheet", "", 3, Position(0, 0, 0), _effects(hide=True)),
    ]
    body = Symbol(entryName=name, unitId=0, styleId=1)
    body.graphicItems = [SyRect(start=Position(-BODY_HALF_WIDTH, half_h),
                                end=Position(BODY_HALF_WIDTH, -half_h),
                                stroke=Stroke(width=0.254), fill=Fill(type="background"))]
    unit = Symbol(entryName=name, unitId=1, styleId=1)
    for p in pins:
        x, y = pin_offset(p, pins)
        unit.pins.append(SymbolPin(electricalType=p.etype, graphicalStyle="line",
                                   position=Position(x, y, 0 if p.side == "L" else 180),
                                   length=PIN_LENGTH, name=p.name, number=p.number,
                                   nameEffects=_effects(), numberEffects=_effects()))
    sym.units = [body, unit]
    return sym


def placements(all_parts: list[Part]) -> dict[str, tuple[float, float]]:
    """Sheet position of each symbol: one column per part family, on the 2.54 mm grid."""
    columns = {"SensorLink": 0, "VEML3328": 1, "C": 2, "R": 3, "LED_RGB_CA": 4}
    next_y: dict[int, float] = {}
    pos = {}
    for part in all_parts:
        name = symbol_of(part)
        col = columns[name]
        if name == "R" and part.pins["1"].startswith("LED"):
            col = 5
        height = (_rows(SYMBOLS[name]) + 3) * GRID
        y = next_y.get(col, 30 * GRID)
        pos[part.ref] = (30 * GRID + col * 20 * GRID, y)
        next_y[col] = y + height
    return pos


def build(geo: Geometry) -> Schematic:
    sch = Schematic.create_new()
    sch.version = KICAD6_SCH_VERSION
    sch.generator = "eeschema"
    sch.uuid = _uuid("sheet")
    sch.paper.paperSize = "A3"
    all_parts = parts(geo)
    sch.libSymbols = [lib_symbol(n) for n in sorted({symbol_of(p) for p in all_parts})]
    where = placements(all_parts)
    for part in all_parts:
        name = symbol_of(part)
        x, y = (round(v, 4) for v in where[part.ref])
        sym = SchematicSymbol(libraryNickname=LIB, entryName=name, position=Position(x, y, 0),
                              unit=1, inBom=not part.ref.startswith("J"), onBoard=True,
                              uuid=_uuid(part.ref))
        half_h = round(_rows(SYMBOLS[name]) * GRID / 2 + GRID / 2 + 1.27, 4)
        sym.properties = [
            Property("Reference", part.ref, 0, Position(x, round(y - half_h, 4), 0), _effects()),
            Property("Value", part.value, 1, Position(x, round(y + half_h, 4), 0), _effects()),
            Property("Footprint", f"{LIB}:{part.footprint}", 2, Position(x, y, 0),
                     _effects(hide=True)),
            Property("Datasheet", "", 3, Position(x, y, 0), _effects(hide=True)),
            Property("MPN", part.mpn, 4, Position(x, y, 0), _effects(hide=True)),
        ]
        sym.pins = {p.number: _uuid(part.ref, p.number) for p in SYMBOLS[name]}
        sch.schematicSymbols.append(sym)
        for p in SYMBOLS[name]:
            dx, dy = pin_offset(p, SYMBOLS[name])
            left = p.side == "L"
            sch.labels.append(LocalLabel(
                text=part.pins[p.number],
                position=Position(round(x + dx, 4), round(y - dy, 4), 180 if left else 0),
                effects=Effects(font=Font(width=1.27, height=1.27),
                                justify=Justify(horizontally="right" if left else "left")),
                uuid=_uuid(part.ref, p.number, "label")))
        sch.symbolInstances.append(SymbolInstance(
            path=f"/{sym.uuid}", reference=part.ref, unit=1, value=part.value,
            footprint=f"{LIB}:{part.footprint}"))
    return sch


def write_library(geo: Geometry, folder: Path) -> None:
    """The symbols as a project library, so KiCad finds them when the schematic is edited."""
    lib = SymbolLib(version=KICAD6_SYM_VERSION, generator="kicad_symbol_editor")
    for name in sorted({symbol_of(p) for p in parts(geo)}):
        sym = lib_symbol(name)
        sym.libraryNickname = None
        lib.symbols.append(sym)
    lib.to_file(str(folder / f"{LIB.lower()}.kicad_sym"))
    table = LibTable.create_new("sym_lib_table")
    table.libs.append(Library(name=LIB, type="KiCad", uri=f"${{KIPRJMOD}}/{LIB.lower()}.kicad_sym",
                              description="SpectraTac sensor board symbols (generated)"))
    table.to_file(str(folder / "sym-lib-table"))


def write(geo: Geometry, path: Path) -> None:
    build(geo).to_file(str(path))
    write_library(geo, path.parent)
