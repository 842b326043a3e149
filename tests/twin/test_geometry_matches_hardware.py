"""The twin's layout is the board's: radius, part ring, part angles and stack height agree with
hardware/params.toml, the single source of the sensor's geometry."""

from __future__ import annotations

import tomllib
from pathlib import Path

import numpy as np
from spectratac.twin import geometry


def test_twin_layout_matches_hardware_params(repo: Path) -> None:
    hw = tomllib.loads((repo / "hardware" / "params.toml").read_text(encoding="utf-8"))
    assert hw["board"]["radius"] == geometry.DISC_RADIUS_MM
    assert hw["layout"]["ring_radius"] == geometry.RING_RADIUS_MM
    assert np.array_equal(geometry.SENSOR_ANGLES_DEG, hw["layout"]["sensor_angles"])
    assert np.array_equal(geometry.LED_ANGLES_DEG, hw["layout"]["led_angles"])
    assert hw["stack"]["height"] == geometry.STACK_HEIGHT_MM
    assert hw["stack"]["height"] == geometry.PCB_MM + geometry.PDMS_MM + geometry.SKIN_MM
