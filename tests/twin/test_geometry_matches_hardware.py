"""The twin's layout is the board's: every twin geometry value either comes from
hardware/params.toml (through the generated spectratac.hardware.board), is a known, documented
twin model parameter that differs from the board, or has no board counterpart. A new twin
constant must be sorted into one of these lists, and a new mismatch fails here."""

from __future__ import annotations

import numpy as np
from spectratac.hardware import board
from spectratac.twin import geometry

# Twin constant -> board parameter it equals.
SHARED = {
    "DISC_RADIUS_MM": "BOARD_RADIUS",
    "RING_RADIUS_MM": "LAYOUT_RING_RADIUS",
    "SENSOR_ANGLES_DEG": "LAYOUT_SENSOR_ANGLES",
    "LED_ANGLES_DEG": "LAYOUT_LED_ANGLES",
    "STACK_HEIGHT_MM": "STACK_HEIGHT",
}
# Twin constant -> (board parameter, twin value, board value): calibrated twin layer thicknesses
# that differ from the built stack (see twin/geometry.py for why they are kept).
KNOWN_DIFFERENCES = {
    "PCB_MM": ("BOARD_THICKNESS", 0.8, 1.0),
    "PDMS_MM": ("STACK_PDMS", 2.4, 2.5),
    "SKIN_MM": ("STACK_SKIN_TOP", 0.8, 0.5),
}
# Twin-only: region layout, and values derived from the ones above.
TWIN_ONLY = {
    "CENTER_RADIUS_MM",
    "ACTIVE_RADIUS_MM",
    "SURFACE_Z_MM",
    "SENSOR_XY",
    "LED_XY",
    "SECTOR_CENTRE_DEG",
}


def _numeric_constants() -> set[str]:
    return {
        name
        for name, value in vars(geometry).items()
        if name.isupper()
        and not name.startswith("_")
        and isinstance(value, int | float | np.ndarray | dict)
    }


def test_shared_values_equal_the_board() -> None:
    for twin_name, board_name in SHARED.items():
        twin, built = getattr(geometry, twin_name), getattr(board, board_name)
        assert np.array_equal(twin, built), f"{twin_name} {twin} != params.toml {board_name}"


def test_only_the_known_values_differ_from_the_board() -> None:
    for twin_name, (board_name, twin_value, board_value) in KNOWN_DIFFERENCES.items():
        got = (getattr(geometry, twin_name), getattr(board, board_name))
        assert got == (twin_value, board_value), f"{twin_name} / {board_name}: {got}"


def test_every_twin_geometry_constant_is_classified() -> None:
    listed = set(SHARED) | set(KNOWN_DIFFERENCES) | TWIN_ONLY
    assert _numeric_constants() == listed


def test_twin_stack_adds_up_to_the_board_height() -> None:
    assert board.STACK_HEIGHT == geometry.PCB_MM + geometry.PDMS_MM + geometry.SKIN_MM
