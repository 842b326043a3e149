"""VEML3328 electronics: settings, integration/gain scaling, noise, quantisation, saturation.

A count rate in reference counts (per 50 ms, gain x1, DG x1, high sensitivity) becomes a
16-bit reading: photo-electrons scale with integration time and sensitivity (SENS low = 1/3
photodiode area), the analog gain (x1/2, x1, x2, x4) amplifies them, shot noise follows the
electron count and read noise is added, the ADC rounds to an integer, the digital gain DG
(x1, x2, x4) multiplies the integer and the result clips at 65535.

>>> cfg = SensorConfig(integration_ms=100, gain=2.0)
>>> cfg.scale, hex(cfg.to_conf())
(4.0, '0x410')
>>> SensorConfig.from_conf(cfg.to_conf()) == cfg
True
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from spectratac.hardware.generated import veml3328 as chip
from spectratac.twin.errors import TwinError
from spectratac.twin.unit import UnitParams

F64 = NDArray[np.float64]

# The part's facts come from hardware/definitions/veml3328.toml (generated
# spectratac.hardware.generated.veml3328).
FULL_SCALE = chip.FULL_SCALE
INTEGRATION_MS = chip.INTEGRATION_MS  # by IT code
GAIN_BITS = dict(enumerate(chip.GAINS))  # gain code -> analogue gain
DG_BITS = dict(enumerate(chip.DIGITAL_GAINS))  # DG code -> factor (0b11 reserved: x1 here)
LOW_SENS_FACTOR = 1.0 / 3.0  # SENS = 1: low sensitivity, 1/3 of high

# CONF register bits.
SD0 = chip.CONF_SD0
TRIG = chip.CONF_TRIG
AF = chip.CONF_AF
SENS = chip.CONF_SENS
SD_ALS = chip.CONF_SD_ALS
SD1 = chip.CONF_SD1


@dataclass(frozen=True)
class SensorConfig:
    """Measurement settings of one VEML3328 (the fields of CONF that shape a reading)."""

    integration_ms: int = 50
    gain: float = 1.0
    dg: int = 1
    sens_low: bool = False

    def __post_init__(self) -> None:
        if self.integration_ms not in INTEGRATION_MS:
            raise TwinError(
                f"integration_ms must be one of {INTEGRATION_MS}, got {self.integration_ms!r}"
            )
        if self.gain not in GAIN_BITS.values():
            raise TwinError(f"gain must be one of 0.5, 1, 2, 4, got {self.gain!r}")
        if self.dg not in DG_BITS.values():
            raise TwinError(f"dg must be one of 1, 2, 4, got {self.dg!r}")

    @property
    def analog_scale(self) -> float:
        """Analog counts per reference count (before DG)."""
        sens = LOW_SENS_FACTOR if self.sens_low else 1.0
        return self.integration_ms / 50.0 * self.gain * sens

    @property
    def scale(self) -> float:
        """Output counts per reference count."""
        return self.analog_scale * self.dg

    def to_conf(self) -> int:
        """CONF register value (powered on, continuous mode) for these settings."""
        it = INTEGRATION_MS.index(self.integration_ms)
        g = next(b for b, v in GAIN_BITS.items() if v == self.gain)
        d = next(b for b, v in DG_BITS.items() if v == self.dg)
        return (
            (d << chip.CONF_DG_SHIFT)
            | (g << chip.CONF_GAIN_SHIFT)
            | (SENS if self.sens_low else 0)
            | (it << chip.CONF_IT_SHIFT)
        )

    @staticmethod
    def from_conf(conf: int) -> SensorConfig:
        return SensorConfig(
            integration_ms=INTEGRATION_MS[(conf & chip.CONF_IT_MASK) >> chip.CONF_IT_SHIFT],
            gain=GAIN_BITS[(conf & chip.CONF_GAIN_MASK) >> chip.CONF_GAIN_SHIFT],
            dg=DG_BITS.get((conf & chip.CONF_DG_MASK) >> chip.CONF_DG_SHIFT, 1),
            sens_low=bool(conf & SENS),
        )


def expected_counts(rates: F64, cfg: SensorConfig, unit: UnitParams, temp_c: F64) -> F64:
    """Noise-free analog counts (before DG): signal plus dark current (doubles per 10 °C)."""
    dark = unit.dark_counts * (2.0 ** ((np.asarray(temp_c)[..., None, None] - 25.0) / 10.0))
    return rates * cfg.analog_scale + dark * (cfg.integration_ms / 50.0 * cfg.gain)


def digitise(
    analog: F64, cfg: SensorConfig, unit: UnitParams, rng: np.random.Generator
) -> tuple[NDArray[np.uint16], NDArray[np.bool_]]:
    """Add shot + read noise, round, apply DG, clip at 65535.

    Returns counts (same shape, uint16) and a saturation flag per sensor (last axis reduced).
    """
    return digitise_noise(analog, rng.standard_normal(np.shape(analog)), cfg, unit)


def digitise_noise(
    analog: F64, noise: F64, cfg: SensorConfig, unit: UnitParams
) -> tuple[NDArray[np.uint16], NDArray[np.bool_]]:
    """`digitise` with its standard-normal draws given (same shape as `analog`), so that
    draws made in bulk ahead of time give the same counts as draws made one window at a time.
    """
    mean = np.maximum(np.nan_to_num(analog, nan=0.0, posinf=1e12), 0.0)
    var = mean * (cfg.gain / unit.electrons_per_count) + unit.read_noise_counts**2
    noisy = mean + np.sqrt(var) * noise
    digital = np.rint(np.clip(noisy, 0.0, 1e9)) * cfg.dg
    clipped = np.minimum(digital, FULL_SCALE)
    saturated = np.any(digital >= FULL_SCALE, axis=-1)
    return clipped.astype(np.uint16), saturated
