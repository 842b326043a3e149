"""Unit parameters: every constant of the forward model, nominal values and seeded variation.

One `UnitParams` is one physical sensor. `UnitParams.nominal()` is the design (on the built
layer stack, or any `LayerStack`); `from_seed(s)` draws a unit with the manufacturing
tolerances of hardware/definitions/params.toml `[tolerances]` (layer thicknesses, LED intensity and
colour bins, sensor gain, placement, mould alignment, elastomer modulus) plus the twin's own
model spreads in `VARIATION` (see MODEL.md for each constant's source or reasoning). Drawn
thicknesses flow through `stack.py` into the optics and mechanics. Count-like constants are in
counts per 50 ms integration at gain x1, DG x1, high sensitivity ("reference counts").

>>> u = UnitParams.from_seed(7)
>>> bool(np.all(u.direct > 0)), u.direct.shape, u.spectral.shape
(True, (3, 3, 3), (3, 5, 3))
>>> bool(UnitParams.from_seed(7).led_gain[0, 0] == u.led_gain[0, 0])
True
>>> UnitParams.nominal().pdms_mm, bool(u.pdms_mm != 2.5)
(2.5, True)
"""

from __future__ import annotations

from dataclasses import dataclass, fields, replace

import numpy as np
from numpy.typing import NDArray

from spectratac.hardware.generated import board
from spectratac.twin import stack as layers
from spectratac.twin.errors import TwinError
from spectratac.twin.geometry import LED_XY, SENSOR_XY
from spectratac.twin.stack import LayerStack

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
# Relative change of each channel's response (R, G, B, C, IR) per nm shift of the LED colour's
# dominant wavelength (colour binning), from the slopes of the datasheet's normalised response
# curves at 625/525/465 nm (approximate): e.g. the G channel's red tail falls steeply, the R
# channel's response to the green LED rises steeply toward red.
SPECTRAL_SLOPE_PER_NM = np.array(
    [
        [-0.010, 0.080, 0.000],  # R
        [-0.040, 0.005, 0.040],  # G
        [0.000, -0.050, -0.005],  # B
        [-0.005, 0.000, 0.005],  # C
        [0.050, 0.000, 0.000],  # IR
    ]
)
# Reference counts per LED colour at duty 1 along an adjacent (5.5 mm) LED->sensor path, on
# the nominal stack (other stacks: `stack.guide_spread_factor`).
DIRECT_ADJACENT_COUNTS = np.array([20000.0, 20000.0, 16000.0])
# In-slab decay length per colour (mm) on the nominal 2.5 mm PDMS (other stacks:
# `stack.decay_length_factor`): blue is scattered/absorbed more by pigment and PDMS.
DECAY_LENGTH_MM = np.array([6.25, 5.2, 4.15])
# Material (half-space) moduli of the skin-on-PDMS stack; the bonded thin layer stiffens them
# (`stack.modulus_factor`) to the effective Hertz E* = 1.56 MPa and G = 0.365 MPa nominal.
E_STAR_NOMINAL_MPA = 1.56
SHEAR_MODULUS_NOMINAL_MPA = 0.365
# Shadow per mm of indentation on the nominal PDMS (other stacks: `stack.shadow_factor`).
SHADOW_STRENGTH = np.array([0.08, 0.30, 0.75])
SKIN_TRANSMISSION = 2e-3  # nominal 0.5 mm skin (other thicknesses: Beer-Lambert in stack.py)
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

    pcb_mm: float  # layer stack of this unit (drawn around hardware/definitions/params.toml)
    pdms_mm: float
    skin_mm: float
    sensor_xy: F64  # (3, 2) mm
    led_xy: F64  # (3, 2) mm
    led_gain: F64  # (3 LEDs, 3 colours) relative intensity at duty 1 (LED binning spread)
    led_droop_per_c: F64  # (3,) fractional intensity change per °C of junction temperature
    led_self_heating_c: float  # junction rise at all nine channels on at duty 1 (°C)
    led_thermal_tau_s: float  # board + LED thermal time constant
    direct: F64  # (3, 3, 3) reference counts per duty for path j->k, colour c (no contact)
    transport_temp_coeff: float  # fractional transport change per °C (PDMS dn/dT, expansion)
    spectral: F64  # (3 sensors, 5 channels, 3 colours) channel response to LED colours
    led_wavelength_shift_nm: F64  # (3 LEDs, 3 colours) dominant-wavelength offset (binning)
    dark_counts: F64  # (3, 5) dark counts per 50 ms at 25 °C (doubles per 10 °C)
    skin_transmission: float  # ambient light fraction reaching the sensors through the skin
    # contact mechanics
    e_star_mpa: float  # effective Hertz modulus of the skin-on-PDMS stack
    max_indent_mm: float  # indentation ceiling of the elastomer (tanh saturation)
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
    # mounting (unit: mould alignment; one session: re-mounting, see session.py)
    contact_offset_xy: F64  # (2,) mm: where a press aimed at (x, y) lands on the board
    mount_tilt_rad: F64  # (2,) rotation of the sensor on the F/T about x and y
    preload_mm: float  # uniform compression of the stack by the mounting clamp
    ft_bias_offset: F64  # (6,) F/T offset left after taring (mounting stress, tare error)

    @property
    def stack(self) -> LayerStack:
        return LayerStack(self.pcb_mm, self.pdms_mm, self.skin_mm)

    def spectral_paths(self) -> F64:
        """(3 LEDs, 3 sensors, 5 channels, 3 colours): each channel's response to each LED
        colour, with the LED's colour bin shifting it along the response curves."""
        shift = np.exp(SPECTRAL_SLOPE_PER_NM[None] * self.led_wavelength_shift_nm[:, None, :])
        return self.spectral[None] * shift[:, None]

    @staticmethod
    def nominal(stack: LayerStack | None = None) -> UnitParams:
        """The design on the built stack, or on `stack` (thickness-dependent constants from
        `stack.py`)."""
        st = stack or LayerStack.board()
        d = np.linalg.norm(LED_XY[:, None, :] - SENSOR_XY[None, :, :], axis=-1)  # (j, k)
        decay = DECAY_LENGTH_MM * layers.decay_length_factor(st)
        direct = (
            layers.guide_spread_factor(st)
            * DIRECT_ADJACENT_COUNTS
            * np.exp(-(d[..., None] - 5.5) / decay)
        )
        stiff = layers.modulus_factor(st)
        return UnitParams(
            pcb_mm=float(st.pcb_mm),
            pdms_mm=float(st.pdms_mm),
            skin_mm=float(st.skin_mm),
            sensor_xy=SENSOR_XY.copy(),
            led_xy=LED_XY.copy(),
            led_gain=np.ones((3, 3)),
            led_droop_per_c=np.array([-0.008, -0.003, -0.0015]),
            led_self_heating_c=12.0,
            led_thermal_tau_s=40.0,
            direct=direct,
            transport_temp_coeff=-0.001,
            spectral=np.broadcast_to(SPECTRAL_NOMINAL, (3, 5, 3)).copy(),
            led_wavelength_shift_nm=np.zeros((3, 3)),
            dark_counts=np.full((3, 5), 3.0),
            skin_transmission=SKIN_TRANSMISSION * layers.skin_transmission_factor(st),
            e_star_mpa=E_STAR_NOMINAL_MPA * stiff,
            max_indent_mm=layers.max_indent_mm(st),
            shear_modulus_mpa=SHEAR_MODULUS_NOMINAL_MPA * stiff,
            max_shear_mm=layers.max_shear_mm(st),
            creep_beta=np.array([0.16, 0.12]),
            creep_tau_s=np.array([0.5, 8.0]),
            shear_creep_beta=np.array([0.15, 0.10]),
            shear_creep_tau_s=np.array([0.3, 5.0]),
            optical_height_mm=layers.optical_height_mm(st),
            reflect_gain=20000.0,
            patch_floor_mm=1.0,
            reflect_colour=np.array([1.0, 0.35, 0.12]),
            reflect_strain=np.array([0.3, 0.1, 0.0]),
            shadow_strength=SHADOW_STRENGTH * layers.shadow_factor(st),
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
            ft_origin_z_mm=layers.ft_origin_z_mm(st),
            contact_offset_xy=np.zeros(2),
            mount_tilt_rad=np.zeros(2),
            preload_mm=0.0,
            ft_bias_offset=np.zeros(6),
        )

    @staticmethod
    def from_seed(seed: int) -> UnitParams:
        """A unit drawn around nominal: layer thicknesses, colour bins, sensor gain and mould
        alignment from `TOLERANCES`, the other constants with the spreads in `VARIATION`;
        same seed, same unit."""
        if not isinstance(seed, (int, np.integer)) or seed < 0:
            raise TwinError(f"unit seed must be a non-negative int, got {seed!r}")
        rng = np.random.default_rng([int(seed), 0x0717])
        tol = np.random.default_rng([int(seed), 0x7013])
        nominal = LayerStack.board()
        # Thicknesses: normal draws, kept physical (far beyond 3 sigma never happens in practice).
        st = LayerStack(
            *(
                float(max(mean + tol.normal(0.0, TOLERANCES[name]), 0.5 * mean))
                for name, mean in (
                    ("pcb_mm", nominal.pcb_mm),
                    ("pdms_mm", nominal.pdms_mm),
                    ("skin_mm", nominal.skin_mm),
                )
            )
        )
        u = UnitParams.nominal(st)
        changes: dict[str, object] = {}
        for name, (kind, spread) in VARIATION.items():
            value = getattr(u, name)
            shape = np.shape(value)
            if kind == "abs":
                draw = value + rng.normal(0.0, spread, shape)
            else:
                draw = value * np.exp(rng.normal(0.0, spread, shape))
            changes[name] = float(draw) if shape == () else draw
        gain = np.exp(tol.normal(0.0, TOLERANCES["sensor_gain"], 3))
        changes["spectral"] = np.asarray(changes["spectral"]) * gain[:, None, None]
        changes["led_wavelength_shift_nm"] = tol.normal(0.0, TOLERANCES["led_wavelength"], (3, 3))
        changes["contact_offset_xy"] = tol.normal(0.0, TOLERANCES["mould_alignment"], 2)
        return replace(u, **changes)

    def validate(self) -> None:
        for f in fields(self):
            v = np.asarray(getattr(self, f.name), dtype=np.float64)
            if not np.all(np.isfinite(v)):
                raise TwinError(f"unit parameter {f.name} is not finite")


# Manufacturing tolerances (1-sigma), one source: hardware/definitions/params.toml [tolerances].
TOLERANCES: dict[str, float] = {
    "pcb_mm": board.TOLERANCES_BOARD_THICKNESS,
    "pdms_mm": board.TOLERANCES_PDMS_THICKNESS,
    "skin_mm": board.TOLERANCES_SKIN_THICKNESS,
    "led_intensity": board.TOLERANCES_LED_INTENSITY,
    "led_wavelength": board.TOLERANCES_LED_WAVELENGTH,
    "sensor_gain": board.TOLERANCES_SENSOR_GAIN,
    "placement": board.TOLERANCES_PLACEMENT,
    "mould_alignment": board.TOLERANCES_MOULD_ALIGNMENT,
    "elastomer_modulus": board.TOLERANCES_ELASTOMER_MODULUS,
}

# Unit-to-unit spread of single constants: ("rel", sigma) = lognormal relative, ("abs", sigma)
# = additive. Build tolerances come from TOLERANCES; the rest are the twin's model spreads.
# Layer thicknesses (and so optical height, decay, moduli, ceilings) are drawn in from_seed.
VARIATION: dict[str, tuple[str, float]] = {
    "sensor_xy": ("abs", TOLERANCES["placement"]),  # pick-and-place (mm)
    "led_xy": ("abs", TOLERANCES["placement"]),
    "led_gain": ("rel", TOLERANCES["led_intensity"]),  # LED intensity binning
    "direct": ("rel", 0.10),  # aperture and solder-height spread per path
    "spectral": ("rel", 0.03),  # filter spread between sensor dies, per channel and colour
    "dark_counts": ("rel", 0.4),
    "skin_transmission": ("rel", 0.3),  # pigment loading of the skin
    "e_star_mpa": ("rel", TOLERANCES["elastomer_modulus"]),  # PDMS mixing ratio / cure
    "shear_modulus_mpa": ("rel", TOLERANCES["elastomer_modulus"]),
    "reflect_gain": ("rel", 0.10),
    "shadow_strength": ("rel", 0.08),
    "steer_gain": ("rel", 0.08),
}
