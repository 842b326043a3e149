"""The committed PCB: outline, placement geometry, nets, connector against the firmware pin map.

Reads hardware/kicad/spectratac.kicad_pcb with kiutils, so it runs without KiCad installed.
"""

from __future__ import annotations

import math
import re

import pytest
from conftest import KICAD_DIR, pad_nets, reference
from kiutils.board import Board

from tools.hardware.circuit import LED_COLOURS, connector_layout, nets, parts
from tools.hardware.params import Geometry, load_pinmap


def _angle_diff(a: float, b: float) -> float:
    return abs((a - b + 180.0) % 360.0 - 180.0)


def _footprints(board: Board) -> dict[str, object]:
    return {reference(fp): fp for fp in board.footprints}


def test_outline_is_one_circle_of_19_2_mm(board: Board, geo: Geometry) -> None:
    edges = [g for g in board.graphicItems if getattr(g, "layer", None) == "Edge.Cuts"]
    assert len(edges) == 1 and type(edges[0]).__name__ == "GrCircle"
    c, e = edges[0].center, edges[0].end
    radius = math.hypot(e.X - c.X, e.Y - c.Y)
    assert 2 * radius == pytest.approx(19.2, abs=1e-6)
    assert math.dist((c.X, c.Y), geo.centre) < 1e-9


def test_board_thickness_matches_stack(board: Board, geo: Geometry) -> None:
    assert board.general.thickness == pytest.approx(geo.board_thickness)
    assert geo.board_thickness + geo.pdms_thickness + geo.skin_top == pytest.approx(4.0)


@pytest.mark.parametrize(
    ("prefix", "angles"), [("U", (0.0, 120.0, 240.0)), ("D", (60.0, 180.0, 300.0))]
)
def test_optical_parts_on_ring(
    board: Board, geo: Geometry, prefix: str, angles: tuple[float, ...]
) -> None:
    fps = _footprints(board)
    for k, want in enumerate(angles):
        fp = fps[f"{prefix}{k + 1}"]
        r, a = geo.from_kicad(fp.position.X, fp.position.Y)
        assert r == pytest.approx(5.5, abs=1e-4), f"{prefix}{k + 1} radius"
        assert _angle_diff(a, want) < 1e-3, f"{prefix}{k + 1} at {a:.3f}°, want {want}°"
        assert fp.layer == "F.Cu", "sensors and LEDs face the PDMS"
        # Rotated so that every part has the same orientation relative to the centre.
        assert _angle_diff(fp.position.angle or 0.0, want) < 1e-3


def test_same_type_120_alternating_60(board: Board, geo: Geometry) -> None:
    fps = _footprints(board)
    ring = sorted(
        (geo.from_kicad(fps[r].position.X, fps[r].position.Y)[1], r[0])
        for r in ("U1", "U2", "U3", "D1", "D2", "D3")
    )
    kinds = [kind for _, kind in ring]
    assert kinds in (["U", "D"] * 3, ["D", "U"] * 3), "sensors and LEDs alternate"
    for i in range(6):
        a, b = ring[i][0], ring[(i + 1) % 6][0]
        assert _angle_diff(b, a) == pytest.approx(60.0, abs=1e-3)
        c = ring[(i + 2) % 6][0]
        assert _angle_diff(c, a) == pytest.approx(120.0, abs=1e-3)


def pad_centre(fp: object, pad: object) -> tuple[float, float]:
    """Absolute pad centre: KiCad rotates counter-clockwise on screen (y axis down)."""
    t = math.radians(fp.position.angle or 0.0)  # type: ignore[attr-defined]
    x, y = pad.position.X, pad.position.Y  # type: ignore[attr-defined]
    return (
        fp.position.X + x * math.cos(t) + y * math.sin(t),  # type: ignore[attr-defined]
        fp.position.Y - x * math.sin(t) + y * math.cos(t),
    )  # type: ignore[attr-defined]


def test_all_copper_pads_inside_board(board: Board, geo: Geometry) -> None:
    edge_clearance = 0.3
    for fp in board.footprints:
        if reference(fp).startswith(("R", "C", "J")):
            assert fp.layer == "B.Cu", f"{reference(fp)}: passives and pads on the bottom"
        for pad in fp.pads:
            r, _ = geo.from_kicad(*pad_centre(fp, pad))
            reach = math.hypot(pad.size.X, pad.size.Y) / 2
            assert r + reach < geo.board_radius - edge_clearance, (
                f"{reference(fp)} pad {pad.number} too close to the edge"
            )


def test_every_pad_on_a_net(board: Board) -> None:
    unconnected = [k for k, net in pad_nets(board).items() if not net]
    assert not unconnected


def test_required_nets_present(board: Board, geo: Geometry) -> None:
    names = {n.name for n in board.nets if n.name}
    required = {"VDD", "GND", "VLED"} | {f"S{x}{k}" for x in ("CL", "DA") for k in (1, 2, 3)}
    required |= {f"LED{j}_{c}" for j in (1, 2, 3) for c in LED_COLOURS}
    assert required <= names
    assert names == set(nets(geo)), "the board carries exactly the circuit's nets"


def test_pads_carry_the_circuit(board: Board, geo: Geometry) -> None:
    want = {(p.ref, pad): net for p in parts(geo) for pad, net in p.pins.items()}
    assert pad_nets(board) == want


def test_each_sensor_has_its_own_bus_pullups_and_decoupling(board: Board) -> None:
    nets_of = pad_nets(board)
    for k in (1, 2, 3):
        sensor = {nets_of[(f"U{k}", n)] for n in "1234"}
        assert sensor == {"GND", "VDD", f"SCL{k}", f"SDA{k}"}
        pullups = {
            net
            for (ref, pad), net in nets_of.items()
            if ref.startswith("R") and nets_of[(ref, "1")] == "VDD" and pad == "2"
        }
        assert {f"SCL{k}", f"SDA{k}"} <= pullups
        assert {nets_of[(f"C{k}", "1")], nets_of[(f"C{k}", "2")]} == {"VDD", "GND"}


def test_led_drive_common_anode_with_series_resistors(board: Board) -> None:
    nets_of = pad_nets(board)
    for j in (1, 2, 3):
        assert nets_of[(f"D{j}", "1")] == "VLED"
        for i, c in enumerate(LED_COLOURS):
            cathode = nets_of[(f"D{j}", str(i + 2))]
            resistor = [
                ref for (ref, pad), net in nets_of.items() if ref.startswith("R") and net == cathode
            ]
            assert len(resistor) == 1, f"one resistor on {cathode}"
            assert nets_of[(resistor[0], "1")] == f"LED{j}_{c}", "resistor leads to the pin"


def test_connector_matches_firmware_pinmap(board: Board, geo: Geometry) -> None:
    pinmap = load_pinmap()
    assert sorted(pinmap) == list(range(1, 19))
    fp = _footprints(board)["J1"]
    got = {pad.number: pad.net.name for pad in fp.pads}
    assert got == {str(n): row["signal"] for n, row in pinmap.items()}
    # Each pad sits at its documented angle on the connector ring (README wiring table).
    angles = connector_layout(geo)
    for pad in fp.pads:
        # J1 sits unrotated at the centre: pad positions are offsets from it (y down).
        r = math.hypot(pad.position.X, pad.position.Y)
        a = math.degrees(math.atan2(-pad.position.Y, pad.position.X)) % 360.0
        assert r == pytest.approx(geo.connector_radius, abs=1e-4)
        assert _angle_diff(a, angles[pad.net.name]) < 1e-3


def test_committed_drc_report_is_clean() -> None:
    text = (KICAD_DIR / "drc.rpt").read_text()
    assert re.search(r"Found 0 DRC violations", text), text
    assert re.search(r"Found 0 unconnected pads", text), text
    assert re.search(r"Found 0 Footprint errors", text), text


def test_fab_outputs_present() -> None:
    gerbers = {p.name for p in (KICAD_DIR / "gerber").iterdir()}
    for layer in (
        "F_Cu",
        "B_Cu",
        "F_Mask",
        "B_Mask",
        "F_Paste",
        "B_Paste",
        "F_Silkscreen",
        "B_Silkscreen",
        "Edge_Cuts",
    ):
        assert f"spectratac-{layer}.gbr" in gerbers
    assert "spectratac.drl" in gerbers
    bom = (KICAD_DIR / "spectratac-bom.csv").read_text().splitlines()
    cpl = (KICAD_DIR / "spectratac-cpl.csv").read_text().splitlines()
    assert bom[0].startswith("Comment,Designator")
    assert len(cpl) - 1 == 24, "every placed part (not the bare connector pads) has a row"


def test_committed_drc_report_does_not_name_a_checkout() -> None:
    # KiCad writes the board's absolute path; the build strips it so the committed report is the
    # same whichever checkout regenerated it.
    first_line = (KICAD_DIR / "drc.rpt").read_text().splitlines()[0]
    assert first_line == "** Drc report for spectratac.kicad_pcb **", first_line
