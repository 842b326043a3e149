"""The live page's server: Starlette on uvicorn, on 127.0.0.1 only.

Routes: ``/`` the page (static files under ``/static``, libraries included: the page
works offline); ``/ws`` a WebSocket that sends the session's ``meta``, the latest estimate,
then every message it publishes, and takes the messages of `spectratac.apps.live.inbound`
(``snake_restart``, ``tare``; ``latency`` and ``pong`` from a benchmark's page only);
``POST /api/save`` ``{"seconds": 10, "format": "mcap"}`` writes a clip; ``GET /api/stats``
the link's figures as JSON.

Only the served page may use it (`spectratac.apps.live.guard`): Host and Origin are checked
on every request, writing or controlling needs the token written into the served page, and
every answer forbids framing and loading from elsewhere (X-Frame-Options, a CSP).
Inputs are bounded: WebSocket messages (uvicorn closes the socket with 1009 beyond
`MAX_MESSAGE_BYTES`, before buffering more; no permessage-deflate, so a small compressed frame
cannot inflate far past it first; binary messages get a typed refusal) and POST bodies (413
beyond `MAX_BODY_BYTES`); a message over `INLINE_BYTES` is parsed on a worker thread, so no
client stalls the others. Connections are bounded too (`spectratac.apps.live.limits`: request
headers within a timeout, a cap on open connections).

A session that dies (the device unplugged, the stream ended with an error) stays on the page
as a banner, and `run()` (the CLI) says so once on stderr.

Messages cross from the session's worker thread into the event loop with
`call_soon_threadsafe`; each client has a bounded queue, whose messages queued in one turn
of the event loop go out as one WebSocket message (a JSON array: `batch_text`), and a
client too slow to keep up loses its oldest messages, never the sensor's. A joining client's
queue gets the meta and the latest estimate and joins the fan-out in one step on the event
loop, so it sees every estimate once, in order.

A benchmark's session (`LiveSession(benchmark=True)`, `tools/bench/live.py`) also gets its
latency measured against a reference: a bare message (`probe`) behind every estimate, timed
one way by the page like the estimate, and an echo ping whose half round trip is kept.
`Hub.stages` then times every estimate from its publication to the event loop and to the
socket, and keeps the page's own work per batch of estimates and per redraw (the page
reports them with its latencies). Without it none of this is sent, kept or shown.
While serving, the process runs with `tuning.serving()` (a short GIL switch interval,
start-up objects frozen out of the collector's reach).
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import socket
import sys
import threading
import time
from collections.abc import AsyncIterator
from pathlib import Path
from typing import Any

import uvicorn
from spectratac.apps.live import inbound, tuning
from spectratac.apps.live.guard import (
    TOKEN_HEADER,
    TOKEN_PLACEHOLDER,
    Guard,
    new_token,
    refusal,
    token_matches,
)
from spectratac.apps.live.latency import Stages, unix_ms
from spectratac.apps.live.limits import Limits
from spectratac.apps.live.session import LiveSession
from spectratac.errors import SpectraTacError
from starlette.applications import Starlette
from starlette.requests import ClientDisconnect, Request
from starlette.responses import HTMLResponse, JSONResponse, Response
from starlette.routing import Mount, Route, WebSocketRoute
from starlette.staticfiles import StaticFiles
from starlette.websockets import WebSocket, WebSocketDisconnect

STATIC = Path(__file__).with_name("static")
HOST = "127.0.0.1"  # never another interface: the page controls a device
QUEUE = 512  # messages per client (25 s at 20 Hz) before the oldest are dropped
PING_EVERY_S = 0.25  # a benchmark's echo pings
BATCH_MAX = 64  # messages per WebSocket message at most (what piled up after a stall)
MAX_MESSAGE_BYTES = inbound.MAX_MESSAGE_BYTES
MAX_BODY_BYTES = 4096  # a save request is ~40 bytes
INLINE_BYTES = 4096  # longer messages are parsed off the event loop


class Hub:
    """The set of connected pages; `publish` is safe to call from any thread, everything
    else runs on the event loop. With `benchmark`, a probe goes behind every estimate and
    `stages` times an estimate's way through the server (published -> fanned out on the
    loop -> handed to the socket) and the page's own work per batch of estimates and per
    redraw, as the page reports it."""

    def __init__(self, benchmark: bool = False) -> None:
        self.loop: asyncio.AbstractEventLoop | None = None
        self.clients: set[asyncio.Queue[Item]] = set()
        self.pings: dict[int, float] = {}
        self.last: str | None = None  # the latest estimate fanned out, for joining pages
        self.benchmark = benchmark
        self.stages = Stages(("loop", "sent", "page_handle", "page_redraw"))

    def publish(self, msg: dict[str, Any]) -> None:
        loop = self.loop
        if loop is None or loop.is_closed():
            return
        text = json.dumps(msg, separators=(",", ":"))
        estimate = msg.get("type") == "estimate"
        with contextlib.suppress(RuntimeError):  # the loop closed meanwhile
            loop.call_soon_threadsafe(self._fan_out, text, time.monotonic() if estimate else None)

    def join(self, meta: dict[str, Any]) -> asyncio.Queue[Item]:
        """A new client's queue, holding `meta` and the latest estimate, added to the
        fan-out in the same step: no estimate can fall between or arrive twice."""
        queue: asyncio.Queue[Item] = asyncio.Queue(QUEUE)
        queue.put_nowait((json.dumps(meta, separators=(",", ":")), None))
        if self.last is not None:
            queue.put_nowait((self.last, None))
        self.clients.add(queue)
        return queue

    def _fan_out(self, text: str, published: float | None = None) -> None:
        """Runs on the loop; `published` (monotonic s) marks an estimate (a benchmark's is
        timed to the page, its probe right behind it)."""
        timed = published is not None and self.benchmark
        if published is not None:
            self.last = text
        if timed:
            self.stages.add("loop", (time.monotonic() - published) * 1e3)
        for q in self.clients:
            _put(q, (text, published if timed else None))
        if timed:
            self._fan_out(probe(unix_ms(time.monotonic())))


#: A client queue's entry: the message's text, and when a benchmark's estimate was published
#: (else None: not timed).
Item = tuple[str, float | None]


def _put(queue: asyncio.Queue[Item], item: Item) -> None:
    if queue.full():
        queue.get_nowait()
    queue.put_nowait(item)


def create_app(session: LiveSession, hub: Hub, *, port: int, token: str) -> Guard:
    """The ASGI app of `session` (started with `hub.publish`) served on 127.0.0.1:`port`,
    controllable with `token`; stops the session on shut-down."""
    page = (STATIC / "index.html").read_text().replace(TOKEN_PLACEHOLDER, token)

    @contextlib.asynccontextmanager
    async def lifespan(app: Starlette) -> AsyncIterator[None]:
        hub.loop = asyncio.get_running_loop()
        pinger = asyncio.create_task(_ping(hub)) if hub.benchmark else None
        try:
            yield
        finally:
            if pinger is not None:
                pinger.cancel()
            await asyncio.to_thread(session.stop)

    async def index(request: Request) -> HTMLResponse:
        return HTMLResponse(page, headers={"Cache-Control": "no-store"})

    async def stats(request: Request) -> JSONResponse:
        return JSONResponse(session.stats())

    async def save(request: Request) -> Response:
        given = request.headers.getlist(TOKEN_HEADER)  # exactly one: a repeat is ambiguous
        if len(given) != 1 or not token_matches(given[0], token):
            return refusal(403, "bad_token", "saving needs the token of the page this server "
                           f"served (the {TOKEN_HEADER} header): reload the page")  # fmt: skip
        if request.headers.get("content-type", "").split(";")[0].strip() != "application/json":
            return refusal(415, "bad_content_type", "send the save request as application/json")
        body = await _read_body(request, MAX_BODY_BYTES)
        if body is None:
            return refusal(413, "too_large", f"a save request is at most {MAX_BODY_BYTES} bytes")
        try:
            req = inbound.parse_save(body)
        except inbound.BadMessage as exc:
            return refusal(400, exc.code, str(exc))
        try:
            return JSONResponse(await asyncio.to_thread(session.save, req.seconds, req.format))
        except SpectraTacError as exc:
            return refusal(400, "not_saved", str(exc))

    async def ws(websocket: WebSocket) -> None:
        given = websocket.query_params.get("token")
        if given is not None and not token_matches(given, token):
            await websocket.send_denial_response(
                refusal(403, "bad_token", "wrong token: reload the page this server served")
            )
            return
        await websocket.accept()
        queue = hub.join(session.meta())
        sender = asyncio.create_task(_send(websocket, queue, hub.stages))
        try:
            while True:
                message = await websocket.receive()
                if message["type"] == "websocket.disconnect":
                    break
                reply = await _receive(session, hub, message, control=given is not None)
                if reply is not None:
                    _put(queue, (json.dumps(reply), None))
        except (WebSocketDisconnect, RuntimeError):
            pass
        finally:
            hub.clients.discard(queue)
            sender.cancel()

    app = Starlette(
        routes=[
            Route("/", index),
            Route("/api/stats", stats),
            Route("/api/save", save, methods=["POST"]),
            WebSocketRoute("/ws", ws),
            Mount("/static", StaticFiles(directory=STATIC), name="static"),
        ],
        lifespan=lifespan,
    )
    return Guard(app, port)


async def _read_body(request: Request, limit: int) -> bytes | None:
    """The body, or None past `limit` bytes (read no further: memory stays bounded)."""
    declared = request.headers.get("content-length", "")
    if declared.isdigit() and int(declared) > limit:
        return None
    body = bytearray()
    with contextlib.suppress(ClientDisconnect):
        async for chunk in request.stream():
            body += chunk
            if len(body) > limit:
                return None
    return bytes(body)


async def _receive(
    session: LiveSession, hub: Hub, message: dict[str, Any], *, control: bool
) -> dict[str, Any] | None:
    """Act on one client message (an ASGI websocket.receive); the typed refusal to send
    back, if any."""
    text = message.get("text")
    try:
        if text is None:
            inbound.refuse_binary(len(message.get("bytes") or b""))
        elif len(text) > INLINE_BYTES:
            msg = await asyncio.to_thread(inbound.parse, text)
        else:
            msg = inbound.parse(text)
    except inbound.BadMessage as exc:
        return {"type": "refused", "code": exc.code, "message": str(exc)}
    if not control:
        why = "this connection is read-only: control needs the page's token"
        return {"type": "refused", "code": "bad_token", "message": why}
    if isinstance(msg, inbound.Latency | inbound.Pong) and not hub.benchmark:
        why = f"{type(msg).__name__.lower()}: this server measures no latency (no benchmark)"
        return {"type": "refused", "code": "not_measuring", "message": why}
    if isinstance(msg, inbound.Latency):
        session.latency.add(list(msg.values))
        session.bare.add(list(msg.bare))
        hub.stages.add("page_handle", *msg.handle)
        hub.stages.add("page_redraw", *msg.redraw)
    elif isinstance(msg, inbound.Pong):
        sent = hub.pings.pop(msg.id, None)
        if sent is not None:
            session.echo.add([(time.monotonic() - sent) * 1e3 / 2])
    elif isinstance(msg, inbound.Tare):
        session.tare()
    else:
        hub.publish({"type": "snake", "snake": session.restart_snake()})
    return None


async def _send(websocket: WebSocket, queue: asyncio.Queue[Item], stages: Stages) -> None:
    with contextlib.suppress(WebSocketDisconnect, RuntimeError):
        while True:
            batch = [await queue.get()]
            while len(batch) < BATCH_MAX and not queue.empty():
                batch.append(queue.get_nowait())
            await websocket.send_text(batch_text([text for text, _ in batch]))
            now = time.monotonic()
            for _, published in batch:
                if published is not None:
                    stages.add("sent", (now - published) * 1e3)


def batch_text(texts: list[str]) -> str:
    """One WebSocket message for the messages queued in one event-loop turn: a lone message
    as it is, several as a JSON array. After a stall the page gets what piled up in one
    receipt and one parse, and a probe shares its estimate's message (`probe`).

    >>> batch_text(['{"a":1}']), batch_text(['{"a":1}', '{"b":2}'])
    ('{"a":1}', '[{"a":1},{"b":2}]')
    """
    return texts[0] if len(texts) == 1 else "[" + ",".join(texts) + "]"


async def _ping(hub: Hub) -> None:
    """A benchmark's pings to every page; the echo's half round trip is kept beside the
    reference (`probe`)."""
    n = 0
    while True:
        await asyncio.sleep(PING_EVERY_S)
        n += 1
        hub.pings = {k: v for k, v in hub.pings.items() if k > n - 40}
        hub.pings[n] = time.monotonic()
        hub._fan_out(json.dumps({"type": "ping", "id": n}))


def probe(sent_ms: float) -> str:
    """The latency reference: a bare message stamped `sent_ms` (Unix ms) as an estimate is
    fanned out and queued right behind it, so that it goes in the same WebSocket message
    (`batch_text`); the page times it on the clock and at the receipt it times the estimate
    with (`bare`): what the socket and the browser alone cost that very message, against
    which the estimate's whole way from the frame is judged. (The echo's half round trip
    counted a stall on one way half; a message of its own met the page's redraw of the
    estimate before it, which the estimate itself never waits for.)

    >>> probe(1.5e12)
    '{"type":"probe","sent_ms":1500000000000.0}'
    """
    return json.dumps({"type": "probe", "sent_ms": round(sent_ms, 3)}, separators=(",", ":"))


def bind(port: int = 0) -> socket.socket:
    """A listening socket on 127.0.0.1 (`port` 0: any free one)."""
    sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    try:
        sock.bind((HOST, port))
    except OSError as exc:
        sock.close()
        raise SpectraTacError(
            f"cannot listen on {HOST}:{port}: {exc}; give another --port"
        ) from None
    return sock


class LiveServer:
    """uvicorn serving the page of `session` on `sock`. Both `run()` (blocks: the CLI) and
    `start()` (serves from a background thread until `stop()`: tests, benchmarks) first
    start the session, so that a device that cannot be opened fails before serving."""

    def __init__(
        self, session: LiveSession, sock: socket.socket, limits: Limits | None = None
    ) -> None:
        self.session = session
        self.sock = sock
        host, port = sock.getsockname()[:2]
        self.url = f"http://{host}:{port}/"
        self.hub = Hub(benchmark=session.benchmark)
        self.token = new_token()
        self.limits = limits or Limits()
        self._told_death = False
        app = create_app(session, self.hub, port=port, token=self.token)
        config = uvicorn.Config(app, http=self.limits.protocol(), ws="wsproto",
                                ws_max_size=MAX_MESSAGE_BYTES, ws_per_message_deflate=False,
                                log_level="warning", lifespan="on")  # fmt: skip
        self.server = uvicorn.Server(config)
        self._thread: threading.Thread | None = None
        self._tuning = contextlib.ExitStack()

    def run(self) -> None:
        self.session.start(self._publish_telling_death)
        try:
            with tuning.serving():
                self.server.run(sockets=[self.sock])
        finally:
            self.session.stop()
        if self.session.error:
            raise SpectraTacError(self.session.error)

    def _publish_telling_death(self, msg: dict[str, Any]) -> None:
        """Publish; the first message of a dead session is also said once on stderr (the
        page shows it as long as it is served)."""
        if msg.get("type") == "error" and not self._told_death:
            self._told_death = True
            print(f"spectratac live: the session ended: {msg['message']} (the page says so; "
                  "Ctrl-C to stop serving it)", file=sys.stderr, flush=True)  # fmt: skip
        self.hub.publish(msg)

    def start(self, timeout: float = 30.0) -> LiveServer:
        self.session.start(self.hub.publish)
        self._tuning.enter_context(tuning.serving())
        self._thread = threading.Thread(target=self.server.run, kwargs={"sockets": [self.sock]},
                                        name="spectratac-live-server", daemon=True)  # fmt: skip
        self._thread.start()
        deadline = time.monotonic() + timeout
        while not self.server.started:
            if not self._thread.is_alive() or time.monotonic() > deadline:
                self._tuning.close()
                raise SpectraTacError(f"the live server did not start within {timeout:g} s")
            time.sleep(0.02)
        return self

    def stop(self) -> None:
        self.server.should_exit = True
        if self._thread is not None:
            self._thread.join(timeout=10.0)
        self.session.stop()
        self.sock.close()
        self._tuning.close()
