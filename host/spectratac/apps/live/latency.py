"""Latency figures a benchmark's page reports (`LiveSession(benchmark=True)`): frame arrival
-> browser, and the references a bare message and an echo give.

The page stamps every estimate on receipt (`performance.timeOrigin + performance.now()`,
the same system clock as the host's `time.time()`) against its `arrival_ms` (`unix_ms`):
every page shows that latency to the browser; a benchmark's page also sends it back in
batches. The reference is what the WebSocket alone costs on this machine, measured at the
same time and the same way: the server's probe behind each estimate, in the same WebSocket
message, timed one way by the page (`bare`); the server also keeps the echo's half round
trip (`echo`).

>>> log = LatencyLog()
>>> log.add([float(v) for v in range(1, 101)])
>>> log.summary()
{'n': 100, 'p50_ms': 50.5, 'p99_ms': 99.01, 'max_ms': 100.0}

`Stages` keeps one log per stage of an estimate's way to the page, so that a slow tail can
be traced to the stage it comes from (`tools/bench/live.py` reports them):

>>> stages = Stages(("loop", "sent"))
>>> stages.add("loop", 2.0)
>>> stages.summary()["loop"]["n"], stages.summary()["sent"]["n"]
(1, 0)
"""

from __future__ import annotations

import collections
import threading
from typing import Any

import numpy as np
from spectratac.host_clock import unix_minus_monotonic_ns

KEEP = 20_000
_offset_s: float | None = None
_offset_lock = threading.Lock()


def unix_ms(monotonic_s: float) -> float:
    """Host monotonic seconds as Unix ms, the clock the page stamps receipts on. Estimates
    and the reference probe go through this one conversion, so that an error in it is
    theirs alike; its offset is read once per process, tightly (`spectratac.host_clock`)."""
    global _offset_s
    with _offset_lock:
        if _offset_s is None:
            _offset_s = unix_minus_monotonic_ns() / 1e9
        offset = _offset_s
    return (monotonic_s + offset) * 1e3


class LatencyLog:
    def __init__(self, keep: int = KEEP) -> None:
        self._values: collections.deque[float] = collections.deque(maxlen=keep)
        self._lock = threading.Lock()

    def add(self, values_ms: list[float]) -> None:
        finite = [float(v) for v in values_ms if isinstance(v, int | float) and np.isfinite(v)]
        with self._lock:
            self._values.extend(finite)

    def clear(self) -> None:
        with self._lock:
            self._values.clear()

    def values(self) -> list[float]:
        with self._lock:
            return list(self._values)

    def summary(self) -> dict[str, Any]:
        v = np.asarray(self.values())
        if not v.size:
            return {"n": 0, "p50_ms": None, "p99_ms": None, "max_ms": None}
        p50, p99 = np.percentile(v, [50, 99])
        return {
            "n": int(v.size),
            "p50_ms": round(float(p50), 3),
            "p99_ms": round(float(p99), 3),
            "max_ms": round(float(v.max()), 3),
        }


class Stages:
    """Named `LatencyLog`s, one per stage; `add` is safe from any thread."""

    def __init__(self, names: tuple[str, ...]) -> None:
        self.logs = {name: LatencyLog() for name in names}

    def add(self, name: str, *values_ms: float) -> None:
        self.logs[name].add(list(values_ms))

    def clear(self) -> None:
        for log in self.logs.values():
            log.clear()

    def summary(self) -> dict[str, dict[str, Any]]:
        return {name: log.summary() for name, log in self.logs.items()}
