"""A stand-in for `LiveSession` that serves the server's tests in milliseconds: no device,
a producer thread publishing numbered estimates, and a record of what clients made it do."""

from __future__ import annotations

import threading
import time
from typing import Any

from spectratac.apps.live.latency import LatencyLog


class FakeSession:
    """Publishes ``{"type": "estimate", "seq": n, ...}`` every `period_s`. Like the real session,
    it sets `last` before publishing; `last_lead_s` widens that gap (the window in which a
    joining page once received the same estimate twice)."""

    def __init__(
        self,
        period_s: float = 0.005,
        last_lead_s: float = 0.0,
        counts: int = 0,
        benchmark: bool = False,
    ) -> None:
        self.period_s = period_s
        self.benchmark = benchmark  # as LiveSession's: the server then probes and pings
        self.last_lead_s = last_lead_s
        self.counts = counts  # raw counts per message: the size of a real estimate
        self.last: dict[str, Any] | None = None
        self.latency = LatencyLog()
        self.echo = LatencyLog()
        self.bare = LatencyLog()
        self.error: str | None = None
        self.restarts = 0
        self.saves: list[tuple[float, str]] = []
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    def start(self, publish: Any) -> None:
        self._thread = threading.Thread(target=self._run, args=(publish,), daemon=True)
        self._thread.start()

    def _run(self, publish: Any) -> None:
        seq = 0
        while not self._stop.is_set():
            msg = {"type": "estimate", "seq": seq, "t": seq * self.period_s,
                   "counts": [seq % 65536] * self.counts}  # fmt: skip
            self.last = msg
            if self.last_lead_s:
                time.sleep(self.last_lead_s)
            publish(msg)
            seq += 1
            time.sleep(self.period_s)

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join(timeout=5.0)

    def meta(self) -> dict[str, Any]:
        return {"type": "meta", "model": {"path": "/secret/model.stac"}, "url": "sim://",
                "benchmark": self.benchmark}  # fmt: skip

    def stats(self) -> dict[str, Any]:
        return {"type": "stats", "latency": self.latency.summary()}

    def restart_snake(self) -> dict[str, Any]:
        self.restarts += 1
        return {"steps": 0}

    def save(self, seconds: float, fmt: str) -> dict[str, Any]:
        self.saves.append((seconds, fmt))
        return {"path": "/nowhere", "format": fmt, "seconds": seconds}
