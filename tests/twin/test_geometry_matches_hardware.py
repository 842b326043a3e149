"""The twin's layout is the board's: every twin geometry value comes from
hardware/definitions/params.toml (through the generated spectratac.hardware.generated.board), from
the sensor's vocabulary (the regions, hardware/definitions/vocabulary.toml) or has no counterpart
there. A new twin constant must be sorted into one of these lists, and a new mismatch fails here.
The unit draw's spreads are the board's [tolerances], one source."""

from __future__ import annotations

import numpy as np
from spectratac.hardware.generated import board, vocabulary
from spectratac.twin import geometry
from spectratac.twin.unit import TOLERANCES, VARIATION, UnitParams

# Twin constant -> board parameter it equals.
SHARED = {
    "DISC_RADIUS_MM": "BOARD_RADIUS",
    "RING_RADIUS_MM": "LAYOUT_RING_RADIUS",
    "SENSOR_ANGLES_DEG": "LAYOUT_SENSOR_ANGLES",
    "LED_ANGLES_DEG": "LAYOUT_LED_ANGLES",
    "STACK_HEIGHT_MM": "STACK_HEIGHT",
    "PCB_MM": "BOARD_THICKNESS",
    "PDMS_MM": "STACK_PDMS",
    "SKIN_MM": "STACK_SKIN_TOP",
}
# Twin constant -> vocabulary constant it equals (the region layout).
REGIONS = {
    "CENTER_RADIUS_MM": "CENTRE_RADIUS_MM",
    "ACTIVE_RADIUS_MM": "ACTIVE_RADIUS_MM",
    "SECTOR_CENTRE_DEG": "SECTOR_CENTRE_DEG",
}
# Twin-only: values derived from the ones above.
TWIN_ONLY = {"SURFACE_Z_MM", "SENSOR_XY", "LED_XY"}


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


def test_region_layout_is_the_vocabulary() -> None:
    for twin_name, vocab_name in REGIONS.items():
        assert getattr(geometry, twin_name) == getattr(vocabulary, vocab_name), twin_name
    # The regions lie on the board: the centre disc inside the part ring, the ring inside
    # the skin's disc, and the vocabulary's sensor count is the board's.
    assert 0 < vocabulary.CENTRE_RADIUS_MM < board.LAYOUT_RING_RADIUS
    assert vocabulary.ACTIVE_RADIUS_MM < board.BOARD_RADIUS
    assert len(board.LAYOUT_SENSOR_ANGLES) == vocabulary.N_SENSORS
    assert len(board.LAYOUT_LED_ANGLES) == vocabulary.N_LEDS


def test_nominal_unit_is_built_on_the_board_stack() -> None:
    u = UnitParams.nominal()
    assert (u.pcb_mm, u.pdms_mm, u.skin_mm) == (
        board.BOARD_THICKNESS,
        board.STACK_PDMS,
        board.STACK_SKIN_TOP,
    )
    # The skin surface (torque lever arm) is the stack top above the PCB.
    assert u.stack.surface_z_mm == board.STACK_HEIGHT - board.BOARD_THICKNESS


def test_unit_spreads_are_the_board_tolerances() -> None:
    built = {k.removeprefix("TOLERANCES_").lower(): v for k, v in vars(board).items()
             if k.startswith("TOLERANCES_")}  # fmt: skip
    names = {"board_thickness": "pcb_mm", "pdms_thickness": "pdms_mm", "skin_thickness": "skin_mm"}
    assert {names.get(k, k): v for k, v in built.items()} == TOLERANCES
    assert VARIATION["sensor_xy"] == ("abs", board.TOLERANCES_PLACEMENT)
    assert VARIATION["led_gain"] == ("rel", board.TOLERANCES_LED_INTENSITY)
    assert VARIATION["e_star_mpa"] == ("rel", board.TOLERANCES_ELASTOMER_MODULUS)


def test_every_twin_geometry_constant_is_classified() -> None:
    listed = set(SHARED) | set(REGIONS) | TWIN_ONLY
    assert _numeric_constants() == listed


def test_twin_stack_adds_up_to_the_board_height() -> None:
    assert board.STACK_HEIGHT == geometry.PCB_MM + geometry.PDMS_MM + geometry.SKIN_MM
