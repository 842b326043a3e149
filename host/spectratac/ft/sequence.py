"""Sequence bookkeeping shared by the drivers: unwrapping wrapping counters and counting
lost, reordered and duplicate records from sequence numbers, batch by batch.

>>> u = Unwrapper(bits=8)
>>> u(np.array([250, 254, 2, 6])).tolist(), u(np.array([1])).tolist()
([250, 254, 258, 262], [257])
>>> from spectratac.ft.records import FTStats
>>> stats = FTStats()
>>> t = SequenceTracker(stats)
>>> t.update(np.array([1, 2, 5, 3, 3, 6])).tolist()
[True, True, True, True, False, True]
>>> stats.lost, stats.gaps, stats.reordered, stats.duplicates
(1, 1, 1, 1)
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from spectratac.ft.records import FTStats

I64 = NDArray[np.int64]

_MAX_TRACKED = 1 << 14  # missing sequence numbers remembered for late (reordered) arrivals


class Unwrapper:
    """Turns a wrapping `bits`-bit counter into a monotone int64 one (steps < half range)."""

    def __init__(self, bits: int = 32) -> None:
        self._mod = 1 << bits
        self._half = 1 << (bits - 1)
        self._last_raw: int | None = None
        self._last: int = 0

    def __call__(self, raw: NDArray[np.integer]) -> I64:
        values = np.asarray(raw).astype(np.int64)
        if values.size == 0:
            return values
        if self._last_raw is None:
            self._last_raw, self._last = int(values[0]), int(values[0])
        if values.size <= 16:  # a poll's worth of packets: plain ints beat NumPy's overhead
            prev, last, out_list = self._last_raw, self._last, []
            for v in values.tolist():
                last += (v - prev + self._half) % self._mod - self._half
                prev = v
                out_list.append(last)
            self._last_raw, self._last = prev, last
            return np.array(out_list, dtype=np.int64)
        steps = np.diff(values, prepend=self._last_raw)
        steps = (steps + self._half) % self._mod - self._half
        out = self._last + np.cumsum(steps)
        self._last_raw, self._last = int(values[-1]), int(out[-1])
        return out

    def rebase(self, start: int) -> None:
        """A new stream restarts the counter: raw value 0 now unwraps to `start`."""
        self._last_raw = 0
        self._last = start


class SequenceTracker:
    """Counts gaps (lost), late arrivals (reordered) and repeats (duplicates) into `stats`.

    update() returns which records to keep: everything except duplicates. A late record that
    fills a gap is taken back off `lost`."""

    def __init__(self, stats: FTStats) -> None:
        self.stats = stats
        self.expected: int | None = None
        self._missing: set[int] = set()

    def update(self, seq: I64) -> NDArray[np.bool_]:
        keep = np.ones(len(seq), dtype=bool)
        if len(seq) == 0:
            return keep
        first = int(seq[0])
        if (self.expected is None or first == self.expected) and (
            len(seq) == 1 or bool(np.all(np.diff(seq) == 1))
        ):
            self.expected = int(seq[-1]) + 1  # the common case: in order, nothing missing
            return keep
        if self.expected is None:
            self.expected = first
        st = self.stats
        for i, s in enumerate(seq.tolist()):
            if s >= self.expected:
                gap = s - self.expected
                if gap:
                    st.lost += gap
                    st.gaps += 1
                    if gap <= _MAX_TRACKED:
                        self._missing.update(range(self.expected, s))
                self.expected = s + 1
            elif s in self._missing:
                self._missing.discard(s)
                st.lost -= 1
                st.reordered += 1
            else:
                st.duplicates += 1
                keep[i] = False
        if len(self._missing) > _MAX_TRACKED:
            floor = self.expected - _MAX_TRACKED
            self._missing = {s for s in self._missing if s >= floor}
        return keep
