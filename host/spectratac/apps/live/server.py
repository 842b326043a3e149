"""The live page's server: Starlette on uvicorn, on 127.0.0.1 only.

Routes: ``/`` the page (static files under ``/static``, libraries included: the page
works offline); ``/ws`` a WebSocket that sends the session's ``meta`` then every message
it publishes, and takes ``{"type": "latency", "values": [...]}`` (the page's receipt
latencies), ``{"type": "pong", "id": n}`` (echo of the server's pings) and
``{"type": "snake_restart"}``; ``POST /api/save`` ``{"seconds": 10, "format": "mcap"}``
writes a clip; ``GET /api/stats`` link, latency and echo figures as JSON.

Messages cross from the session's worker thread into the event loop with
`call_soon_threadsafe`; each client has a bounded queue, and a client too slow to keep up
loses its oldest messages, never the sensor's.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import socket
import threading
import time
from collections.abc import AsyncIterator
from pathlib import Path
from typing import Any

import uvicorn
from spectratac.apps.live.session import LiveSession
from spectratac.errors import SpectraTacError
from starlette.applications import Starlette
from starlette.requests import Request
from starlette.responses import FileResponse, JSONResponse
from starlette.routing import Mount, Route, WebSocketRoute
from starlette.staticfiles import StaticFiles
from starlette.websockets import WebSocket, WebSocketDisconnect

STATIC = Path(__file__).with_name("static")
HOST = "127.0.0.1"  # never another interface: the page controls a device
QUEUE = 512  # messages per client (25 s at 20 Hz) before the oldest are dropped
PING_EVERY_S = 0.25


class Hub:
    """The set of connected pages; `publish` is safe to call from any thread."""

    def __init__(self) -> None:
        self.loop: asyncio.AbstractEventLoop | None = None
        self.clients: set[asyncio.Queue[str]] = set()
        self.pings: dict[int, float] = {}

    def publish(self, msg: dict[str, Any]) -> None:
        loop = self.loop
        if loop is None or loop.is_closed():
            return
        text = json.dumps(msg, separators=(",", ":"))
        with contextlib.suppress(RuntimeError):  # the loop closed meanwhile
            loop.call_soon_threadsafe(self._fan_out, text)

    def _fan_out(self, text: str) -> None:
        for q in self.clients:
            if q.full():
                q.get_nowait()
            q.put_nowait(text)


def create_app(session: LiveSession, hub: Hub) -> Starlette:
    """The ASGI app of `session` (started with `hub.publish`); stops it on shut-down."""

    @contextlib.asynccontextmanager
    async def lifespan(app: Starlette) -> AsyncIterator[None]:
        hub.loop = asyncio.get_running_loop()
        pinger = asyncio.create_task(_ping(hub))
        try:
            yield
        finally:
            pinger.cancel()
            await asyncio.to_thread(session.stop)

    async def index(request: Request) -> FileResponse:
        return FileResponse(STATIC / "index.html", headers={"Cache-Control": "no-store"})

    async def stats(request: Request) -> JSONResponse:
        return JSONResponse(session.stats())

    async def save(request: Request) -> JSONResponse:
        try:
            body = await request.json()
            seconds = float(body.get("seconds", 10))
            fmt = str(body.get("format", "mcap"))
        except (ValueError, TypeError, AttributeError):
            return JSONResponse({"error": 'give JSON {"seconds": 10, "format": "mcap"}'}, 400)
        try:
            return JSONResponse(await asyncio.to_thread(session.save, seconds, fmt))
        except SpectraTacError as exc:
            return JSONResponse({"error": str(exc)}, 400)

    async def ws(websocket: WebSocket) -> None:
        await websocket.accept()
        queue: asyncio.Queue[str] = asyncio.Queue(QUEUE)
        hub.clients.add(queue)
        sender = asyncio.create_task(_send(websocket, queue))
        try:
            await websocket.send_text(json.dumps(session.meta()))
            if session.last is not None:
                await websocket.send_text(json.dumps(session.last))
            while True:
                msg = json.loads(await websocket.receive_text())
                _handle(session, hub, msg)
        except (WebSocketDisconnect, json.JSONDecodeError, RuntimeError):
            pass
        finally:
            hub.clients.discard(queue)
            sender.cancel()

    return Starlette(
        routes=[
            Route("/", index),
            Route("/api/stats", stats),
            Route("/api/save", save, methods=["POST"]),
            WebSocketRoute("/ws", ws),
            Mount("/static", StaticFiles(directory=STATIC), name="static"),
        ],
        lifespan=lifespan,
    )


def _handle(session: LiveSession, hub: Hub, msg: Any) -> None:
    if not isinstance(msg, dict):
        return
    kind = msg.get("type")
    if kind == "latency" and isinstance(msg.get("values"), list):
        session.latency.add(msg["values"])
    elif kind == "pong":
        sent = hub.pings.pop(int(msg.get("id", -1)), None)
        if sent is not None:
            session.echo.add([(time.monotonic() - sent) * 1e3 / 2])
    elif kind == "snake_restart":
        hub.publish({"type": "snake", "snake": session.restart_snake()})


async def _send(websocket: WebSocket, queue: asyncio.Queue[str]) -> None:
    with contextlib.suppress(WebSocketDisconnect, RuntimeError):
        while True:
            await websocket.send_text(await queue.get())


async def _ping(hub: Hub) -> None:
    """Ping every page; the echo's half round trip is the latency reference."""
    n = 0
    while True:
        await asyncio.sleep(PING_EVERY_S)
        n += 1
        hub.pings = {k: v for k, v in hub.pings.items() if k > n - 40}
        hub.pings[n] = time.monotonic()
        hub._fan_out(json.dumps({"type": "ping", "id": n}))


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

    def __init__(self, session: LiveSession, sock: socket.socket) -> None:
        self.session = session
        self.sock = sock
        host, port = sock.getsockname()[:2]
        self.url = f"http://{host}:{port}/"
        self.hub = Hub()
        config = uvicorn.Config(
            create_app(session, self.hub), ws="wsproto", log_level="warning", lifespan="on"
        )
        self.server = uvicorn.Server(config)
        self._thread: threading.Thread | None = None

    def run(self) -> None:
        self.session.start(self.hub.publish)
        try:
            self.server.run(sockets=[self.sock])
        finally:
            self.session.stop()
        if self.session.error:
            raise SpectraTacError(self.session.error)

    def start(self, timeout: float = 30.0) -> LiveServer:
        self.session.start(self.hub.publish)
        self._thread = threading.Thread(target=self.server.run, kwargs={"sockets": [self.sock]},
                                        name="spectratac-live-server", daemon=True)  # fmt: skip
        self._thread.start()
        deadline = time.monotonic() + timeout
        while not self.server.started:
            if not self._thread.is_alive() or time.monotonic() > deadline:
                raise SpectraTacError(f"the live server did not start within {timeout:g} s")
            time.sleep(0.02)
        return self

    def stop(self) -> None:
        self.server.should_exit = True
        if self._thread is not None:
            self._thread.join(timeout=10.0)
        self.session.stop()
        self.sock.close()
