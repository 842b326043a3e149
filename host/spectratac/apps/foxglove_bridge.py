"""`FoxgloveBridge`: the live streams over the Foxglove WebSocket protocol, on 127.0.0.1.

    spectratac live model.stac "sim://?scene=presses&speed=1&ft=bota" --foxglove

then, in Foxglove, "Open connection" -> ``ws://127.0.0.1:8765`` and plot
``/ft/wrench.force.z`` beside ``/spectratac/estimates.force.z``. The channels are those of
a recording's decoded channels, with the same JSON schemas and messages
(`spectratac.record.schemas`): ``/spectratac/counts`` (raw counts of every sample, IR
too), ``/spectratac/estimates`` (the host decoder's, or the device's ESTIMATE frames),
``/ft/wrench`` (every reference F/T sample). Each message's log time is its host receive
time (Unix ns). As in a recording, a stream faster than `record.schemas.RATE_CAP_HZ`
(an accelerated simulation) is sent as an even subset at that rate.

The bridge is a tap of the live page's history (`History.add_tap`): whatever the session
keeps for clips, the bridge serves, with or without a model. The taps only queue (the
sensor's reader thread calls one); the bridge's own thread encodes and sends, and only for
channels a client subscribes to. The server is the foxglove SDK's (``foxglove-sdk``), in a
context of its own, so two bridges (or a bridge and a recording) never share channels.

>>> with FoxgloveBridge(port=0) as bridge:
...     bridge.url.startswith("ws://127.0.0.1:")
True
"""

from __future__ import annotations

import collections
import socket
import threading
import time
from typing import Any

import numpy as np

from spectratac import host_clock
from spectratac.errors import SpectraTacError
from spectratac.record.schemas import (
    COUNTS,
    ESTIMATES,
    SCHEMAS,
    WRENCH,
    RateCap,
    counts_messages,
    device_estimate_messages,
    host_estimate_message,
    split_frames,
    wrench_messages,
)

DEFAULT_PORT = 8765
HOST = "127.0.0.1"  # never another interface: the streams carry no authentication
TOPICS = (COUNTS, ESTIMATES, WRENCH)
POLL_S = 0.02


class BridgeError(SpectraTacError):
    """The bridge could not start (its port is taken, most often)."""


class FoxgloveBridge:
    def __init__(self, port: int = DEFAULT_PORT, *, name: str = "SpectraTac") -> None:
        """A bridge on 127.0.0.1:`port` (0: any free port; `port` tells which once started)."""
        self.requested_port = port
        self.name = name
        self._frames: collections.deque[tuple[bytes, float]] = collections.deque()
        self._ft: collections.deque[np.ndarray] = collections.deque()
        self._rows: collections.deque[dict[str, Any]] = collections.deque()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._server: Any = None
        self._context: Any = None
        self._channels: dict[str, Any] = {}
        self._offset_ns = host_clock.unix_minus_monotonic_ns()  # host monotonic -> Unix
        self.sent = dict.fromkeys(TOPICS, 0)
        # the recording's caps: a stream faster than a real sensor (an accelerated
        # simulation) is thinned rather than starve the session's threads
        self._caps = {topic: RateCap() for topic in TOPICS}

    # ------------------------------------------------------------------ lifecycle
    def start(self) -> FoxgloveBridge:
        import foxglove  # the optional SDK: imported only when a bridge is wanted

        # kept: the SDK's channels and server hold their context weakly (a dropped context
        # advertises nothing)
        self._context = context = foxglove.Context()
        self._channels = {
            topic: foxglove.Channel(topic, schema=SCHEMAS[topic], context=context)
            for topic in TOPICS
        }
        try:
            self._server = foxglove.start_server(
                name=self.name, host=HOST, port=self.requested_port, context=context
            )
        except RuntimeError as exc:  # the SDK's FoxgloveError
            raise BridgeError(
                f"the Foxglove bridge cannot listen on {HOST}:{self.requested_port} ({exc}): "
                f"give another port, e.g. --foxglove {self.requested_port + 1}"
            ) from None
        self._thread = threading.Thread(target=self._pump, name="spectratac-foxglove",
                                        daemon=True)  # fmt: skip
        self._thread.start()
        return self

    def close(self) -> None:
        """Stop sending, close the server; returns once its port is free again (the SDK's
        stop() lets its runtime close the listener a moment later). Idempotent."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=10.0)
            self._thread = None
        for channel in self._channels.values():
            channel.close()
        self._channels = {}
        if self._server is not None:
            port = int(self._server.port)
            self._server.stop()
            self._server = None
            _wait_unbound(port)
        self._context = None

    def __enter__(self) -> FoxgloveBridge:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.close()

    @property
    def port(self) -> int:
        if self._server is None:
            raise BridgeError("the bridge is not running: start() it first")
        return int(self._server.port)

    @property
    def url(self) -> str:
        return f"ws://{HOST}:{self.port}"

    # ------------------------------------------------------------------ taps (History)
    def frame(self, raw: bytes, host_time: float) -> None:
        self._frames.append((raw, host_time))  # the sensor's reader thread: only queue

    def ft(self, rows: np.ndarray) -> None:
        self._ft.append(rows.copy())

    def row(self, key: int, row: dict[str, Any]) -> None:
        self._rows.append({"key": key, **row})

    # ------------------------------------------------------------------ sending
    def _pump(self) -> None:
        while not self._stop.wait(POLL_S):
            self._send()
        self._send()

    def _send(self) -> None:
        frames = _drain(self._frames)
        ft = _drain(self._ft)
        rows = _drain(self._rows)
        live = {t for t, c in self._channels.items() if c.has_sinks()}
        if frames and live & {COUNTS, ESTIMATES}:
            samples, sample_t, estimates, estimate_t = split_frames(frames)
            now = frames[-1][1]
            if COUNTS in live:
                keep = self._caps[COUNTS].take(len(samples), now)
                self._log(COUNTS, counts_messages(samples[keep]), sample_t[keep])
            if ESTIMATES in live:
                keep = self._caps[ESTIMATES].take(len(estimates), now)
                self._log(ESTIMATES, device_estimate_messages(estimates[keep]), estimate_t[keep])
        if ft and WRENCH in live:
            for batch in ft:
                kept = batch[self._caps[WRENCH].take(len(batch), float(batch["host_time"][-1]))]
                self._log(WRENCH, wrench_messages(kept), kept["host_time"].tolist())
        if rows and ESTIMATES in live:
            rows = rows[self._caps[ESTIMATES].take(len(rows), float(rows[-1]["host_time"]))]
            self._log(ESTIMATES, [host_estimate_message(r) for r in rows],
                      [float(r["host_time"]) for r in rows])  # fmt: skip

    def _log(self, topic: str, messages: list[bytes], host_times: list[float]) -> None:
        channel = self._channels[topic]
        offset = self._offset_ns
        for data, t in zip(messages, host_times, strict=True):
            channel.log(data, log_time=round(t * 1e9) + offset)
        self.sent[topic] += len(messages)


def _wait_unbound(port: int, limit_s: float = 5.0) -> None:
    """Wait (up to `limit_s`) until nothing listens on `port` of HOST any more."""
    end = time.monotonic() + limit_s
    while time.monotonic() < end:
        with socket.socket() as probe:
            # as a server binds (SO_REUSEADDR): only a listener, not a closed connection's
            # TIME_WAIT, keeps the port
            probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            try:
                probe.bind((HOST, port))
            except OSError:
                time.sleep(0.02)
                continue
            return


def _drain(queue: collections.deque[Any]) -> list[Any]:
    return [queue.popleft() for _ in range(len(queue))]
