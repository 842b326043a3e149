"""The last minutes of a live session, kept to save a clip: "save the last N seconds".

Raw device frames (as the recorder stores them), reference F/T rows and the decoded rows
are kept for `keep_s` seconds of host time. F/T rows are kept whole up to FT_KEEP_HZ rows per
second of host time (a Bota's or Net F/T's 1 kHz, what a recording's /ft/wrench copies whole);
a faster stream (a 10-kHz simulated F/T at speed=10) keeps an even subset at that rate, the
rows left out counted (`ft_thinned`, and in a clip's end message), so the history's memory
is bounded whatever the F/T's rate. A clip is written either as an MCAP recording
in the toolkit's format (`spectratac.record`, readable by `spectratac dataset build`; the
page's estimates on `/spectratac/estimates`) or as a CSV of the estimates, their reference
(when an F/T sensor is connected) and the raw counts. Thread-safe: the session's worker
adds, the server's save request reads.

Everything added also goes to the taps (`add_tap`: the Foxglove bridge), so a consumer of
the live streams needs no hook in the session.
"""

from __future__ import annotations

import collections
import csv
import threading
import time
from dataclasses import asdict
from pathlib import Path
from typing import Any, Protocol

import numpy as np
from spectratac.device.streams import DeviceStream
from spectratac.errors import SpectraTacError
from spectratac.hardware.generated import vocabulary as vocab
from spectratac.record.schemas import RATE_CAP_HZ, RateCap

KEEP_S = 120.0
CSV_COLUMNS = (
    "t_s",
    "host_time",
    "device_time_s",
    "step",
    *vocab.FT_AXES,
    "region",
    "region_prob",
    "contact",
    "ood",
    "invalid",
    *(f"ref_{a}" for a in vocab.FT_AXES),
    *vocab.DECODED_INPUTS,
)
FORMATS = ("mcap", "csv")
#: F/T rows kept per second of host time (the rate a recording's /ft/wrench copies whole)
FT_KEEP_HZ = RATE_CAP_HZ


class HistoryTap(Protocol):
    """Sees what the history is given, as it is given (on the adder's thread: keep it short)."""

    def frame(self, raw: bytes, host_time: float) -> None: ...
    def ft(self, rows: np.ndarray) -> None: ...
    def row(self, key: int, row: dict[str, Any]) -> None: ...


class History:
    def __init__(self, keep_s: float = KEEP_S) -> None:
        if not keep_s > 0:
            raise SpectraTacError(f"history of {keep_s} s: keep a positive number of seconds")
        self.keep_s = keep_s
        self._lock = threading.Lock()
        self._frames: collections.deque[tuple[bytes, float]] = collections.deque()
        self._ft: collections.deque[np.ndarray] = collections.deque()
        self._ft_cap = RateCap(FT_KEEP_HZ)
        self._ft_left: collections.deque[int] = collections.deque()  # per batch in _ft
        self.ft_thinned = 0  # F/T rows not kept (a stream faster than FT_KEEP_HZ)
        self._rows: collections.deque[dict[str, Any]] = collections.deque()
        self._refs: dict[int, list[float]] = {}
        self._taps: tuple[HistoryTap, ...] = ()

    def add_tap(self, tap: HistoryTap) -> None:
        self._taps = (*self._taps, tap)  # a new tuple: adders iterate without the lock

    # ------------------------------------------------------------------ adding
    def add_frame(self, raw: bytes, host_time: float) -> None:
        """A frame listener (runs on the sensor's reader thread: kept this small)."""
        self._frames.append((raw, host_time))
        for tap in self._taps:
            tap.frame(raw, host_time)

    def add_ft(self, rows: np.ndarray) -> None:
        if len(rows):
            times = rows["host_time"]
            with self._lock:
                kept = rows[self._ft_cap.take(len(rows), float(times[-1]), float(times[0]))]
                self._ft.append(kept.copy())  # a copy: a slice would hold the whole batch
                self._ft_left.append(len(rows) - len(kept))
                self.ft_thinned += len(rows) - len(kept)
            for tap in self._taps:
                tap.ft(rows)

    def add_row(self, key: int, row: dict[str, Any]) -> None:
        """One decoded row (CSV_COLUMNS without the ref_ ones), under the estimate's key."""
        with self._lock:
            self._rows.append({"key": key, **row})
            self._trim(float(row["host_time"]))
        for tap in self._taps:
            tap.row(key, row)

    def add_reference(self, key: int, wrench: Any) -> None:
        with self._lock:
            self._refs[key] = [float(v) for v in wrench]

    def _trim(self, now: float) -> None:
        old = now - self.keep_s
        while self._frames and self._frames[0][1] < old:
            self._frames.popleft()
        while self._ft and self._ft[0]["host_time"][-1] < old:
            self._ft.popleft()
            self._ft_left.popleft()
        while self._rows and self._rows[0]["host_time"] < old:
            self._refs.pop(self._rows.popleft()["key"], None)

    # ------------------------------------------------------------------ saving
    def window(self, seconds: float) -> tuple[list[tuple[bytes, float]], np.ndarray | None, list]:
        """(frames, F/T rows or None, decoded rows with their references) of the last
        `seconds` of host time."""
        frames, ft, rows, _ = self._window(seconds)
        return frames, ft, rows

    def _window(
        self, seconds: float
    ) -> tuple[list[tuple[bytes, float]], np.ndarray | None, list, int]:
        """window(), and the F/T rows of its batches the history did not keep."""
        if not 0 < seconds <= self.keep_s:
            raise SpectraTacError(
                f"save {seconds} s: give 0 < seconds <= {self.keep_s:g} (the history kept)"
            )
        since = time.monotonic() - seconds
        with self._lock:
            frames = [f for f in list(self._frames) if f[1] >= since]
            ft = np.concatenate(list(self._ft)) if self._ft else None
            thinned = sum(n for b, n in zip(self._ft, self._ft_left, strict=True)
                          if b["host_time"][-1] >= since)  # fmt: skip
            rows = [
                r
                | {
                    f"ref_{a}": v
                    for a, v in zip(vocab.FT_AXES, self._refs.get(r["key"], []), strict=False)
                }
                for r in self._rows
                if r["host_time"] >= since
            ]
        if ft is not None:
            ft = ft[ft["host_time"] >= since]
        return frames, ft, rows, thinned

    def save_csv(self, path: Path, seconds: float) -> int:
        """The decoded rows of the last `seconds` as CSV; returns the row count."""
        _, _, rows = self.window(seconds)
        with open(path, "w", newline="") as f:
            w = csv.DictWriter(f, CSV_COLUMNS, extrasaction="ignore", restval="")
            w.writeheader()
            w.writerows(rows)
        return len(rows)

    def save_mcap(
        self, path: Path, seconds: float, sensor: DeviceStream, session: dict[str, Any]
    ) -> int:
        """The raw frames, F/T rows and decoded rows of the last `seconds` as a recording;
        returns the frame count. `sensor` gives the device's INFO, configuration and clock sync."""
        from spectratac.record.describe import config_summary, info_dict
        from spectratac.record.format import CONFIG, END, FT_INFO, INFO, TIME_SYNC
        from spectratac.record.writer import RecordingWriter

        frames, ft, rows, thinned = self._window(seconds)
        sensor.sync_clock(8)
        exchanges = [asdict(e) for e in sensor.time_sync[-64:]]
        ft_dtype = ft.dtype if ft is not None else None
        now = time.monotonic()
        # the link's clock scale puts the clip on the sensor's clock (record.timeline)
        session = {"labels": "none", "link": sensor.link_info.as_dict(), **session}
        with RecordingWriter(path, session, ft_dtype=ft_dtype) as w:
            w.json(INFO, info_dict(sensor.info), now)
            if session.get("ft_info") is not None:
                w.json(FT_INFO, session["ft_info"], now)
            reply = sensor.get_config().to_dict()
            w.json(
                CONFIG,
                {
                    "config_id": reply.get("config_id"),
                    "reply": reply,
                    "config": config_summary(reply),
                },
                now,
            )
            w.json(TIME_SYNC, {"exchanges": exchanges}, now)
            w.frames(frames)
            if ft is not None and len(ft):
                w.ft(ft)
            w.estimates(rows)
            w.json(
                END,
                {
                    "stopped_by": "clip",
                    "samples": len(rows),
                    "frames": len(frames),
                    "ft_samples": 0 if ft is None else len(ft),
                    "ft_thinned": thinned,  # rows of a stream beyond FT_KEEP_HZ, not kept
                    "labels": 0,
                },
                time.monotonic(),
            )
        return len(frames)
