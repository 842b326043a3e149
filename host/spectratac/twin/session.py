"""Session-to-session variation: what changes when the same unit is recorded another day.

A `SessionConditions` is drawn from (unit seed, session index, seed) and applied to a unit and
a scene for one recording session:

- re-mounting: the sensor is taken off the F/T adapter and put back, so a press aimed at
  (x, y) lands slightly elsewhere on the board (`mount_offset_mm`), the sensor sits tilted on
  the F/T (`mount_tilt_deg`: the F/T reads the wrench in its own, rotated axes), the clamp
  compresses the stack a little (`preload_mm`) and the tare leaves a small F/T offset
  (`ft_bias`);
- room temperature: an offset on the whole session (`temperature_offset_c`), which reaches
  the LEDs (droop), the light guide and the dark counts through the existing temperature
  paths;
- ageing with the session index: LED output declines (`led_output_factor`) and the elastomer
  stiffens as it post-cures (`modulus_factor`), each unit at its own rate;
- the press protocol and noise of the session (`scene_seed`, `noise_seed`).

Every spread is an engineering estimate (MODEL.md, "Session-to-session variation").

>>> c = SessionConditions.draw(unit_seed=3, session_index=2, seed=0)
>>> c == SessionConditions.draw(3, 2, 0), c == SessionConditions.draw(3, 1, 0)
(True, False)
>>> c.led_output_factor < 1.0 < c.modulus_factor
True
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, replace
from typing import Any

import numpy as np

from spectratac.twin.errors import TwinError
from spectratac.twin.scene_model import Scene
from spectratac.twin.unit import UnitParams

# Re-mounting on the F/T adapter: screw clearance and dowel play (assumed).
MOUNT_OFFSET_SD_MM = 0.15
# Adapter flatness, debris and uneven screw torque tilt the sensor (assumed).
MOUNT_TILT_SD_DEG = 0.3
# The clamp compresses the stack by up to this much (assumed: a fraction of the PDMS' 2.5 mm).
PRELOAD_MAX_MM = 0.05
# What the tare leaves after mounting (stress relaxation of the adapter, tare averaging):
# twice the gauges' slow drift std (N, N, N, N·m, N·m, N·m).
FT_BIAS_STEP_SD = np.array([0.02, 0.02, 0.04, 4e-4, 4e-4, 2e-4])
# Day-to-day room temperature (heating, air conditioning, season), °C.
TEMPERATURE_OFFSET_SD_C = 2.0
# Ageing per session (sessions about a week of use apart): LED lumen decline plus dust and
# skin oil on the optical path, and the elastomer stiffening as PDMS keeps curing at room
# temperature, saturating (assumed). Each unit ages at its own rate (log-normal spread).
LED_DECLINE_PER_SESSION = 0.005
STIFFENING_MAX = 0.10
STIFFENING_SESSIONS = 8.0
AGEING_RATE_SPREAD = 0.3


@dataclass(frozen=True)
class SessionConditions:
    """One recording session's conditions for one unit (see module docstring)."""

    unit_seed: int
    session_index: int
    seed: int
    mount_offset_mm: tuple[float, float]
    mount_tilt_deg: tuple[float, float]
    preload_mm: float
    ft_bias: tuple[float, ...]  # (6,) N, N, N, N·m, N·m, N·m
    temperature_offset_c: float
    led_output_factor: float
    modulus_factor: float
    scene_seed: int
    noise_seed: int

    @staticmethod
    def draw(unit_seed: int, session_index: int, seed: int = 0) -> SessionConditions:
        """The conditions of session `session_index` of unit `unit_seed`; deterministic."""
        for name, v in (("unit_seed", unit_seed), ("session_index", session_index), ("seed", seed)):
            if not isinstance(v, (int, np.integer)) or isinstance(v, bool) or v < 0:
                raise TwinError(f"{name} must be a non-negative int, got {v!r}")
        rng = np.random.default_rng([int(unit_seed), int(session_index), int(seed), 0x5E55])
        unit_rng = np.random.default_rng([int(unit_seed), int(seed), 0xA6E])
        led_rate, stiff_rate = np.exp(unit_rng.normal(0.0, AGEING_RATE_SPREAD, 2))
        k = float(session_index)
        return SessionConditions(
            unit_seed=int(unit_seed),
            session_index=int(session_index),
            seed=int(seed),
            mount_offset_mm=_pair(rng.normal(0.0, MOUNT_OFFSET_SD_MM, 2)),
            mount_tilt_deg=_pair(rng.normal(0.0, MOUNT_TILT_SD_DEG, 2)),
            preload_mm=float(rng.uniform(0.0, PRELOAD_MAX_MM)),
            ft_bias=tuple(float(v) for v in rng.normal(0.0, FT_BIAS_STEP_SD)),
            temperature_offset_c=float(rng.normal(0.0, TEMPERATURE_OFFSET_SD_C)),
            led_output_factor=float((1.0 - LED_DECLINE_PER_SESSION * led_rate) ** k),
            modulus_factor=float(
                1.0 + STIFFENING_MAX * stiff_rate * (1.0 - np.exp(-k / STIFFENING_SESSIONS))
            ),
            scene_seed=int(rng.integers(2**31 - 1)),
            noise_seed=int(rng.integers(2**31 - 1)),
        )

    def apply_unit(self, unit: UnitParams) -> UnitParams:
        """The unit as mounted and aged for this session."""
        return replace(
            unit,
            contact_offset_xy=unit.contact_offset_xy + np.asarray(self.mount_offset_mm),
            mount_tilt_rad=unit.mount_tilt_rad + np.deg2rad(self.mount_tilt_deg),
            preload_mm=unit.preload_mm + self.preload_mm,
            ft_bias_offset=unit.ft_bias_offset + np.asarray(self.ft_bias),
            led_gain=unit.led_gain * self.led_output_factor,
            e_star_mpa=unit.e_star_mpa * self.modulus_factor,
            shear_modulus_mpa=unit.shear_modulus_mpa * self.modulus_factor,
        )

    def apply_scene(self, scene: Scene) -> Scene:
        """The scene in this session's room (temperature offset on its whole course)."""
        env = replace(scene.env, temperature_c=scene.env.temperature_c + self.temperature_offset_c)
        return replace(scene, env=env)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready (dataset metadata)."""
        d = asdict(self)
        return {k: list(v) if isinstance(v, tuple) else v for k, v in d.items()}


def _pair(v: np.ndarray) -> tuple[float, float]:
    return (float(v[0]), float(v[1]))
