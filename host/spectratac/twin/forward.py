"""Noise-free forward model for quasi-static contacts (no creep history): the oracle's model
and the reference for the physical-property tests.

>>> import numpy as np
>>> u = UnitParams.nominal()
>>> z = np.zeros(1)
>>> c = expected_output(u, z, z, z, z, z, np.full(1, 4.0), np.full((3, 3), 0.25))
>>> c.shape, bool(20_000 < c[0, 0, 3] < 35_000)
((1, 3, 5), True)
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from spectratac.twin import optics
from spectratac.twin.electronics import SensorConfig, expected_counts
from spectratac.twin.mechanics import indentation, shear_displacement
from spectratac.twin.unit import UnitParams

F64 = NDArray[np.float64]


def deformation(
    unit: UnitParams, fx: F64, fy: F64, normal: F64, radius_mm: F64
) -> tuple[F64, F64, F64, F64]:
    """Quasi-static indentation, contact radius and shear displacement (mm)."""
    delta, a = indentation(normal, radius_mm, unit)
    ux, uy = shear_displacement(fx, fy, a, unit)
    return delta, a, ux, uy


def static_rates(
    unit: UnitParams,
    x: F64,
    y: F64,
    fx: F64,
    fy: F64,
    normal: F64,
    radius_mm: F64,
    led: F64,
    *,
    lux: float | F64 = 0.0,
    spectrum: str = "led",
    temperature_c: float | F64 = optics.REFERENCE_TEMP_C,
) -> F64:
    """Reference count rates (M, 3, 5) for M static contacts; `led` is the LED output
    (3, 3) or (M, 3, 3) (duty x gain x droop; see `optics.led_intensity`)."""
    m = np.shape(x)[0]
    delta, a, ux, uy = deformation(unit, fx, fy, normal, radius_mm)
    temp = np.broadcast_to(np.asarray(temperature_c, dtype=np.float64), (m,))
    ox, oy = (float(v) for v in unit.contact_offset_xy)  # as MechanicsTrack: board position
    paths = optics.transport(unit, x + ox, y + oy, delta, a, ux, uy, temp)
    led_m = np.broadcast_to(led, (m, 3, 3))
    amb = optics.ambient_rates(
        unit, np.broadcast_to(np.asarray(lux, dtype=np.float64), (m,)), spectrum
    )
    return optics.sensor_rates(unit, paths, led_m, amb)


def expected_output(
    unit: UnitParams,
    x: F64,
    y: F64,
    fx: F64,
    fy: F64,
    normal: F64,
    radius_mm: F64,
    duty: F64,
    cfg: SensorConfig | None = None,
    *,
    lux: float = 0.0,
    spectrum: str = "led",
    temperature_c: float = optics.REFERENCE_TEMP_C,
    junction_rise_c: float | None = None,
) -> F64:
    """Mean output counts (M, 3, 5), before noise and clipping, at LED `duty` (3, 3)."""
    cfg = cfg or SensorConfig()
    rise = (
        unit.led_self_heating_c * float(np.mean(duty))
        if junction_rise_c is None
        else junction_rise_c
    )
    led = optics.led_intensity(
        unit, np.asarray(duty, dtype=np.float64), np.asarray(temperature_c + rise)
    )
    rates = static_rates(
        unit,
        x,
        y,
        fx,
        fy,
        normal,
        radius_mm,
        led,
        lux=lux,
        spectrum=spectrum,
        temperature_c=temperature_c,
    )
    return expected_counts(rates, cfg, unit, np.full(np.shape(x)[0], temperature_c)) * cfg.dg
