"""Load hardware/definitions/params.toml: the one place the sensor's geometry is written down.

Stdlib only, because both the venv (tests, schematic) and Debian's /usr/bin/python3 (pcbnew)
import it.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
PARAMS_TOML = REPO / "hardware" / "definitions" / "params.toml"
PINMAP_TOML = REPO / "hardware" / "definitions" / "stm32f411_pinmap.toml"


@dataclass(frozen=True)
class Geometry:
    board_radius: float
    board_thickness: float
    centre: tuple[float, float]
    ring_radius: float
    sensor_angles: tuple[float, ...]
    led_angles: tuple[float, ...]
    connector_radius: float
    height: float
    skin_top: float
    skin_wall: float
    pocket_clearance: float
    pocket_extra_depth: float
    sensor_body: tuple[float, float, float]
    led_body: tuple[float, float, float]
    mould_wall: float
    mould_floor: float
    fixture_clearance: float
    eject_hole_radius: float

    @property
    def pdms_thickness(self) -> float:
        """The PDMS light guide takes what the board and the skin leave of the 4 mm stack."""
        return self.height - self.board_thickness - self.skin_top

    @property
    def pdms_radius(self) -> float:
        """The skin cup's wall surrounds the PDMS, so the outer diameter stays the board's."""
        return self.board_radius - self.skin_wall

    def to_kicad(self, radius: float, angle_deg: float) -> tuple[float, float]:
        """Polar (top view, CCW) to KiCad sheet millimetres, whose y axis points down."""
        a = math.radians(angle_deg)
        return (self.centre[0] + radius * math.cos(a), self.centre[1] - radius * math.sin(a))

    def from_kicad(self, x: float, y: float) -> tuple[float, float]:
        """KiCad sheet millimetres to polar (radius, angle in [0, 360))."""
        dx, dy = x - self.centre[0], self.centre[1] - y
        return math.hypot(dx, dy), math.degrees(math.atan2(dy, dx)) % 360.0


def load(path: Path = PARAMS_TOML) -> Geometry:
    raw = tomllib.loads(path.read_text())
    b, lay, s, p, m = raw["board"], raw["layout"], raw["stack"], raw["parts"], raw["mould"]
    return Geometry(
        board_radius=float(b["radius"]),
        board_thickness=float(b["thickness"]),
        centre=(float(b["centre"][0]), float(b["centre"][1])),
        ring_radius=float(lay["ring_radius"]),
        sensor_angles=tuple(float(a) for a in lay["sensor_angles"]),
        led_angles=tuple(float(a) for a in lay["led_angles"]),
        connector_radius=float(lay["connector_radius"]),
        height=float(s["height"]),
        skin_top=float(s["skin_top"]),
        skin_wall=float(s["skin_wall"]),
        pocket_clearance=float(s["pocket_clearance"]),
        pocket_extra_depth=float(s["pocket_extra_depth"]),
        sensor_body=(float(p["sensor_body"][0]), float(p["sensor_body"][1]),
                     float(p["sensor_body"][2])),
        led_body=(float(p["led_body"][0]), float(p["led_body"][1]), float(p["led_body"][2])),
        mould_wall=float(m["wall"]),
        mould_floor=float(m["floor"]),
        fixture_clearance=float(m["fixture_clearance"]),
        eject_hole_radius=float(m["eject_hole_radius"]),
    )


def load_pinmap(path: Path = PINMAP_TOML) -> dict[int, dict[str, str]]:
    """Connector pad number -> {signal, mcu, function} from the firmware's pin map."""
    raw = tomllib.loads(path.read_text())
    return {
        int(row["pad"]): {"signal": row["signal"], "mcu": row["mcu"], "function": row["function"]}
        for row in raw["connector"]["pads"]
    }
