"""Who may talk to the live server: only the page it served, on the address it serves.

The server listens on 127.0.0.1, but any web page the user opens can still make the browser
send requests there. Two checks keep other sites out:

- `Guard`, an ASGI middleware, compares ``Host`` (and ``Origin``, when the browser sends
  one) with the served address on every HTTP and WebSocket request. Another ``Host`` is a
  DNS-rebinding page; another ``Origin`` is a cross-site page. Both are refused with 403
  and a JSON body before any route runs.
- A per-server token (`new_token`), written only into the served ``index.html``, is required
  for anything that writes or controls: the ``X-SpectraTac-Token`` header on
  ``POST /api/save`` (a custom header also makes any cross-site request preflighted, and
  the server answers no preflight) and the ``token`` query parameter of ``/ws`` for the
  control messages (``latency``, ``pong``, ``snake_restart``).

Every HTTP answer also says that no other page may frame this one and that the page loads
and connects to nothing but this server (`security_headers`).
"""

from __future__ import annotations

import hmac
import secrets
from collections.abc import Awaitable, Callable, MutableMapping
from typing import Any

from starlette.responses import JSONResponse

Scope = MutableMapping[str, Any]
Message = MutableMapping[str, Any]
Receive = Callable[[], Awaitable[Message]]
Send = Callable[[Message], Awaitable[None]]
ASGIApp = Callable[[Scope, Receive, Send], Awaitable[None]]

TOKEN_HEADER = "x-spectratac-token"
TOKEN_PLACEHOLDER = "__SPECTRATAC_TOKEN__"  # in static/index.html


def new_token() -> str:
    return secrets.token_urlsafe(32)


def token_matches(given: str | None, token: str) -> bool:
    return given is not None and hmac.compare_digest(given.encode(), token.encode())


def refusal(status: int, code: str, message: str) -> JSONResponse:
    """The JSON every refusal carries: a stable `code` and what to do about it."""
    return JSONResponse({"error": message, "code": code}, status)


def security_headers(port: int) -> list[tuple[bytes, bytes]]:
    """What every HTTP answer carries: no other page may frame this one (clickjacking on Save
    or Tare), and the page may load and connect to nothing but this server (it loads nothing
    from the internet: uPlot ships in the package)."""
    sockets = " ".join(f"ws://{h}:{port}" for h in ("127.0.0.1", "localhost"))
    csp = (
        "default-src 'none'; script-src 'self'; style-src 'self'; img-src 'self' data:; "
        f"connect-src 'self' {sockets}; base-uri 'none'; form-action 'none'; "
        "frame-ancestors 'none'"
    )
    return [
        (b"x-frame-options", b"DENY"),
        (b"content-security-policy", csp.encode()),
        (b"x-content-type-options", b"nosniff"),
        (b"referrer-policy", b"no-referrer"),
    ]


class Guard:
    """Refuse every HTTP and WebSocket request whose Host or Origin is not the served
    address (``127.0.0.1:PORT`` or ``localhost:PORT``); put `security_headers` on every
    HTTP answer (refusals included)."""

    def __init__(self, app: ASGIApp, port: int) -> None:
        self.app = app
        self.hosts = frozenset({f"127.0.0.1:{port}", f"localhost:{port}"})
        self.origins = frozenset(f"http://{h}" for h in self.hosts)
        self.headers = security_headers(port)

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] not in ("http", "websocket"):
            await self.app(scope, receive, send)
            return
        send = self._with_headers(send)
        why = self.refuse_reason(_headers(scope))
        if why is None:
            await self.app(scope, receive, send)
            return
        if scope["type"] == "websocket":
            await receive()  # websocket.connect: then deny the handshake with an HTTP answer
        await refusal(403, *why)(scope, receive, send)

    def _with_headers(self, send: Send) -> Send:
        async def sending(message: Message) -> None:
            if message["type"] in ("http.response.start", "websocket.http.response.start"):
                message = {**message, "headers": [*message.get("headers", ()), *self.headers]}
            await send(message)

        return sending

    def refuse_reason(self, headers: dict[str, str]) -> tuple[str, str] | None:
        host = headers.get("host")
        if host not in self.hosts:
            return ("bad_host", f"Host {host!r} is not this server: open {self._served()}")
        origin = headers.get("origin")
        if origin is not None and origin not in self.origins:
            return (
                "bad_origin",
                f"Origin {origin!r} may not use this server: only its own page "
                f"({self._served()}) may",
            )
        return None

    def _served(self) -> str:
        return " or ".join(sorted(f"http://{h}/" for h in self.hosts))


def _headers(scope: Scope) -> dict[str, str]:
    """Header names lower-cased; a repeated Host or Origin is refused as unreadable."""
    out: dict[str, str] = {}
    for name, value in scope.get("headers", ()):
        key = name.decode("latin-1").lower()
        text = value.decode("latin-1")
        out[key] = "\0repeated" if key in out and key in ("host", "origin") else text
    return out
