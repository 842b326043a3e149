"""The acquisition settings a hard-case scene carries, as the CONFIGURE a simulated device
boots with, so that a sim:// device plays the scene as `twin generate` does (saturated
under sunlight or full LED duty, dark at 0.2 % duty) instead of under the firmware's
defaults.

Settings are `generate_session` keywords (`twin.builtin_scenes.HardCase.settings`):
integration_ms, gain (x0.5..x4), dg (1, 2, 4), sens_low, led_steps (fractions of full duty,
(3, 3) or (steps, 3, 3)); missing ones take `Sensor.configure`'s defaults.

>>> msg = configure_message({"integration_ms": 400, "gain": 4.0, "led_steps": np.ones((3, 3))})
>>> msg.integration_ms, msg.gain, msg.led_step_count, msg.led_duty[0][0]
(400, 2, 1, (1000, 1000, 1000))
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from spectratac.protocol.generated import messages as m

_GAIN_CODE = {1.0: 0, 2.0: 1, 4.0: 2, 0.5: 3}
_DG_CODE = {1: 0, 2: 1, 4: 2}
DEFAULT_DUTY = 500  # permille, one white step: Sensor.configure's default
DEFAULT_SETTLE_US = 1000


def configure_message(settings: Mapping[str, Any]) -> m.Configure:
    """The CONFIGURE (not streaming) that applies `settings`; ValueError on a value the
    protocol cannot carry."""
    gain = float(settings.get("gain", 1.0))
    dg = int(settings.get("dg", 1))
    if gain not in _GAIN_CODE or dg not in _DG_CODE:
        raise ValueError(f"scene settings gain={gain}, dg={dg}: not a VEML3328 setting")
    steps = settings.get("led_steps")
    duty = (
        np.full((1, 3, 3), DEFAULT_DUTY)
        if steps is None
        else np.rint(np.asarray(steps, np.float64).reshape(-1, 3, 3) * 1000).astype(int)
    )
    if not 1 <= duty.shape[0] <= m.MAX_LED_STEPS or duty.min() < 0 or duty.max() > 1000:
        raise ValueError(f"scene settings led_steps {duty.shape}: 1..8 steps of duties 0..1")
    table = np.zeros((m.MAX_LED_STEPS, 3, 3), int)
    table[: duty.shape[0]] = duty
    return m.Configure(
        integration_ms=int(settings.get("integration_ms", 50)),
        gain=_GAIN_CODE[gain],
        digital_gain=_DG_CODE[dg],
        sensitivity=1 if settings.get("sens_low") else 0,
        flags=0,
        led_settle_us=DEFAULT_SETTLE_US,
        led_step_count=int(duty.shape[0]),
        led_duty=tuple(tuple(tuple(int(v) for v in led) for led in step) for step in table),
    )
