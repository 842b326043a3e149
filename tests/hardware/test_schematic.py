"""The schematic's netlist equals the PCB's, and regenerating the schematic changes nothing.

Connectivity is recovered from the file itself: every net label must sit on a pin end, and the
(reference, pin) -> net map so obtained is compared with the pads of the committed board.
"""

from __future__ import annotations

from pathlib import Path

from conftest import KICAD_DIR, pad_nets
from kiutils.board import Board
from kiutils.schematic import Schematic

from tools.hardware import schematic as schgen
from tools.hardware.params import Geometry, load_pinmap


def schematic_netlist(sch: Schematic) -> dict[tuple[str, str], str]:
    labels: dict[tuple[float, float], list[str]] = {}
    for label in sch.labels:
        key = (round(label.position.X, 3), round(label.position.Y, 3))
        labels.setdefault(key, []).append(label.text)
    lib = {f"{s.libraryNickname}:{s.entryName}": s for s in sch.libSymbols}
    netlist: dict[tuple[str, str], str] = {}
    used: set[tuple[float, float]] = set()
    for sym in sch.schematicSymbols:
        assert not sym.position.angle, "generated symbols are not rotated"
        ref = next(p.value for p in sym.properties if p.key == "Reference")
        pins = [pin for unit in lib[sym.libId].units for pin in unit.pins]
        for pin in pins:
            # Library coordinates point y up, sheet coordinates y down.
            key = (
                round(sym.position.X + pin.position.X, 3),
                round(sym.position.Y - pin.position.Y, 3),
            )
            names = labels.get(key, [])
            assert len(names) == 1, f"{ref} pin {pin.number}: labels {names} at {key}"
            netlist[(ref, pin.number)] = names[0]
            used.add(key)
    assert used == set(labels), f"labels on no pin: {set(labels) - used}"
    return netlist


def test_schematic_netlist_equals_pcb(sch: Schematic, board: Board) -> None:
    assert schematic_netlist(sch) == pad_nets(board)


def test_schematic_connector_matches_pinmap(sch: Schematic) -> None:
    netlist = schematic_netlist(sch)
    want = {("J1", str(pad)): row["signal"] for pad, row in load_pinmap().items()}
    assert {k: v for k, v in netlist.items() if k[0] == "J1"} == want


def test_schematic_is_kicad6_and_regenerates_identically(geo: Geometry, tmp_path: Path) -> None:
    committed = KICAD_DIR / "spectratac.kicad_sch"
    assert committed.read_text().startswith("(kicad_sch (version 20211123)")
    fresh = tmp_path / "spectratac.kicad_sch"
    schgen.write(geo, fresh)
    assert fresh.read_text() == committed.read_text(), "run `make hardware` and commit"
