"""Board geometry and the nine contact regions (the fixed interface other parts build on).

Board centre is the origin, x to the right, y up, z out of the skin, lengths in mm.
Sensor k sits at angle 120°·k and LED j at 60° + 120°·j, both on a 5.5 mm radius. The board's
outline, part ring, angles and layer thicknesses come from hardware/definitions/params.toml
(generated `spectratac.hardware.generated.board`), so the twin is laid out like the board that
is built.

The regions are the sensor vocabulary's (hardware/definitions/vocabulary.toml, generated
`spectratac.hardware.generated.vocabulary`), numbered like a phone keypad:

    1 2 3        region 5: the central disc r < CENTER_RADIUS_MM
    4 5 6        regions 1-4, 6-9: eight 45° sectors of the ring
    7 8 9        CENTER_RADIUS_MM <= r <= ACTIVE_RADIUS_MM, centred on 135°, 90°, 45°, 180°, 0°, ...

Contacts beyond ACTIVE_RADIUS_MM (the rim, where the skin is clamped) carry no region (-1).
This module turns those definitions into positions: which region a point lies in, and where
a region's centre is.

>>> int(region_of(0.0, 0.0)), int(region_of(6.0, 0.0)), int(region_of(0.0, -6.0))
(5, 6, 8)
>>> int(region_of(9.0, 0.0))
-1
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from spectratac.hardware.generated import board
from spectratac.hardware.generated import vocabulary as vocab

DISC_RADIUS_MM = board.BOARD_RADIUS
STACK_HEIGHT_MM = board.STACK_HEIGHT
RING_RADIUS_MM = board.LAYOUT_RING_RADIUS
# Layer stack (z = 0 at the PCB top), the board's as built: FR-4 below, the PDMS light guide,
# the black skin top. twin/stack.py turns these (and each unit's drawn thicknesses) into the
# optical and mechanical constants that depend on them.
PCB_MM = board.BOARD_THICKNESS
PDMS_MM = board.STACK_PDMS
SKIN_MM = board.STACK_SKIN_TOP
SURFACE_Z_MM = PDMS_MM + SKIN_MM  # skin surface above the PCB top

CENTER_RADIUS_MM = vocab.CENTRE_RADIUS_MM
ACTIVE_RADIUS_MM = vocab.ACTIVE_RADIUS_MM

SENSOR_ANGLES_DEG = np.array(board.LAYOUT_SENSOR_ANGLES)
LED_ANGLES_DEG = np.array(board.LAYOUT_LED_ANGLES)

# Region number -> sector centre angle in degrees (ring regions only).
SECTOR_CENTRE_DEG = vocab.SECTOR_CENTRE_DEG
_SECTOR_TO_REGION = np.array(vocab.RING_REGIONS, dtype=np.int8)
_SECTOR_DEG = 360.0 / len(vocab.RING_REGIONS)


def polar_xy(radius: float, angles_deg: NDArray[np.float64]) -> NDArray[np.float64]:
    """Points on a circle, shape (len(angles), 2)."""
    a = np.deg2rad(angles_deg)
    return np.stack([radius * np.cos(a), radius * np.sin(a)], axis=-1)


SENSOR_XY = polar_xy(RING_RADIUS_MM, SENSOR_ANGLES_DEG)
LED_XY = polar_xy(RING_RADIUS_MM, LED_ANGLES_DEG)


def region_of(x: ArrayLike, y: ArrayLike) -> NDArray[np.int8]:
    """Region 1-9 of points on the skin, -1 beyond the active area (vectorised)."""
    xa = np.asarray(x, dtype=np.float64)
    ya = np.asarray(y, dtype=np.float64)
    r = np.hypot(xa, ya)
    ang = np.mod(np.degrees(np.arctan2(ya, xa)) + _SECTOR_DEG / 2, 360.0)
    sector = np.minimum((ang // _SECTOR_DEG).astype(np.int64), len(_SECTOR_TO_REGION) - 1)
    out = _SECTOR_TO_REGION[sector]
    out = np.where(r < CENTER_RADIUS_MM, np.int8(vocab.CENTRE_REGION), out)
    out = np.where(r > ACTIVE_RADIUS_MM, np.int8(vocab.NO_REGION), out)
    return np.asarray(out, dtype=np.int8)


def region_centre(region: int) -> tuple[float, float]:
    """Representative centre (x, y) in mm of a region 1-9.

    >>> region_centre(5)
    (0.0, 0.0)
    """
    if region == vocab.CENTRE_REGION:
        return (0.0, 0.0)
    if region not in SECTOR_CENTRE_DEG:
        from spectratac.twin.errors import TwinError

        raise TwinError(f"region must be 1..{vocab.N_REGIONS}, got {region!r}")
    r = 0.5 * (CENTER_RADIUS_MM + ACTIVE_RADIUS_MM)
    a = np.deg2rad(SECTOR_CENTRE_DEG[region])
    return (float(r * np.cos(a)), float(r * np.sin(a)))
