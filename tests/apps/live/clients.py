"""Plain clients of the live server for tests: raw HTTP (any Host, Origin, body) and a
blocking WebSocket on wsproto (uvicorn's own WebSocket library), so that the tests can
send what a hostile page or a confused script would."""

from __future__ import annotations

import contextlib
import http.client
import json
import socket
import time
from dataclasses import dataclass, field
from typing import Any

from wsproto import ConnectionType, WSConnection
from wsproto.events import (
    AcceptConnection,
    CloseConnection,
    Message,
    RejectConnection,
    RejectData,
    Request,
    TextMessage,
)
from wsproto.utilities import LocalProtocolError


@dataclass
class Answer:
    status: int
    body: bytes

    def json(self) -> Any:
        return json.loads(self.body)


def http_request(
    port: int,
    method: str,
    path: str,
    *,
    headers: dict[str, str] | None = None,
    body: bytes | None = None,
    timeout: float = 60.0,
) -> Answer:
    """One request; `headers` may replace Host (http.client otherwise sends the real one)."""
    conn = http.client.HTTPConnection("127.0.0.1", port, timeout=timeout)
    try:
        hdrs = dict(headers or {})
        conn.putrequest(method, path, skip_host="Host" in hdrs, skip_accept_encoding=True)
        for k, v in hdrs.items():
            conn.putheader(k, v)
        if body is not None and "Content-Length" not in hdrs:
            conn.putheader("Content-Length", str(len(body)))
        conn.endheaders()
        if body is not None:
            conn.send(body)
        r = conn.getresponse()
        return Answer(r.status, r.read())
    finally:
        conn.close()


class Refused(Exception):
    def __init__(self, status: int, body: bytes) -> None:
        super().__init__(f"handshake refused: {status} {body!r}")
        self.status = status
        self.body = body


@dataclass
class WsClient:
    """A blocking WebSocket client; `recv` returns text, or a CloseConnection when closed."""

    sock: socket.socket
    conn: WSConnection
    pending: list[Any] = field(default_factory=list)
    text: list[str] = field(default_factory=list)
    unpacked: list[dict[str, Any]] = field(default_factory=list)

    @classmethod
    def connect(
        cls,
        port: int,
        path: str = "/ws",
        *,
        host: str | None = None,
        origin: str | None = None,
        timeout: float = 60.0,
    ) -> WsClient:
        sock = socket.create_connection(("127.0.0.1", port), timeout=timeout)
        conn = WSConnection(ConnectionType.CLIENT)
        extra = [(b"Origin", origin.encode())] if origin is not None else []
        sock.sendall(conn.send(Request(host=host or f"127.0.0.1:{port}", target=path,
                                       extra_headers=extra)))  # fmt: skip
        client = cls(sock, conn)
        status, body, accepted = 0, b"", False
        while not accepted:
            for event in client._events():
                if accepted:  # messages read with the handshake's answer
                    client.pending.append(event)
                elif isinstance(event, AcceptConnection):
                    accepted = True
                elif isinstance(event, RejectConnection):
                    status = event.status_code
                    if not event.has_body:
                        raise Refused(status, body)
                elif isinstance(event, RejectData):
                    body += event.data
                    if event.body_finished:
                        sock.close()
                        raise Refused(status, body)
        return client

    def _events(self) -> list[Any]:
        data = self.sock.recv(65536)
        self.conn.receive_data(data or None)
        return list(self.conn.events())

    def send_text(self, text: str) -> None:
        self.sock.sendall(self.conn.send(Message(data=text)))

    def send_json(self, obj: Any) -> None:
        self.send_text(json.dumps(obj))

    def recv(self, timeout: float = 60.0) -> str | CloseConnection:
        deadline = time.monotonic() + timeout
        while True:
            while self.pending:
                event = self.pending.pop(0)
                if isinstance(event, TextMessage):
                    self.text.append(event.data)
                    if event.message_finished:
                        out = "".join(self.text)
                        self.text = []
                        return out
                elif isinstance(event, CloseConnection):
                    return event
            left = deadline - time.monotonic()
            if left <= 0:
                raise TimeoutError(f"no WebSocket message within {timeout:g} s")
            self.sock.settimeout(left)
            self.pending.extend(self._events())

    def recv_json(self, timeout: float = 60.0) -> dict[str, Any]:
        """The next message; one WebSocket message may carry several (a JSON array)."""
        if not self.unpacked:
            got = self.recv(timeout)
            assert isinstance(got, str), f"the server closed the socket: {got}"
            data = json.loads(got)
            self.unpacked = data if isinstance(data, list) else [data]
        return self.unpacked.pop(0)

    def recv_until(self, kind: str, timeout: float = 60.0) -> dict[str, Any]:
        """The next message of type `kind` (skipping pings, estimates, stats)."""
        deadline = time.monotonic() + timeout
        while True:
            msg = self.recv_json(max(0.0, deadline - time.monotonic()))
            if msg.get("type") == kind:
                return msg

    def close(self) -> None:
        with contextlib.suppress(OSError, LocalProtocolError):  # closed by the server already
            self.sock.sendall(self.conn.send(CloseConnection(code=1000)))
        self.sock.close()
