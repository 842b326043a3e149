"""The twin column's note says what a session without a twin reference is: a recording of a
simulated device is not "real data" (the note once said so)."""

from __future__ import annotations

import numpy as np
from spectratac.dataset import Dataset
from spectratac.studies.oracle_floor import twin_oracle

CONFIG = {"integration_ms": 50, "gain": 1.0, "leds": [[[500, 500, 500]] * 3]}


def session_of(info: dict[str, object]) -> Dataset:
    ds = Dataset.generic(np.zeros((4, 1)), np.zeros(4), ["a"], ["Fz"])
    ds.meta.update(kind="spectratac", config=CONFIG, sessions=[info])
    return ds


def test_a_simulated_recording_is_called_simulated() -> None:
    url = "sim://?scene=tour&seed=3&speed=10"
    reason = twin_oracle(session_of({"source": "record", "url": url, "seed": 3})).reason
    assert "real" not in reason
    assert "recorded from a simulated device" in reason and url in reason
    assert "twin generate" in reason


def test_a_real_sensors_recording_is_called_real() -> None:
    reason = twin_oracle(session_of({"source": "record", "url": "/dev/ttyACM0"})).reason
    assert "real sensor" in reason and "simulated device" not in reason
