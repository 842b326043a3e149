"""Light transport surrogate for every LED -> sensor path and colour, LEDs and ambient light.

T[j, k, c] is the reference count rate at sensor k from LED j's colour c at duty 1 (before the
sensor's spectral response). Without contact it is the unit's direct (guided + scattered)
transport. A contact changes it in three ways (MODEL.md gives each constant's reasoning):

1. shadow: the indented black skin dips into the light guide and absorbs light whose path
   runs beneath the contact; loss ~ depth x Gaussian of the distance from the contact to the
   LED->sensor segment, strongest for blue (scattered most, so travels highest in the slab);
2. reflection: the displaced skin patch (volume ~ a^2 delta) reflects light from LED j to
   sensor k with softened inverse-square kernels about the patch; red-heavy (pigment
   reflectance), growing as the skin thins; shear moves the patch and tilts it toward the shear
   direction, brightening the sensors downstream of the shear and dimming the others;
3. bulk: compression brings the skin closer everywhere, a small gain on every path;
4. steering: shear tilts the whole skin/PDMS interface, steering guided light along the shear:
   path j->k gains in proportion to u . (e_k - e_j) / |e_k - e_j| (e = unit position
   vectors), so the sensors downstream of the shear brighten and the upstream ones dim.

>>> u = UnitParams.nominal()
>>> z = np.zeros(1)
>>> T0 = transport(u, z, z, z, z, z, z)
>>> bool(np.allclose(T0[0], u.direct))
True
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from spectratac.twin.scene_model import AMBIENT_SPECTRA
from spectratac.twin.unit import AMBIENT_COUNTS_PER_LUX, UnitParams

F64 = NDArray[np.float64]

REFERENCE_TEMP_C = 25.0


def transport(
    unit: UnitParams,
    x: F64,
    y: F64,
    delta: F64,
    a: F64,
    ux: F64,
    uy: F64,
    temperature_c: F64 | None = None,
) -> F64:
    """Path transport T (M, 3 LEDs, 3 sensors, 3 colours) for M contact states."""
    delta = np.maximum(delta, 0.0)
    qx = x + unit.patch_shift * ux
    qy = y + unit.patch_shift * uy
    w2 = unit.optical_height_mm**2
    lx = qx[:, None] - unit.led_xy[None, :, 0]
    ly = qy[:, None] - unit.led_xy[None, :, 1]
    kl = (w2 / (lx * lx + ly * ly + w2)) ** 1.5  # (M, j): softened inverse square
    sx = unit.sensor_xy[None, :, 0] - qx[:, None]
    sy = unit.sensor_xy[None, :, 1] - qy[:, None]
    ds = np.sqrt(sx * sx + sy * sy)
    ks = (w2 / (ds * ds + w2)) ** 1.5  # (M, k)
    along = (ux[:, None] * sx + uy[:, None] * sy) / np.maximum(ds, 1e-6)
    tilt = np.maximum(1.0 + unit.tilt_gain * along, 0.0)
    vol = (a * a + unit.patch_floor_mm**2) * delta
    rho = unit.reflect_colour[None, :] * (1.0 + unit.reflect_strain[None, :] * delta[:, None])
    m = delta.shape[0]
    # Two (M, j, k, c) buffers worked in place: the full-size temporaries of the plain
    # expression cost more (allocation, page faults) than its arithmetic. Each product is the
    # plain expression's, operands in the same order up to commutation, so the values are too.
    out = np.empty((m, 3, 3, 3))
    tmp = np.empty((m, 3, 3, 3))
    # Shadow: distance from the (sheared) surface contact to each LED->sensor segment.
    px = (x + ux)[:, None, None]
    py = (y + uy)[:, None, None]
    ax = unit.led_xy[:, 0][None, :, None]
    ay = unit.led_xy[:, 1][None, :, None]
    abx = unit.sensor_xy[:, 0][None, None, :] - ax
    aby = unit.sensor_xy[:, 1][None, None, :] - ay
    s = np.clip(((px - ax) * abx + (py - ay) * aby) / (abx * abx + aby * aby), 0.0, 1.0)
    dx = px - ax - s * abx
    dy = py - ay - s * aby
    width = (a + unit.shadow_width_mm)[:, None, None]
    near = np.exp(-(dx * dx + dy * dy) / (2.0 * width * width))  # (M, j, k)
    strength = unit.shadow_strength[None, :] * delta[:, None]  # (M, c)
    np.multiply(strength[:, None, None, :], near[..., None], out=out)  # loss
    np.subtract(1.0, out, out=out)
    np.maximum(out, 0.02, out=out)  # shadow
    np.multiply(out, unit.direct[None], out=out)
    bulk = 1.0 + unit.bulk_gain[None, :] * (delta + unit.preload_mm)[:, None]  # (M, c)
    steer_dir = _steer_dir(unit)
    along_steer = (
        ux[:, None, None] * steer_dir[None, :, :, 0] + uy[:, None, None] * steer_dir[None, :, :, 1]
    )
    np.multiply(along_steer[..., None], unit.steer_gain[None, None, None, :], out=tmp)
    np.add(tmp, 1.0, out=tmp)
    np.maximum(tmp, 0.0, out=tmp)  # steer
    out *= tmp
    out *= bulk[:, None, None, :]
    patch = (unit.reflect_gain * vol[:, None] * kl)[:, :, None] * (ks * tilt)[:, None, :]
    np.multiply(patch[..., None], rho[:, None, None, :], out=tmp)  # reflection
    out += tmp
    t = out
    if temperature_c is not None:
        t *= (1.0 + unit.transport_temp_coeff * (temperature_c - REFERENCE_TEMP_C))[
            :, None, None, None
        ]
    return t


def _steer_dir(unit: UnitParams) -> F64:
    """(3 LEDs, 3 sensors, 2) unit vectors from LED j's to sensor k's bearing."""
    ej = unit.led_xy / np.linalg.norm(unit.led_xy, axis=1, keepdims=True)
    ek = unit.sensor_xy / np.linalg.norm(unit.sensor_xy, axis=1, keepdims=True)
    d = ek[None, :, :] - ej[:, None, :]
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


def led_intensity(unit: UnitParams, duty: F64, junction_c: F64, flicker: F64 | None = None) -> F64:
    """LED output (..., 3 LEDs, 3 colours): duty (PWM is far faster than a window, so the
    window sees the mean) x binning gain x thermal droop x optional per-window flicker."""
    droop = 1.0 + unit.led_droop_per_c * (np.asarray(junction_c)[..., None, None] - 25.0)
    out = duty * unit.led_gain * np.maximum(droop, 0.0)
    if flicker is not None:
        out = out * flicker
    return out


def led_junction_rise(unit: UnitParams, mean_duty: float, t: F64, prewarmed: bool) -> F64:
    """Self-heating of the LEDs above ambient for a constant mean duty switched on at t=0."""
    steady = unit.led_self_heating_c * mean_duty
    if prewarmed:
        return np.full(np.shape(t), steady)
    return steady * (1.0 - np.exp(-np.maximum(t, 0.0) / unit.led_thermal_tau_s))


def ambient_rates(unit: UnitParams, lux: F64, spectrum: str) -> F64:
    """Ambient leakage through the skin, reference counts (M, 3 sensors, 5 channels)."""
    if spectrum not in AMBIENT_SPECTRA:
        raise ValueError(spectrum)
    per = AMBIENT_COUNTS_PER_LUX[spectrum] * unit.skin_transmission
    return np.asarray(lux, dtype=np.float64)[:, None, None] * np.broadcast_to(per, (3, 5))[None]


def sensor_rates(unit: UnitParams, t_paths: F64, led: F64, ambient: F64) -> F64:
    """Reference count rates (N, 3 sensors, 5 channels) from transport (N, j, k, c) and LED
    output (N, j, c): each channel weights each LED's colours by its spectral response (which
    depends on the LED's colour bin, `UnitParams.spectral_paths`)."""
    big = t_paths.shape[0] > 64  # path optimisation pays for batches, costs ~20 µs for one
    tl = t_paths * led[:, :, None, :]
    return np.einsum("njkc,jkdc->nkd", tl, unit.spectral_paths(), optimize=big) + ambient
