"""The live page draws the sensor face the twin labels contacts by: the same board layout
and region boundaries (the page never imports the twin, so this test ties the two)."""

from __future__ import annotations

from spectratac.apps.live.geometry import page_geometry
from spectratac.twin import geometry as g


def test_the_page_draws_the_twins_regions_and_layout() -> None:
    assert page_geometry() == {
        "disc_mm": g.DISC_RADIUS_MM,
        "centre_mm": g.CENTER_RADIUS_MM,
        "active_mm": g.ACTIVE_RADIUS_MM,
        "ring_mm": g.RING_RADIUS_MM,
        "sectors_deg": {str(k): v for k, v in g.SECTOR_CENTRE_DEG.items()},
        "sensors_deg": g.SENSOR_ANGLES_DEG.tolist(),
        "leds_deg": g.LED_ANGLES_DEG.tolist(),
    }
    assert list(page_geometry()["sectors_deg"]) == [str(k) for k in g.SECTOR_CENTRE_DEG]
