"""Where a recording of `duration_s` (or of `samples`) ends: after exactly the samples whose
integration windows start within that much of the sensor's clock (or after exactly that many
samples), whatever the host was doing.

The recorder stops the stream once the samples cover the duration, but a device that runs ahead
of the host (a simulation at speed=max, a backlog after a stall) has sent more by then. Cutting
on device time instead of arrival makes two recordings of the same simulated scene hold the same
samples; so does a sample count (the samples that arrived before the recorder saw its count
reached and stopped the stream, one to a few by host timing, are not written). Sensor time
adds up over connection epochs (a reconnect may restart the device clock), as
`Recorder.sensor_s` does.

>>> from spectratac.protocol import decode_frame, encode_frame
>>> def sample(seq, t0):
...     msg = m.Sample(sample_seq=seq, t_start_us=t0, t_end_us=t0 + 50_000)
...     return decode_frame(encode_frame(msg, seq=seq)[:-1])
>>> cut = DurationCut(0.1)
>>> [f.message.sample_seq for f in cut.keep([sample(k, 1000 + 50_000 * k) for k in range(4)])]
[0, 1]
>>> cut.reached, cut.kept
(True, 2)
>>> cut = DurationCut(None, samples=3)
>>> [f.message.sample_seq for f in cut.keep([sample(k, 1000 + 50_000 * k) for k in range(5)])]
[0, 1, 2]
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from spectratac.device.records import Unwrapper
from spectratac.protocol import Frame
from spectratac.protocol.generated import messages as m


class DurationCut:
    def __init__(self, duration_s: float | None, samples: int | None = None) -> None:
        self.limit_us = math.inf if duration_s is None else duration_s * 1e6
        self.max_samples = samples
        self._done_us = 0.0  # sensor time of closed epochs
        self._first_us: int | None = None  # this epoch's first window start
        self._last_end_us = 0
        self._unwrap = Unwrapper()
        self.reached = False
        self.kept = 0  # SAMPLE frames kept

    @property
    def kept_s(self) -> float:
        """Seconds of the sensor's clock the kept samples cover (first start to last end)."""
        if self._first_us is None:
            return self._done_us / 1e6
        return (self._done_us + self._last_end_us - self._first_us) / 1e6

    def new_epoch(self) -> None:
        """A reconnect: the device clock may restart; the sensor time so far is kept."""
        if self._first_us is not None:
            self._done_us += self._last_end_us - self._first_us
        self._first_us = None
        self._unwrap = Unwrapper()

    def keep(self, frames: Sequence[Frame]) -> list[Frame]:
        """`frames` (protocol Frames, in arrival order) without the SAMPLE frames past the
        duration and the ESTIMATE frames after the first of those."""
        kept: list[Frame] = []
        for frame in frames:
            msg = frame.message
            if isinstance(msg, m.Sample) and not self.reached:
                t_end = self._unwrap(msg.t_end_us)
                t_start = t_end - ((msg.t_end_us - msg.t_start_us) & 0xFFFF_FFFF)
                if self._first_us is None:
                    self._first_us = t_start
                full = self.max_samples is not None and self.kept >= self.max_samples
                if full or self._done_us + t_start - self._first_us >= self.limit_us:
                    self.reached = True
                else:
                    self._last_end_us = t_end
                    self.kept += 1
            if self.reached and isinstance(msg, (m.Sample, m.Estimate)):
                continue
            kept.append(frame)
        return kept
