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

The server is the live page's stack (Starlette on uvicorn, wsproto) speaking the protocol
itself (github.com/foxglove/ws-protocol: serverInfo, advertise, subscribe, unsubscribe,
binary messageData), because the foxglove SDK's server accepts only the subprotocol
``foxglove.sdk.v1`` while Lichtblick and every ``@foxglove/ws-protocol`` client offer only
``foxglove.websocket.v1``: both are accepted here. The live page's `Guard` checks Host and
Origin, so another web page open in the browser is refused (403, with the reason) as it is
by the page.

The bridge is a tap of the live page's history (`History.add_tap`): the taps only queue
(the sensor's reader thread calls one); the bridge's own thread encodes, only for channels
a client subscribes to, and hands the bytes to the event loop. Every queue is bounded (the
oldest dropped and counted in `stats`); an exception while encoding is logged once and the
bridge keeps serving.

>>> with FoxgloveBridge(port=0) as bridge:
...     bridge.url.startswith("ws://127.0.0.1:")
True
"""

from __future__ import annotations

import asyncio
import collections
import json
import logging
import socket
import struct
import threading
import time
from typing import Any

import numpy as np
import uvicorn
from starlette.applications import Starlette
from starlette.routing import WebSocketRoute
from starlette.websockets import WebSocket, WebSocketDisconnect

from spectratac import host_clock
from spectratac.apps.live.guard import Guard, refusal
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
    schema_bytes,
    split_frames,
    wrench_messages,
)

DEFAULT_PORT = 8765
HOST = "127.0.0.1"  # never another interface: the streams carry no authentication
TOPICS = (COUNTS, ESTIMATES, WRENCH)
#: Lichtblick's and @foxglove/ws-protocol's name first, then the foxglove SDK's
SUBPROTOCOLS = ("foxglove.websocket.v1", "foxglove.sdk.v1")
POLL_S = 0.02
TAP_LIMIT = 20_000  # items per tap queue (frames, F/T batches, rows): minutes of a real sensor
CLIENT_LIMIT = 50_000  # messages queued for one client that reads too slowly
DROP_REPORT_S = 10.0  # how often the log may say that messages were dropped
MAX_CLIENT_MESSAGE = 64 * 1024  # subscribe/unsubscribe requests are small
MESSAGE_DATA = 0x01
_DATA_HEADER = struct.Struct("<BIQ")  # opcode, subscription id, log time (ns)

log = logging.getLogger(__name__)


class BridgeError(SpectraTacError):
    """The bridge could not start (its port is taken, most often)."""


class _Tap:
    """A bounded queue filled by one thread and drained by another: drops the oldest
    beyond `limit` and counts them."""

    def __init__(self, limit: int) -> None:
        self._items: collections.deque[Any] = collections.deque()
        self.limit = limit
        self.dropped = 0

    def put(self, item: Any) -> None:
        if len(self._items) >= self.limit:
            try:
                self._items.popleft()
                self.dropped += 1
            except IndexError:  # drained meanwhile
                pass
        self._items.append(item)

    def drain(self) -> list[Any]:
        return [self._items.popleft() for _ in range(len(self._items))]


class _Client:
    """One connection: its subscriptions and its bounded outgoing queue."""

    def __init__(self) -> None:
        self.subscriptions: dict[int, int] = {}  # subscription id -> channel id
        self.out: collections.deque[bytes] = collections.deque()
        self.ready = asyncio.Event()
        self.dropped = 0

    def push(self, frames: list[bytes]) -> None:
        self.out.extend(frames)
        while len(self.out) > CLIENT_LIMIT:
            self.out.popleft()
            self.dropped += 1
        self.ready.set()


class FoxgloveBridge:
    def __init__(
        self, port: int = DEFAULT_PORT, *, name: str = "SpectraTac",
        origins: tuple[str, ...] = (),
    ) -> None:  # fmt: skip
        """A bridge on 127.0.0.1:`port` (0: any free port; `port` tells which once started).
        `origins`: web origins allowed besides the served address (e.g. a Foxglove web
        app the user trusts); clients that send no Origin (desktop apps, scripts) pass."""
        self.requested_port = port
        self.name = name
        self.extra_origins = frozenset(origins)
        self._frames = _Tap(TAP_LIMIT)
        self._ft = _Tap(TAP_LIMIT)
        self._rows = _Tap(TAP_LIMIT)
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._server_thread: threading.Thread | None = None
        self._server: uvicorn.Server | None = None
        self._sock: socket.socket | None = None
        self._port = 0
        self._loop: asyncio.AbstractEventLoop | None = None
        self._clients: set[_Client] = set()
        self._live: frozenset[str] = frozenset()  # topics some client subscribes to
        self._channel_ids = {topic: i + 1 for i, topic in enumerate(TOPICS)}
        self._topics_by_id = {i: t for t, i in self._channel_ids.items()}
        self._offset_ns = host_clock.unix_minus_monotonic_ns()  # host monotonic -> Unix
        self.sent = dict.fromkeys(TOPICS, 0)
        self.errors = 0  # exceptions while encoding (the first one logged)
        self._logged: set[str] = set()
        self._dropped_client = 0  # messages dropped for clients that closed
        # the recording's caps: a stream faster than a real sensor (an accelerated
        # simulation) is thinned rather than starve the session's threads
        self._caps = {topic: RateCap() for topic in TOPICS}

    # ------------------------------------------------------------------ lifecycle
    def start(self, timeout: float = 30.0) -> FoxgloveBridge:
        sock = socket.socket()
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            sock.bind((HOST, self.requested_port))
            sock.listen(64)
        except OSError as exc:
            sock.close()
            raise BridgeError(
                f"the Foxglove bridge cannot listen on {HOST}:{self.requested_port} ({exc}): "
                f"give another port, e.g. --foxglove {self.requested_port + 1}"
            ) from None
        self._sock = sock
        self._port = port = int(sock.getsockname()[1])
        guard = Guard(Starlette(routes=[WebSocketRoute("/", self._serve_client)]), port)
        guard.origins = guard.origins | self.extra_origins
        config = uvicorn.Config(guard, ws="wsproto", ws_max_size=MAX_CLIENT_MESSAGE,
                                ws_per_message_deflate=False, log_level="warning",
                                lifespan="off", timeout_graceful_shutdown=2)  # fmt: skip
        self._server = server = uvicorn.Server(config)
        self._loop = asyncio.new_event_loop()
        self._server_thread = threading.Thread(
            target=self._loop.run_until_complete, args=(server.serve(sockets=[sock]),),
            name="spectratac-foxglove-server", daemon=True,
        )  # fmt: skip
        self._server_thread.start()
        deadline = time.monotonic() + timeout
        while not server.started:
            if not self._server_thread.is_alive() or time.monotonic() > deadline:
                self.close()
                raise BridgeError(f"the Foxglove bridge did not start within {timeout:g} s")
            time.sleep(0.01)
        self._thread = threading.Thread(target=self._pump, name="spectratac-foxglove",
                                        daemon=True)  # fmt: skip
        self._thread.start()
        return self

    def close(self) -> None:
        """Stop sending, close the server and every connection; returns once its port is
        free again. Idempotent."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=10.0)
            self._thread = None
        if self._server is not None:
            self._server.should_exit = True
            if self._server_thread is not None:
                self._server_thread.join(timeout=10.0)
            self._server = None
        if self._loop is not None:
            self._loop.close()
            self._loop = None
        if self._sock is not None:
            self._sock.close()
            self._sock = None
            _wait_unbound(self._port)

    def __enter__(self) -> FoxgloveBridge:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.close()

    @property
    def port(self) -> int:
        if self._sock is None:
            raise BridgeError("the bridge is not running: start() it first")
        return self._port

    @property
    def url(self) -> str:
        return f"ws://{HOST}:{self.port}"

    @property
    def subscribed_topics(self) -> frozenset[str]:
        """The topics some client subscribes to now: messages of any other are not encoded."""
        return self._live

    @property
    def stats(self) -> dict[str, Any]:
        """Messages sent by topic, dropped (tap queues and slow clients: oldest first),
        encoding errors, clients connected."""
        dropped = self._frames.dropped + self._ft.dropped + self._rows.dropped
        dropped += self._dropped_client + sum(c.dropped for c in list(self._clients))
        return {"sent": dict(self.sent), "dropped": dropped, "errors": self.errors,
                "clients": len(self._clients)}  # fmt: skip

    # ------------------------------------------------------------------ taps (History)
    def frame(self, raw: bytes, host_time: float) -> None:
        self._frames.put((raw, host_time))  # the sensor's reader thread: only queue

    def ft(self, rows: np.ndarray) -> None:
        self._ft.put(rows.copy())

    def row(self, key: int, row: dict[str, Any]) -> None:
        self._rows.put({"key": key, **row})

    # ------------------------------------------------------------------ the protocol
    async def _serve_client(self, ws: WebSocket) -> None:
        offered = ws.scope.get("subprotocols") or []
        chosen = next((p for p in offered if p in SUBPROTOCOLS), None)
        if chosen is None:
            receive, send = ws._receive, ws._send  # the raw ASGI pair, as the Guard refuses
            await receive()  # websocket.connect: then deny the handshake with an HTTP answer
            await refusal(
                400, "bad_subprotocol",
                f"offer the WebSocket subprotocol {' or '.join(SUBPROTOCOLS)} (offered: "
                f"{', '.join(offered) or 'none'})",
            )(ws.scope, receive, send)  # fmt: skip
            return
        await ws.accept(subprotocol=chosen)
        client = _Client()
        self._clients.add(client)
        sender = asyncio.create_task(self._send_loop(ws, client))
        try:
            await ws.send_text(json.dumps({
                "op": "serverInfo", "name": self.name, "capabilities": [],
                "supportedEncodings": [], "metadata": {}, "sessionId": str(self._offset_ns),
            }))  # fmt: skip
            await ws.send_text(json.dumps({"op": "advertise", "channels": self._advertised()}))
            while True:
                message = await ws.receive()
                if message["type"] == "websocket.disconnect":
                    break
                text = message.get("text")
                if text is None:
                    await self._status(ws, "binary client messages are not supported here")
                    continue
                await self._control(ws, client, text)
        except (WebSocketDisconnect, RuntimeError):
            pass
        finally:
            sender.cancel()
            self._clients.discard(client)
            self._dropped_client += client.dropped
            self._update_live()

    def _advertised(self) -> list[dict[str, Any]]:
        return [
            {
                "id": self._channel_ids[topic],
                "topic": topic,
                "encoding": "json",
                "schemaName": SCHEMAS[topic]["title"],
                "schema": schema_bytes(SCHEMAS[topic]).decode(),
                "schemaEncoding": "jsonschema",
            }
            for topic in TOPICS
        ]

    async def _control(self, ws: WebSocket, client: _Client, text: str) -> None:
        try:
            msg = json.loads(text)
            op = msg["op"]
            if op == "subscribe":
                for sub in msg["subscriptions"]:
                    if int(sub["channelId"]) not in self._topics_by_id:
                        raise ValueError(f"no channel {sub['channelId']}")
                    client.subscriptions[int(sub["id"])] = int(sub["channelId"])
            elif op == "unsubscribe":
                for sub_id in msg["subscriptionIds"]:
                    client.subscriptions.pop(int(sub_id), None)
            else:
                raise ValueError(f"op {op!r} is not supported by this server")
        except (ValueError, KeyError, TypeError) as exc:
            await self._status(ws, f"request refused: {exc}")
            return
        self._update_live()

    @staticmethod
    async def _status(ws: WebSocket, message: str) -> None:
        await ws.send_text(json.dumps({"op": "status", "level": 1, "message": message}))

    def _update_live(self) -> None:
        ids = {c for client in list(self._clients) for c in client.subscriptions.values()}
        self._live = frozenset(self._topics_by_id[i] for i in ids)

    async def _send_loop(self, ws: WebSocket, client: _Client) -> None:
        try:
            while True:
                await client.ready.wait()
                client.ready.clear()
                while client.out:
                    await ws.send_bytes(client.out.popleft())
        except (WebSocketDisconnect, RuntimeError, OSError):
            pass  # the receive side sees the disconnect and cleans up

    def _fan_out(self, topic: str, messages: list[tuple[int, bytes]]) -> None:
        """On the event loop: each subscriber's frames of `messages` ((log ns, data))."""
        channel = self._channel_ids[topic]
        for client in list(self._clients):
            for sub_id, ch in list(client.subscriptions.items()):
                if ch == channel:
                    client.push([_DATA_HEADER.pack(MESSAGE_DATA, sub_id, ns) + data
                                 for ns, data in messages])  # fmt: skip

    # ------------------------------------------------------------------ encoding
    def _pump(self) -> None:
        reported, next_report = 0, time.monotonic() + DROP_REPORT_S
        while not self._stop.wait(POLL_S):
            self._send()
            if time.monotonic() >= next_report:  # one line per period at most, not a flood
                next_report += DROP_REPORT_S
                dropped = self.stats["dropped"]
                if dropped > reported:
                    log.warning("Foxglove bridge: %d messages dropped so far (the oldest "
                                "first: a client or the encoder fell behind)", dropped)  # fmt: skip
                    reported = dropped
        self._send()

    def _guarded(self, work: Any, *args: Any) -> None:
        """Run one batch's encoding; an exception skips that batch alone, logged once per
        kind (a subscriber must not end the bridge for everyone)."""
        try:
            work(*args)
        except Exception as exc:
            self.errors += 1
            kind = type(exc).__name__
            if kind not in self._logged:
                self._logged.add(kind)
                log.exception("Foxglove bridge: a batch could not be sent (%s); it is "
                              "skipped, later ones are sent", kind)  # fmt: skip

    def _send(self) -> None:
        frames = self._frames.drain()
        ft = self._ft.drain()
        rows = self._rows.drain()
        live = self._live
        if frames and live & {COUNTS, ESTIMATES}:
            self._guarded(self._send_frames, frames, live)
        if ft and WRENCH in live:
            for batch in ft:
                self._guarded(self._send_wrench, batch)
        if rows and ESTIMATES in live:
            self._guarded(self._send_rows, rows)

    def _send_frames(self, frames: list[tuple[bytes, float]], live: frozenset[str]) -> None:
        samples, sample_t, estimates, estimate_t = split_frames(frames)
        first, now = frames[0][1], frames[-1][1]
        if COUNTS in live:
            keep = self._caps[COUNTS].take(len(samples), now, first)
            self._log(COUNTS, counts_messages(samples[keep]), sample_t[keep])
        if ESTIMATES in live:
            keep = self._caps[ESTIMATES].take(len(estimates), now, first)
            self._log(ESTIMATES, device_estimate_messages(estimates[keep]), estimate_t[keep])

    def _send_wrench(self, batch: np.ndarray) -> None:
        times = batch["host_time"]
        kept = batch[self._caps[WRENCH].take(len(batch), float(times[-1]), float(times[0]))]
        self._log(WRENCH, wrench_messages(kept), kept["host_time"].tolist())

    def _send_rows(self, rows: list[dict[str, Any]]) -> None:
        cap = self._caps[ESTIMATES]
        rows = rows[cap.take(len(rows), float(rows[-1]["host_time"]),
                             float(rows[0]["host_time"]))]  # fmt: skip
        self._log(ESTIMATES, [host_estimate_message(r) for r in rows],
                  [float(r["host_time"]) for r in rows])  # fmt: skip

    def _log(self, topic: str, messages: list[bytes], host_times: list[float]) -> None:
        loop = self._loop
        if not messages or loop is None:
            return
        offset = self._offset_ns
        batch = [(round(t * 1e9) + offset, data)
                 for data, t in zip(messages, host_times, strict=True)]  # fmt: skip
        try:
            loop.call_soon_threadsafe(self._fan_out, topic, batch)
        except RuntimeError:  # the loop closed: the bridge is stopping
            return
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
