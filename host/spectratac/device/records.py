"""The sample record the host hands to users: one NumPy structured row per SAMPLE frame."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

#: One row per sample. Device times are unwrapped to 64 bits (µs since the device's clock
#: started in this `epoch`); host_time is time.monotonic() in seconds when the frame's bytes
#: were read. `epoch` counts the connections of the sensor: 0 for the first, +1 after every
#: reconnect (the device may have restarted, so device times and sequence numbers of two
#: epochs are not comparable). `flags` holds SAMPLE_* bits saying what the host had to fix.
SAMPLE_RECORD = np.dtype(
    [
        ("device_time_us", "<u8"),  # integration end (t_end_us), unwrapped
        ("t_start_us", "<u8"),  # integration start, unwrapped
        ("host_time", "<f8"),
        ("sequence", "<u4"),
        ("step", "u1"),
        ("config_id", "<u2"),
        ("counts", "<u2", (3, 5)),  # sensor x (R, G, B, C, IR)
        ("status", "u1", (3,)),  # SENSOR_* bits per sensor
        ("epoch", "<u2"),
        ("flags", "u1"),  # SAMPLE_* bits
    ]
)

#: The device sent t_start_us after t_end_us: the window is unknown; t_start_us is set to
#: device_time_us (a zero-length window) so that the row stays usable for its counts.
SAMPLE_TIME_INVERTED = 0x01
#: The window began before the first time of this epoch's unwrapped clock (its start lies
#: across a wrap of the device clock that the host never saw): t_start_us is clipped to 0.
SAMPLE_WINDOW_CLIPPED = 0x02


class Sample(NamedTuple):
    """A single sample, as yielded by iterating over a Sensor."""

    device_time_us: int
    t_start_us: int
    host_time: float
    sequence: int
    step: int
    config_id: int
    counts: tuple[tuple[int, ...], ...]
    status: tuple[int, ...]
    epoch: int = 0
    flags: int = 0


def to_array(samples: list[Sample]) -> np.ndarray:
    """Samples as SAMPLE_RECORD rows; raises OverflowError or ValueError on values a row
    cannot hold (Sensor builds only samples that fit)."""
    return np.array(samples, dtype=SAMPLE_RECORD) if samples else np.empty(0, SAMPLE_RECORD)


class Unwrapper:
    """Turns a wrapping u32 µs clock into a 64-bit one (forward steps < 2^31 µs)."""

    def __init__(self) -> None:
        self._high = 0
        self._last: int | None = None

    def __call__(self, t32: int) -> int:
        last = self._last
        if last is not None and t32 < last and last - t32 > 0x8000_0000:
            self._high += 1 << 32
        self._last = t32
        return self._high + t32
