"""The sensor's face as the live page draws it: disc, regions, sensors and LEDs (mm, deg).

The board's layout comes from the generated board constants; the region boundaries are the
ones the twin labels contacts by (`spectratac.twin.geometry`, checked equal by
tests/apps/live/test_geometry.py), written here because the live page sits in the data flow
and never imports the twin.

>>> face = page_geometry()
>>> face["disc_mm"], face["sensors_deg"], face["sectors_deg"]["2"]
(9.6, [0.0, 120.0, 240.0], 90.0)
"""

from __future__ import annotations

from typing import Any

from spectratac.hardware.generated import board

#: Region 5 is the central disc inside this radius; regions 1..9 end at the active radius.
CENTRE_RADIUS_MM = 2.6
ACTIVE_RADIUS_MM = 8.0
#: Region number -> its sector's centre angle (the ring regions, keypad layout).
SECTOR_CENTRE_DEG = {6: 0.0, 3: 45.0, 2: 90.0, 1: 135.0, 4: 180.0, 7: 225.0, 8: 270.0, 9: 315.0}


def page_geometry() -> dict[str, Any]:
    """The "geometry" block of the page's meta message."""
    return {
        "disc_mm": board.BOARD_RADIUS,
        "centre_mm": CENTRE_RADIUS_MM,
        "active_mm": ACTIVE_RADIUS_MM,
        "ring_mm": board.LAYOUT_RING_RADIUS,
        "sectors_deg": {str(k): v for k, v in SECTOR_CENTRE_DEG.items()},
        "sensors_deg": list(board.LAYOUT_SENSOR_ANGLES),
        "leds_deg": list(board.LAYOUT_LED_ANGLES),
    }
