"""ReplayFTSensor: an F/T "sensor" that replays rows loaded from a file (csv://, rosbag://).

The subclass's connect() loads every FT_RECORD row at once (so a bad file fails at open) and
calls `_setup`; this class releases them: as fast as possible by default, at `rate` rows per
second, or paced by their sensor_time (`realtime`, times `speed`). With `keep_host` the rows
keep the host_time the file gave them; otherwise each batch is stamped with its arrival
(time.monotonic()), as a live sensor's would be.
"""

from __future__ import annotations

import time

import numpy as np

from spectratac.ft.base import FTSensor
from spectratac.ft.sequence import SequenceTracker

_CHUNK = 65536


class ReplayFTSensor(FTSensor):
    """Releases preloaded FT_RECORD rows (see the module documentation for pacing)."""

    _rows: np.ndarray
    _keep_host: bool
    _rate: float | None
    _realtime: bool
    _speed: float
    _tracker: SequenceTracker
    _pos = 0
    _t0: float | None = None

    def _setup(
        self,
        rows: np.ndarray,
        *,
        keep_host: bool,
        rate: float | None,
        realtime: bool,
        speed: float,
    ) -> None:
        self._rows = rows
        self._keep_host = keep_host
        self._rate = rate
        self._realtime = realtime
        self._speed = speed
        self._tracker = SequenceTracker(self.stats)

    @property
    def keeps_file_times(self) -> bool:
        """Whether rows keep the host times the file gave them (else: their read time)."""
        return self._keep_host

    def _due(self, now: float) -> int:
        """How many rows a paced replay has released by `now`."""
        assert self._t0 is not None
        elapsed = (now - self._t0) * self._speed
        if self._rate is not None:
            return int(elapsed * self._rate) + 1
        times = self._rows["sensor_time"]
        return int(np.searchsorted(times, times[0] + elapsed, side="right"))

    def _poll(self, timeout: float) -> np.ndarray | None:
        n = len(self._rows)
        if self._pos >= n:
            return None
        if self._rate is None and not self._realtime:
            end = min(self._pos + _CHUNK, n)
        else:
            if self._t0 is None:
                self._t0 = time.monotonic()
            end = min(self._due(time.monotonic()), n)
            if end <= self._pos:
                time.sleep(min(timeout, 0.002))
                return self._rows[:0]
        batch = self._rows[self._pos : end].copy()
        self._pos = end
        if not self._keep_host:
            batch["host_time"] = time.monotonic()
        keep = self._tracker.update(batch["sequence"].astype(np.int64))
        return batch if keep.all() else batch[keep]
