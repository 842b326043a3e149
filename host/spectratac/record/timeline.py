"""Message times on the sensor's clock: what recordings, clips and exported bags stamp
messages with, so that a session spans as many seconds on a player's timeline as the sensor
measured (a 30-s session at `sim://?speed=15` spans 30 s, not the 2 s the host took).

`Timeline` maps host monotonic seconds onto Unix nanoseconds: Unix time at the anchor (the
session's start), then `scale` sensor seconds per host second (the link's clock scale: 1 for
hardware, so hardware timelines are plain wall-clock times). A message timed by a device
clock is put at the host time that clock maps to (`LiveClock`, provisional while recording;
`spectratac dataset build` fits the clocks for good), a message with no device time at its
host arrival time. `Timeline.host` inverts the map (a bag's receive times back onto the
recording's host clock).

>>> tl = Timeline(unix_minus_monotonic_ns=1_000 * 10**9, anchor_monotonic=10.0, scale=15.0)
>>> tl.ns(12.0) - tl.ns(10.0), round(float(tl.host(tl.ns(12.0))), 9)
(30000000000, 12.0)
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from spectratac.fusion import ClockFitError, fit_clock

#: The bag metadata key (rosbag2 `custom_data`) and session key holding a Timeline.
KEY = "spectratac.timeline"
#: A fitted drift beyond this is the host's scheduling, not a clock (dataset.align.MAX_DRIFT).
_MAX_DRIFT = 0.02
#: Refit the provisional clock after this many new envelope points (one per batch).
_REFIT_EVERY = 64
#: Envelope points kept at full density (older ones are thinned).
_KEEP = 2048


@dataclass(frozen=True)
class Timeline:
    """host monotonic s -> Unix ns at `scale` sensor seconds per host second from the anchor."""

    unix_minus_monotonic_ns: int
    anchor_monotonic: float
    scale: float = 1.0

    def ns(self, host_s: float) -> int:
        """Unix ns of one host monotonic time (never negative: MCAP's times are unsigned)."""
        return max(self.unix_minus_monotonic_ns + round(self._seconds(host_s) * 1e9), 0)

    def ns_array(self, host_s: ArrayLike) -> np.ndarray:
        """Vectorised ns(): int64 Unix ns."""
        s = self._seconds(np.asarray(host_s, np.float64))
        ns = np.round(s * 1e9).astype(np.int64) + np.int64(self.unix_minus_monotonic_ns)
        return np.maximum(ns, 0)

    def host(self, unix_ns: ArrayLike) -> np.ndarray:
        """Host monotonic s of Unix ns on this timeline (the inverse of ns)."""
        t = (np.asarray(unix_ns, np.int64) - np.int64(self.unix_minus_monotonic_ns)) / 1e9
        return self.anchor_monotonic + (t - self.anchor_monotonic) / self.scale

    def _seconds(self, host_s: Any) -> Any:
        return self.anchor_monotonic + self.scale * (host_s - self.anchor_monotonic)

    def as_dict(self) -> dict[str, Any]:
        return {
            "unix_minus_monotonic_ns": self.unix_minus_monotonic_ns,
            "anchor_monotonic": self.anchor_monotonic,
            "scale": self.scale,
        }

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> Timeline:
        scale = float(d.get("scale") or 1.0)
        if not np.isfinite(scale) or scale <= 0:
            raise ValueError(f"timeline scale {scale!r}: must be a positive number")
        return cls(int(d["unix_minus_monotonic_ns"]), float(d["anchor_monotonic"]), scale)

    @classmethod
    def of_session(cls, session: dict[str, Any], clock_scale: float | None) -> Timeline:
        """A recording's timeline: its session's own (`timeline`), or for files written
        before it, anchored at the session's start with the link's clock scale."""
        if isinstance(session.get("timeline"), dict):
            return cls.from_dict(session["timeline"])
        return cls(
            int(session.get("unix_minus_monotonic_ns", 0)),
            float(session.get("started_monotonic", 0.0)),
            1.0 if clock_scale is None else float(clock_scale),
        )


class LiveClock:
    """A device clock (seconds) mapped to host seconds while a session is recorded.

    host = offset + sensor / scale: the offset is the lower envelope of (arrival - sensor /
    scale) seen so far (a transport's latency is never negative), and every _REFIT_EVERY
    batches the envelope's points are fitted with `spectratac.fusion.fit_clock` to follow
    the clock's drift. Provisional: early messages may sit a few ms late until a faster
    arrival comes; the dataset builder's fit (with the TIME_SYNC exchanges) is the accurate
    one. `scale` None (a device clock not tied to the host's, sim's speed=max): the offset
    is fixed by the first arrival, so device seconds stay seconds on the timeline."""

    def __init__(self, scale: float | None) -> None:
        self.tied = scale is not None
        self.scale = 1.0 if scale is None else float(scale)
        self.reset()

    def reset(self) -> None:
        """A new connection epoch: the device clock may have restarted."""
        self._offset: float | None = None
        self._drift = 0.0
        self._ref = 0.0
        self._points: list[tuple[float, float]] = []
        self._new = 0

    def to_host(self, sensor_s: np.ndarray, arrival: np.ndarray) -> np.ndarray:
        """Host seconds of `sensor_s`, a batch that arrived at `arrival` (host s), after
        taking the batch into the envelope."""
        s = np.asarray(sensor_s, np.float64) / self.scale
        a = np.asarray(arrival, np.float64)
        ok = np.isfinite(s) & np.isfinite(a)
        if ok.any():
            gap = a[ok] - s[ok]
            k = int(np.argmin(gap))
            if self._offset is None:
                self._offset, self._ref = float(gap[k]), float(s[ok][k])
            elif self.tied:
                self._track(float(s[ok][k]), float(a[ok][k]))
        if self._offset is None:
            return a
        return s + self._offset + self._drift * (s - self._ref)

    def map(self, sensor_s: np.ndarray) -> np.ndarray | None:
        """Host seconds of `sensor_s` by the fit so far, learning nothing (None: no fit yet)."""
        if self._offset is None:
            return None
        s = np.asarray(sensor_s, np.float64) / self.scale
        return s + self._offset + self._drift * (s - self._ref)

    def _track(self, s: float, a: float) -> None:
        here = self._offset + self._drift * (s - self._ref)  # type: ignore[operator]
        if a - s < here:
            self._offset -= here - (a - s)  # type: ignore[operator]
        self._points.append((s, a))
        if len(self._points) > 2 * _KEEP:  # bounded: every other point of the oldest half
            self._points = self._points[:_KEEP:2] + self._points[_KEEP:]
        self._new += 1
        if self._new >= _REFIT_EVERY and len(self._points) >= 8:
            self._new = 0
            xs, hs = np.array(self._points).T
            try:
                model = fit_clock(xs, hs)
            except ClockFitError:
                return
            if abs(model.drift) <= _MAX_DRIFT:
                self._ref, self._drift = model.sensor_ref, model.drift
                self._offset = model.host_ref - model.sensor_ref
