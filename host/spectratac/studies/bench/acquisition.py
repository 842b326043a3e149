"""Acquisition settings compared by the speed-versus-error benchmark: integration time and
LED sequencing, each at a fair exposure.

Fair exposure: every setting keeps the resting clear channel near the twin's reference level
(41 % of full scale: headroom for a firm press) while collecting as many photons as it can.
Longer windows first lower the analog gain (x1/2) and then the photodiode sensitivity
(SENS low, 1/3), which raises electrons per count (less shot noise); the LED duty then makes
up the rest. A step that lights 3 of the 9 LED channels gets 3x their duty.

LED sequences (duties as steps x 3 LEDs x R, G, B):
  white    one step, every channel on
  rgb      3 steps: all three LEDs red, then green, then blue
  per-led  3 steps: LED 1, then LED 2, then LED 3, each white

A full observation needs one integration per step, so it arrives at 1000 / (IT x S) Hz.

>>> a = Acquisition(400, "rgb")
>>> a.settings()["gain"], a.settings()["sens_low"], round(a.observations_per_s, 3)
(0.5, True, 0.833)
>>> a.led_steps().shape, round(float(a.led_steps()[0, 0, 0]), 4)
((3, 3, 3), 0.5625)
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from spectratac.errors import SpectraTacError
from spectratac.hardware.generated.veml3328 import INTEGRATION_MS

SEQUENCES = ("white", "rgb", "per-led")
REFERENCE_DUTY = 0.25  # all nine channels: clear ~41 % of full scale at 50 ms, x1 (twin)
# (gain, SENS low) per integration time: analog scale it/50 x gain x (1/3 if low) near 1.
_SETTINGS = {50: (1.0, False), 100: (0.5, False), 200: (0.5, True), 400: (0.5, True)}


class AcquisitionError(SpectraTacError):
    """An integration time or LED sequence the benchmark does not know."""


@dataclass(frozen=True)
class Acquisition:
    integration_ms: int = 50
    sequence: str = "white"

    def __post_init__(self) -> None:
        if self.integration_ms not in INTEGRATION_MS:
            raise AcquisitionError(
                f"integration time {self.integration_ms} ms: choose one of {INTEGRATION_MS}"
            )
        if self.sequence not in SEQUENCES:
            raise AcquisitionError(f"LED sequence {self.sequence!r}: choose one of {SEQUENCES}")

    @property
    def name(self) -> str:
        return f"{self.integration_ms}ms-{self.sequence}"

    @property
    def steps(self) -> int:
        return 1 if self.sequence == "white" else 3

    @property
    def observations_per_s(self) -> float:
        """Full observations (one integration per LED step) per second."""
        return 1000.0 / (self.integration_ms * self.steps)

    @property
    def analog_scale(self) -> float:
        gain, low = _SETTINGS[self.integration_ms]
        return self.integration_ms / 50.0 * gain * (1.0 / 3.0 if low else 1.0)

    def led_steps(self) -> NDArray[np.float64]:
        """(S, 3 LEDs, 3 colours) duties in [0, 1]."""
        if self.sequence == "white":
            lit = np.ones((1, 3, 3))
        elif self.sequence == "rgb":
            lit = np.zeros((3, 3, 3))
            for c in range(3):
                lit[c, :, c] = 1.0
        else:
            lit = np.zeros((3, 3, 3))
            for led in range(3):
                lit[led, led, :] = 1.0
        per_step = lit.reshape(lit.shape[0], -1).sum(axis=1)[:, None, None]
        duty = REFERENCE_DUTY * (9.0 / per_step) / self.analog_scale
        return np.minimum(lit * duty, 1.0)

    def settings(self) -> dict[str, Any]:
        """Keyword arguments for `spectratac.twin.generate_session`."""
        gain, low = _SETTINGS[self.integration_ms]
        return {
            "integration_ms": self.integration_ms,
            "gain": gain,
            "sens_low": low,
            "led_steps": self.led_steps(),
        }


def grid(integrations: tuple[int, ...] = INTEGRATION_MS, sequences: tuple[str, ...] = SEQUENCES):
    """Every combination, fastest observation rate first."""
    out = [Acquisition(i, s) for i in integrations for s in sequences]
    return sorted(out, key=lambda a: -a.observations_per_s)
