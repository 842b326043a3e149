"""Unit parameters: every constant of the forward model, nominal values and seeded variation.

One `UnitParams` is one physical sensor. `UnitParams.nominal()` is the design; `from_seed(s)`
draws a unit with the assembly and component spread listed in `VARIATION` (see MODEL.md for
each constant's source or reasoning). Count-like constants are in counts per 50 ms integration
at gain x1, DG x1, high sensitivity ("reference counts").

>>> u = UnitParams.from_seed(7)
>>> bool(np.all(u.direct > 0)), u.direct.shape, u.spectral.shape
(True, (3, 3, 3), (3, 5, 3))
>>> bool(UnitParams.from_seed(7).led_gain[0, 0] == u.led_gain[0, 0])
True
"""

from __future__ import annotations

from dataclasses import dataclass, fields, replace

import numpy as np
from numpy.typing import NDArray

from spectratac.twin.errors import TwinError
from spectratac.twin.geometry import LED_XY, SENSOR_XY

F64 = NDArray[np.float64]

# --- optical design constants (nominal) ------------------------------------------------------
# Channel (R, G, B, C, IR) response to LED colour (R 625 nm, G 525 nm, B 465 nm), read off the
# VEML3328 normalised spectral-response curves at the LED peaks (approximate, +-0.05).
SPECTRAL_NOMINAL = np.array(
    [
        [0.90, 0.06, 0.02],  # R
        [0.10, 0.80, 0.18],  # G
        [0.01, 0.12, 0.75],  # B
        [0.85, 0.90, 0.70],  # C (broadband)
        [0.03, 0.005, 0.005],  # IR (only the red LED's long tail)
    ]
)
# Reference counts per LED colour at duty 1 along an adjacent (5.5 mm) LED->sensor path.
DIRECT_ADJACENT_COUNTS = np.array([20000.0, 20000.0, 16000.0])
# In-slab decay length per colour (mm): blue is scattered/absorbed more by pigment and PDMS.
DECAY_LENGTH_MM = np.array([6.0, 5.0, 4.0])
# Ambient counts per lux per channel (G ~ lux) for each ambient spectrum, before the skin.
AMBIENT_COUNTS_PER_LUX = {
    "led": np.array([2.0, 2.6, 2.1, 6.8, 0.1]),
    "fluorescent": np.array([2.2, 2.6, 2.0, 6.9, 0.3]),
    "incandescent": np.array([4.2, 2.6, 1.0, 8.3, 10.4]),
    "sunlight": np.array([2.6, 2.6, 2.3, 7.3, 3.9]),
}


@dataclass(frozen=True)
class UnitParams:
    """All parameters of one simulated sensor ([j] = LED, [k] = sensor, [c] = colour)."""

    sensor_xy: F64  # (3, 2) mm
    led_xy: F64  # (3, 2) mm
    led_gain: F64  # (3 LEDs, 3 colours) relative intensity at duty 1 (LED binning spread)
    led_droop_per_c: F64  # (3,) fractional intensity change per °C of junction temperature
    led_self_heating_c: float  # junction rise at all nine channels on at duty 1 (°C)
    led_thermal_tau_s: float  # board + LED thermal time constant
    direct: F64  # (3, 3, 3) reference counts per duty for path j->k, colour c (no contact)
    transport_temp_coeff: float  # fractional transport change per °C (PDMS dn/dT, expansion)
    spectral: F64  # (3 sensors, 5 channels, 3 colours) channel response to LED colours
    dark_counts: F64  # (3, 5) dark counts per 50 ms at 25 °C (doubles per 10 °C)
    skin_transmission: float  # ambient light fraction reaching the sensors through the skin
    # contact mechanics
    e_star_mpa: float  # effective Hertz modulus of the skin-on-PDMS stack
    max_indent_mm: float  # indentation ceiling of the 3.2 mm elastomer (tanh saturation)
    shear_modulus_mpa: float  # Mindlin tangential stiffness 8 G a
    max_shear_mm: float
    creep_beta: F64  # (2,) Prony creep amplitudes (Lee-Radok)
    creep_tau_s: F64  # (2,) Prony creep time constants
    shear_creep_beta: F64  # (2,) shear creep amplitudes (silicone creeps more in shear)
    shear_creep_tau_s: F64  # (2,)
    # light transport under contact
    optical_height_mm: float  # kernel softening: PDMS height above the apertures + diffusion
    reflect_gain: float  # reference counts per duty per mm^3 of displaced skin (patch term)
    patch_floor_mm: float  # skin bending widens the reflecting patch beyond the Hertz radius
    reflect_colour: F64  # (3,) relative skin reflectance per colour (black pigment: red-heavy)
    reflect_strain: F64  # (3,) reflectance increase per mm of indentation (skin thins)
    shadow_strength: F64  # (3,) fractional path loss per mm of indentation on the path
    shadow_width_mm: float  # added to the contact radius: lateral spread of a path
    bulk_gain: F64  # (3,) fractional gain of all paths per mm of indentation (compression)
    patch_shift: float  # fraction of the surface shear displacement seen by the patch
    tilt_gain: float  # per mm of shear: reflection tilts toward the shear direction
    steer_gain: F64  # (3,) per mm of shear: guided light steered along the shear direction
    # electronics and noise
    electrons_per_count: float  # at gain x1: sets shot noise
    read_noise_counts: float
    led_flicker: float  # per-window relative intensity noise of each LED channel
    # reference F/T sensor
    ft_noise: F64  # (6,) white noise std at 1 kHz: N, N, N, N·m, N·m, N·m
    ft_bias_std: F64  # (6,) slow bias wander std (Ornstein-Uhlenbeck)
    ft_bias_tau_s: float
    ft_origin_z_mm: float  # F/T sensing origin below the PCB top (lever arm for torques)

    @staticmethod
    def nominal() -> UnitParams:
        d = np.linalg.norm(LED_XY[:, None, :] - SENSOR_XY[None, :, :], axis=-1)  # (j, k)
        direct = DIRECT_ADJACENT_COUNTS * np.exp(-(d[..., None] - 5.5) / DECAY_LENGTH_MM)
        return UnitParams(
            sensor_xy=SENSOR_XY.copy(),
            led_xy=LED_XY.copy(),
            led_gain=np.ones((3, 3)),
            led_droop_per_c=np.array([-0.008, -0.003, -0.0015]),
            led_self_heating_c=12.0,
            led_thermal_tau_s=40.0,
            direct=direct,
            transport_temp_coeff=-0.001,
            spectral=np.broadcast_to(SPECTRAL_NOMINAL, (3, 5, 3)).copy(),
            dark_counts=np.full((3, 5), 3.0),
            skin_transmission=2e-3,
            e_star_mpa=1.5,
            max_indent_mm=1.6,
            shear_modulus_mpa=0.35,
            max_shear_mm=1.5,
            creep_beta=np.array([0.16, 0.12]),
            creep_tau_s=np.array([0.5, 8.0]),
            shear_creep_beta=np.array([0.15, 0.10]),
            shear_creep_tau_s=np.array([0.3, 5.0]),
            optical_height_mm=2.0,
            reflect_gain=20000.0,
            patch_floor_mm=1.0,
            reflect_colour=np.array([1.0, 0.35, 0.12]),
            reflect_strain=np.array([0.3, 0.1, 0.0]),
            shadow_strength=np.array([0.08, 0.30, 0.75]),
            shadow_width_mm=0.8,
            bulk_gain=np.array([0.03, 0.03, 0.03]),
            patch_shift=0.6,
            tilt_gain=1.0,
            steer_gain=np.array([0.21, 0.21, 0.21]),
            electrons_per_count=3.0,
            read_noise_counts=2.0,
            led_flicker=0.002,
            ft_noise=np.array([0.01, 0.01, 0.02, 3e-4, 3e-4, 2e-4]),
            ft_bias_std=np.array([0.01, 0.01, 0.02, 2e-4, 2e-4, 1e-4]),
            ft_bias_tau_s=120.0,
            ft_origin_z_mm=-9.0,
        )

    @staticmethod
    def from_seed(seed: int) -> UnitParams:
        """A unit drawn around nominal with the spreads in `VARIATION`; same seed, same unit."""
        if not isinstance(seed, (int, np.integer)) or seed < 0:
            raise TwinError(f"unit seed must be a non-negative int, got {seed!r}")
        rng = np.random.default_rng([int(seed), 0x0717])
        u = UnitParams.nominal()
        changes: dict[str, object] = {}
        for name, (kind, spread) in VARIATION.items():
            value = getattr(u, name)
            shape = np.shape(value)
            if kind == "abs":
                draw = value + rng.normal(0.0, spread, shape)
            else:
                draw = value * np.exp(rng.normal(0.0, spread, shape))
            changes[name] = float(draw) if shape == () else draw
        return replace(u, **changes)

    def validate(self) -> None:
        for f in fields(self):
            v = np.asarray(getattr(self, f.name), dtype=np.float64)
            if not np.all(np.isfinite(v)):
                raise TwinError(f"unit parameter {f.name} is not finite")


# Unit-to-unit spread: ("rel", sigma) = lognormal relative, ("abs", sigma) = additive.
VARIATION: dict[str, tuple[str, float]] = {
    "sensor_xy": ("abs", 0.05),  # pick-and-place tolerance (mm)
    "led_xy": ("abs", 0.05),
    "led_gain": ("rel", 0.08),  # LED intensity binning
    "direct": ("rel", 0.10),  # moulding, aperture and solder-height spread per path
    "spectral": ("rel", 0.03),  # filter spread between sensor dies
    "dark_counts": ("rel", 0.4),
    "skin_transmission": ("rel", 0.3),  # pigment loading of the skin
    "e_star_mpa": ("rel", 0.08),  # PDMS mixing-ratio / cure spread
    "shear_modulus_mpa": ("rel", 0.08),
    "optical_height_mm": ("rel", 0.03),
    "reflect_gain": ("rel", 0.10),
    "shadow_strength": ("rel", 0.08),
    "steer_gain": ("rel", 0.08),
}
