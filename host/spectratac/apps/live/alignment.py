"""Live time alignment of the decoder's estimates with the reference F/T, and running MAE.

The same method the dataset builder uses (`spectratac.dataset.align`), run on a rolling
window: each device clock (the optical sensor's, the F/T's) is fitted onto the host's
monotonic clock with `spectratac.fusion.fit_clock` over the last `window_s` seconds of
(device time, arrival time) pairs, refitted every `refit_s`; the reference for an
estimate is the F/T averaged over its integration window (`window_average`), as in the
dataset. `scale` is device seconds per host second (a paced sim's speed, 1 for hardware);
None keeps the device clocks as they are (sim at speed=max, where they run ahead of the
host: both are scene time already). A fit costs 10-30 ms; with `background=True` (the live
session) it runs on a worker thread and the new model replaces the old when it is ready, so
the decoding thread never waits a whole fit (the p99 latency to the page doubled otherwise).
Each background clock fits on a thread of its own started with it (`_Fitter`), handed each
fit with a queue put: a thread started per fit made the decoding thread wait for the new
thread's first time slice, ~90 ms per refit on a machine at load 30. `close()` ends it.

>>> clock = LiveClock(scale=1.0)
>>> t = np.arange(0.0, 3.0, 0.05)
>>> clock.add(t, 100.002 + t * (1 + 1e-3) + np.where(np.arange(t.size) % 3, 0.004, 0.0))
>>> round(float(clock.to_host(4.0)), 4)
104.006
"""

from __future__ import annotations

import collections
import contextlib
import logging
import queue
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from spectratac.dataset.labels import CONTACT_N
from spectratac.fusion import ClockFitError, ClockModel, fit_clock, window_average
from spectratac.hardware.generated import vocabulary as vocab
from spectratac.record.schemas import RATE_CAP_HZ, RateCap

F64 = NDArray[np.float64]
WINDOW_S = 30.0
FT_WINDOW_S = 10.0  # the F/T streams hundreds of rows a second: a shorter fit and buffer
#: F/T rows per second of host time the tracker keeps: a window's average over an even subset
#: at this rate is the reference still, and its fit and buffer stay bounded at any F/T rate
TRACK_HZ = RATE_CAP_HZ
REFIT_S = 2.0
MIN_FIT_S = 2.0  # device seconds of pairs before a drift is fitted (offset only until then)
#: F/T rows either side of a window that its average looks at: the samples just outside it
#: (coverage) and enough rows for the median period that sets the gap limit (F/T >= 50 Hz).
NEAR_S = 0.25
#: F/T rows the buffer must hold before a window is judged: the gap limit is a few median
#: periods, and the median of the first two or three rows can be a dropout itself (rows at
#: 0, 1 and 65 ms gave a 32 ms period and a 62 ms hole passed as covered).
PERIOD_ROWS = 16


log = logging.getLogger("spectratac.apps.live")


class _Fitter:
    """A clock's fitting thread, started with the clock (before its session decodes) and
    handed each fit by a queue put, never started per fit. One per clock: the F/T clock's
    fits (thousands of pairs) do not hold up the sensor clock's."""

    def __init__(self) -> None:
        self._jobs: queue.SimpleQueue[Callable[[], None] | None] = queue.SimpleQueue()
        self._thread = threading.Thread(target=self._run, name="spectratac-live-clock",
                                        daemon=True)  # fmt: skip
        self._thread.start()

    def submit(self, job: Callable[[], None]) -> None:
        self._jobs.put(job)

    def close(self) -> None:
        """End the thread once the fit in hand (if any) has landed."""
        self._jobs.put(None)

    def _run(self) -> None:
        while (job := self._jobs.get()) is not None:
            try:
                job()
            except Exception:  # a failed fit keeps the previous model; the next may land
                log.exception("a live clock fit failed")


class LiveClock:
    """A device clock mapped onto the host clock, refitted as pairs arrive."""

    def __init__(
        self,
        scale: float | None,
        *,
        window_s: float = WINDOW_S,
        refit_s: float = REFIT_S,
        background: bool = False,
    ):
        self.scale = scale
        self.window_s = window_s
        self.refit_s = refit_s
        self.background = background
        self._idle = threading.Event()  # no background fit in progress
        self._idle.set()
        self._fitter = _Fitter() if background else None
        self._device: collections.deque[F64] = collections.deque()
        self._host: collections.deque[F64] = collections.deque()
        self._model: ClockModel | None = None
        self._offset = np.inf  # lowest host - device seen: the offset until the first fit
        self._refit_at = 0.0

    def add(self, device_s: ArrayLike, host_s: ArrayLike) -> None:
        """Pairs of (device time s, host arrival time s), in arrival order."""
        if self.scale is None:
            return
        d = np.asarray(device_s, dtype=np.float64).ravel() / self.scale
        h = np.asarray(host_s, dtype=np.float64).ravel()
        if not d.size:
            return
        self._offset = min(self._offset, float(np.min(h - d)))
        self._device.append(d)
        self._host.append(h)
        while len(self._host) > 1 and self._host[0][-1] < h[-1] - self.window_s:
            self._device.popleft()
            self._host.popleft()
        now = time.monotonic()
        if self._device[-1][-1] - self._device[0][0] < MIN_FIT_S:
            return
        if not self._idle.is_set():
            return  # one fit at a time; the next is due once it has landed
        if now >= self._refit_at or self._model is None:
            self._refit_at = now + self.refit_s
            device, host = np.concatenate(self._device), np.concatenate(self._host)
            if not self.background:
                self._refit(device, host)
                return
            assert self._fitter is not None
            self._idle.clear()
            self._fitter.submit(lambda: self._background_refit(device, host))

    def _background_refit(self, device: F64, host: F64) -> None:
        try:
            self._refit(device, host)
        finally:
            self._idle.set()

    def _refit(self, device: F64, host: F64) -> None:
        # fewer than two distinct times: the lowest offset seen serves meanwhile
        with contextlib.suppress(ClockFitError):
            self._model = fit_clock(device, host)  # one reference swap: atomic for readers

    def wait(self, timeout: float | None = None) -> None:
        """Until a background fit in progress has landed."""
        self._idle.wait(timeout)

    def close(self) -> None:
        """End the background fitting thread (idempotent; the model stays usable)."""
        if self._fitter is not None:
            self._fitter.close()
            self._fitter = None

    def to_host(self, device_s: ArrayLike) -> F64:
        d = np.asarray(device_s, dtype=np.float64)
        if self.scale is None:
            return d
        if self._model is not None:
            return self._model.to_host(d / self.scale)
        return d / self.scale + (self._offset if np.isfinite(self._offset) else 0.0)


class _Rows:
    """The F/T rows of the last `keep_s` seconds, in time order, in one growing buffer:
    appending costs the new rows, not a copy of the whole buffer per batch."""

    def __init__(self, width: int) -> None:
        self._t = np.empty(1024)
        self._w = np.empty((1024, width))
        self._lo = self._hi = 0

    @property
    def t(self) -> F64:
        return self._t[self._lo : self._hi]

    @property
    def w(self) -> F64:
        return self._w[self._lo : self._hi]

    def append(self, t: F64, w: F64, keep_s: float) -> None:
        n, live = t.size, self._hi - self._lo
        if self._hi + n > self._t.size:  # compact (and grow): at most once per `live` rows
            cap = max(2 * (live + n), 1024)
            nt, nw = np.empty(cap), np.empty((cap, self._w.shape[1]))
            nt[:live], nw[:live] = self.t, self.w
            self._t, self._w, self._lo, self._hi = nt, nw, 0, live
        back = live > 0 and n > 0 and t[0] < self._t[self._hi - 1]
        self._t[self._hi : self._hi + n], self._w[self._hi : self._hi + n] = t, w
        self._hi += n
        if back or np.any(np.diff(t) < 0):  # a clock refit moved time back: reorder
            order = np.argsort(self.t, kind="stable")
            self._t[self._lo : self._hi], self._w[self._lo : self._hi] = (
                self.t[order],
                self.w[order],
            )
        if self._hi > self._lo:
            self._lo += int(np.searchsorted(self.t, self._t[self._hi - 1] - keep_s))


@dataclass
class Pending:
    key: int
    t_start: float  # host clock
    t_end: float
    predicted: F64  # (6,) Fx Fy Fz Tx Ty Tz, NaN where not decoded


class RunningMAE:
    """Mean absolute error per axis over the windows added so far."""

    def __init__(self) -> None:
        self.abs_sum = np.zeros(len(vocab.FT_AXES))
        self.count = np.zeros(len(vocab.FT_AXES), dtype=np.int64)
        self.windows = 0

    def add(self, err: F64) -> None:
        ok = np.isfinite(err)
        self.abs_sum[ok] += err[ok]
        self.count[ok] += 1
        self.windows += 1

    def per_axis(self) -> dict[str, float | None]:
        """Per axis (None for axes not decoded yet)."""
        return {
            a: (float(self.abs_sum[i] / self.count[i]) if self.count[i] else None)
            for i, a in enumerate(vocab.FT_AXES)
        }


class ReferenceTracker:
    """Pairs estimates with the reference F/T over their windows; keeps the running MAE,
    overall and in contact (reference |F| >= `contact_n`)."""

    def __init__(
        self,
        clock: LiveClock,
        *,
        keep_s: float = FT_WINDOW_S,
        max_pending: int = 100,
        contact_n: float = CONTACT_N,
    ):
        self.clock = clock
        self.keep_s = keep_s
        self.max_pending = max_pending
        self.contact_n = contact_n
        self._rows = _Rows(6)
        self._cap = RateCap(TRACK_HZ)
        self.thinned = 0  # rows of a stream faster than TRACK_HZ left out
        self._pending: collections.deque[Pending] = collections.deque()
        self.overall = RunningMAE()
        self.contact = RunningMAE()

    def add_ft(self, rows: np.ndarray) -> None:
        """FT_RECORD rows as they arrive; of a stream faster than TRACK_HZ an even subset,
        with each batch's earliest-arriving row (what the clock's lower envelope follows)."""
        if not len(rows):
            return
        times = rows["host_time"]
        keep = np.arange(len(rows))[self._cap.take(len(rows), float(times[-1]), float(times[0]))]
        if len(keep) < len(rows):
            early = int(np.argmin(times - rows["sensor_time"] / (self.clock.scale or 1.0)))
            keep = np.union1d(keep, [early])
            self.thinned += len(rows) - len(keep)
            rows = rows[keep]
        self.clock.add(rows["sensor_time"], rows["host_time"])
        t = self.clock.to_host(rows["sensor_time"])
        self._rows.append(t, rows["wrench"].astype(np.float64), self.keep_s)

    def add_estimate(self, key: int, t_start: float, t_end: float, predicted: ArrayLike) -> None:
        self._pending.append(Pending(key, t_start, t_end, np.asarray(predicted, np.float64)))

    def ready(self) -> list[tuple[int, float, F64]]:
        """(key, window end, reference wrench (6,)) of the windows the F/T now covers, in
        order; windows it will never cover (a dropout, F/T stopped) are given up once
        `max_pending` wait behind them."""
        out: list[tuple[int, float, F64]] = []
        last = self._rows.t[-1] if self._rows.t.size >= PERIOD_ROWS else -np.inf
        while self._pending:
            p = self._pending[0]
            if p.t_end > last:
                if len(self._pending) <= self.max_pending:
                    break
                self._pending.popleft()  # never covered: a dropout, or the F/T stopped
                continue
            self._pending.popleft()
            mean, valid = self._average(p.t_start, p.t_end)
            if not valid[0]:
                continue
            ref = mean[0]
            err = np.abs(p.predicted - ref)
            self.overall.add(err)
            if np.linalg.norm(ref[:3]) >= self.contact_n:
                self.contact.add(err)
            out.append((p.key, p.t_end, ref))
        return out

    def _average(self, t_start: float, t_end: float) -> tuple[F64, NDArray[np.bool_]]:
        """`window_average` over the F/T rows near the window only (time-sorted buffer):
        over the whole 10 s buffer of a 1 kHz F/T it cost ~10 ms per estimate, which on a
        loaded machine was most of the page's latency."""
        t, w = self._rows.t, self._rows.w
        lo = int(np.searchsorted(t, t_start - NEAR_S))
        hi = int(np.searchsorted(t, t_end + NEAR_S, side="right"))
        mean, valid, _ = window_average(t[lo:hi], w[lo:hi], [t_start], [t_end])
        return mean, valid

    def mae(self) -> dict[str, float | None]:
        """Running mean absolute error per axis over every window (None: not decoded yet)."""
        return self.overall.per_axis()

    def mae_contact(self) -> dict[str, float | None]:
        """The same over the windows in contact only."""
        return self.contact.per_axis()
