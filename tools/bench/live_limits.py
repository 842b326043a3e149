"""The live server's newer limits, probed as a hostile client would (issue 36's low items):
binary WebSocket frames refused with a typed message, a compressed frame never inflated
(permessage-deflate not negotiated; a frame sent compressed anyway is refused without the
server's memory growing), request headers sent byte by byte cut off at the header timeout,
connections beyond the cap closed, and every answer carrying X-Frame-Options and a CSP.

`probe(port, limits)` returns, per check, what was tried and what was refused; live_guard
prints them beside its other figures.
"""

from __future__ import annotations

import http.client
import os
import socket
import struct
import time
import zlib
from pathlib import Path
from typing import Any

from spectratac.apps.live.limits import Limits
from wsproto import ConnectionType, WSConnection
from wsproto.events import AcceptConnection, Message, Request
from wsproto.extensions import PerMessageDeflate

from tests.apps.live.clients import WsClient

GUARD_S = 60.0  # a hang guard per connection: a server that never answers fails the probe
INFLATED_MB = 60  # the compressed frame's size once inflated (~60 KB on the wire)


def _rss_mb(pid: int | None = None) -> float:
    where = f"/proc/{pid or os.getpid()}/status"
    for line in Path(where).read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024
    return float("nan")


def binary_frames(port: int, n: int = 20) -> dict[str, int]:
    """`n` binary messages on one page's socket: each answered by a typed refusal."""
    client = WsClient.connect(port)
    refused = 0
    try:
        for i in range(n):
            client.sock.sendall(client.conn.send(Message(data=b"\x00binary%d" % i)))
            refused += client.recv_until("refused", GUARD_S)["code"] == "binary"
    finally:
        client.close()
    return {"tried": n, "refused": refused}


def _handshake(port: int, offer_deflate: bool) -> tuple[socket.socket, WSConnection, list[Any]]:
    sock = socket.create_connection(("127.0.0.1", port), timeout=GUARD_S)
    conn = WSConnection(ConnectionType.CLIENT)
    extensions = [PerMessageDeflate()] if offer_deflate else []
    sock.sendall(conn.send(Request(host=f"127.0.0.1:{port}", target="/ws",
                                   extensions=extensions)))  # fmt: skip
    while True:
        conn.receive_data(sock.recv(65536))
        for event in conn.events():
            if isinstance(event, AcceptConnection):
                return sock, conn, list(event.extensions)


def _compressed_frame(mb: int) -> bytes:
    """A masked text frame with RSV1 set (compressed) whose payload inflates to `mb` MB."""
    deflate = zlib.compressobj(wbits=-15)
    payload = deflate.compress(b" " * (mb << 20)) + deflate.flush(zlib.Z_SYNC_FLUSH)[:-4]
    key = os.urandom(4)
    masked = bytes(b ^ key[i % 4] for i, b in enumerate(payload))
    return bytes([0xC1, 0x80 | 127]) + struct.pack(">Q", len(payload)) + key + masked


def compressed_frame(port: int, server_pid: int | None = None) -> dict[str, Any]:
    """Offer permessage-deflate (refused: not negotiated), then send a compressed frame
    anyway: the server closes the socket without inflating it (its RSS does not grow by the
    inflated size)."""
    sock, _, extensions = _handshake(port, offer_deflate=True)
    before = _rss_mb(server_pid)
    frame = _compressed_frame(INFLATED_MB)
    closed = False
    try:
        sock.sendall(frame)
        sock.settimeout(GUARD_S)
        while not closed:
            data = sock.recv(65536)
            closed = data == b"" or b"\x88" in data[:2]  # EOF or a close frame
    except OSError:
        closed = True
    finally:
        sock.close()
    after = _rss_mb(server_pid)
    inflated = after - before > INFLATED_MB / 2
    return {"tried": 2, "refused": int(not extensions) + int(closed and not inflated),
            "frame_bytes": len(frame), "rss_before_mb": round(before, 1),
            "rss_after_mb": round(after, 1)}  # fmt: skip


def closed_by_server(sock: socket.socket, trickle: bytes = b"") -> bool:
    """Send `trickle` a byte at a time (slowloris); True once the server closed the socket,
    False if it still holds it after the hang guard (the live server's tests use it too)."""
    deadline = time.monotonic() + GUARD_S
    sock.settimeout(0.2)
    i = 0
    while time.monotonic() < deadline:
        try:
            if i < len(trickle):
                sock.sendall(trickle[i : i + 1])
                i += 1
            if sock.recv(1024) == b"":
                return True
        except TimeoutError:
            continue
        except OSError:
            return True
    return False


def slow_headers(port: int, n: int = 3) -> dict[str, int]:
    """`n` connections sending their request headers a byte at a time (slowloris)."""
    slow = b"GET / HTTP/1.1\r\nHost: 127.0.0.1:%d\r\nX-Slow: " % port + b"a" * 100_000
    refused = 0
    for _ in range(n):
        with socket.create_connection(("127.0.0.1", port), timeout=GUARD_S) as s:
            refused += closed_by_server(s, slow)
    return {"tried": n, "refused": refused}


def over_cap(port: int, cap: int, n: int = 10) -> dict[str, int]:
    """`cap` connections held open, then `n` more: each closed by the server."""
    held = [socket.create_connection(("127.0.0.1", port)) for _ in range(cap)]
    try:
        time.sleep(0.5)  # the server has taken them all
        refused = 0
        for _ in range(n):
            with socket.create_connection(("127.0.0.1", port), timeout=GUARD_S) as s:
                refused += closed_by_server(s)
    finally:
        for s in held:
            s.close()
    return {"tried": n, "refused": refused}


def framing_headers(port: int) -> dict[str, int]:
    """Every kind of answer (page, script, API, not found, wrong Host) forbids framing and
    outside content: X-Frame-Options DENY and a CSP with frame-ancestors 'none'."""
    tried = guarded = 0
    for path, host in (("/", None), ("/static/app.js", None), ("/api/stats", None),
                       ("/nothing", None), ("/", "evil.example")):  # fmt: skip
        conn = http.client.HTTPConnection("127.0.0.1", port, timeout=GUARD_S)
        try:
            conn.putrequest("GET", path, skip_host=host is not None)
            if host is not None:
                conn.putheader("Host", host)
            conn.endheaders()
            answer = conn.getresponse()
            answer.read()
            headers = {k.lower(): v for k, v in answer.getheaders()}
        finally:
            conn.close()
        tried += 1
        csp = headers.get("content-security-policy", "")
        guarded += headers.get("x-frame-options") == "DENY" and "frame-ancestors 'none'" in csp
    return {"tried": tried, "refused": guarded}


def probe(port: int, limits: Limits) -> dict[str, dict[str, Any]]:
    """Every newer limit of the server on `port` (serving with `limits`)."""
    out = {
        "binary_frames": binary_frames(port),
        "compressed_frame": compressed_frame(port),
        "framing_headers": framing_headers(port),
        "slow_headers": slow_headers(port),
        "over_cap": over_cap(port, limits.max_connections),
    }
    out["slow_headers"]["counted"] = limits.timed_out
    out["over_cap"]["counted"] = limits.over_cap
    return out
