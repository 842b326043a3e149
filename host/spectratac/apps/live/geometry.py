"""The sensor's face as the live page draws it: disc, regions, sensors and LEDs (mm, deg).

Everything comes from the generated definitions: the board's layout (`hardware.generated.board`,
params.toml) and the regions' boundaries (`hardware.generated.vocabulary`, vocabulary.toml),
the same ones the twin labels contacts by.

>>> face = page_geometry()
>>> face["disc_mm"], face["sensors_deg"], face["sectors_deg"]["2"]
(9.6, [0.0, 120.0, 240.0], 90.0)
"""

from __future__ import annotations

from typing import Any

from spectratac.hardware.generated import board
from spectratac.hardware.generated import vocabulary as vocab


def page_geometry() -> dict[str, Any]:
    """The "geometry" block of the page's meta message."""
    return {
        "disc_mm": board.BOARD_RADIUS,
        "centre_mm": vocab.CENTRE_RADIUS_MM,
        "active_mm": vocab.ACTIVE_RADIUS_MM,
        "ring_mm": board.LAYOUT_RING_RADIUS,
        "sectors_deg": {str(k): v for k, v in vocab.SECTOR_CENTRE_DEG.items()},
        "sensors_deg": list(board.LAYOUT_SENSOR_ANGLES),
        "leds_deg": list(board.LAYOUT_LED_ANGLES),
    }
