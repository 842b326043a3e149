"""The live server against hostile clients (issue 25), with figures for the reliability
rows of the measurements log: other sites and Host names refused, control without the page's
token refused, a 400 MB POST and a 16 MB WebSocket message refused without raising memory or
stalling another page, and pages joining mid-stream seeing every estimate once, in order;
then the newer limits (tools/bench/live_limits.py: binary frames, a compressed frame, slow
headers, the connection cap, X-Frame-Options and CSP), each as refusals against attempts.

The server runs in this process on a stand-in session (tests/apps/live/fake_session.py:
numbered estimates every 5 ms, no device), so the figures are the server's alone.

    python -m tools.bench.live_guard [--joins 200] [--json]
"""

from __future__ import annotations

import argparse
import socket
import threading
import time
from pathlib import Path
from typing import Any

from spectratac.apps.live.limits import Limits
from spectratac.apps.live.server import LiveServer, bind
from wsproto.events import CloseConnection

from tests.apps.live.clients import Refused, WsClient, http_request
from tests.apps.live.fake_session import FakeSession
from tools.bench import live_limits
from tools.bench.benchlib import Figure, report

EVIL = "http://evil.example"


def rss_mb() -> float:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024
    return float("nan")


def hostile(port: int) -> dict[str, int]:
    """Requests from another site or another Host name, and control without the token."""
    refused = tried = 0
    for path in ("/", "/api/stats", "/static/app.js", "/static/../server.py"):
        for headers in ({"Host": "evil.example"}, {"Host": f"evil.example:{port}"},
                        {"Origin": EVIL}, {"Origin": "null"}):  # fmt: skip
            tried += 1
            refused += http_request(port, "GET", path, headers=headers).status == 403
    for kwargs in ({"origin": EVIL}, {"host": "evil.example"}, {"origin": "null"}):
        tried += 1
        try:
            WsClient.connect(port, **kwargs).close()  # type: ignore[arg-type]
        except Refused as exc:
            refused += exc.status == 403
    json_type = {"Content-Type": "application/json"}
    for headers in ({"Content-Type": "text/plain"}, json_type,
                    {**json_type, "X-SpectraTac-Token": "guess"}):  # fmt: skip
        tried += 1
        body = b'{"seconds": 2}'
        refused += http_request(port, "POST", "/api/save", headers=headers, body=body).status in (
            403,
            415,
        )
    page = WsClient.connect(port)  # right origin, no token: reads, but may not control
    for msg in ({"type": "snake_restart"}, {"type": "latency", "values": [1e5] * 1000}):
        tried += 1
        page.send_json(msg)
        refused += page.recv_until("refused")["code"] == "bad_token"
    page.close()
    return {"tried": tried, "refused": refused}


def big_post(port: int, token: str, mb: int = 400) -> dict[str, Any]:
    """A `mb` MB body, declared, then streamed without a length: answered 413, RSS flat."""
    before = rss_mb()
    statuses = []
    for declared in (True, False):
        sock = socket.create_connection(("127.0.0.1", port), timeout=60)
        head = (f"POST /api/save HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\n"
                f"Content-Type: application/json\r\nX-SpectraTac-Token: {token}\r\n")  # fmt: skip
        head += (
            f"Content-Length: {mb << 20}\r\n\r\n"
            if declared
            else "Transfer-Encoding: chunked\r\n\r\n"
        )
        sock.sendall(head.encode())
        chunk = b" " * (1 << 20)
        framed = chunk if declared else b"100000\r\n" + chunk + b"\r\n"
        try:
            for _ in range(mb):
                sock.sendall(framed)
        except OSError:
            pass  # the server answered and closed: the rest is never read
        answer = sock.recv(4096)
        statuses.append(int(answer.split(b" ")[1]) if answer.startswith(b"HTTP/1.1") else 0)
        sock.close()
    return {"statuses": statuses, "rss_before_mb": round(before, 1),
            "rss_after_mb": round(rss_mb(), 1)}  # fmt: skip


def big_message(port: int, token: str) -> dict[str, Any]:
    """A 16 MB latency message from one page while another one is watched."""
    watcher = WsClient.connect(port, f"/ws?token={token}")
    sender = WsClient.connect(port, f"/ws?token={token}")
    big = '{"type": "latency", "values": [' + ",".join(["1.5"] * 4_000_000) + "]}"
    ends: list[Any] = []

    def send() -> None:
        try:
            sender.send_text(big)
            while not isinstance(got := sender.recv(), CloseConnection):
                pass
            ends.append(got.code)
        except OSError as exc:
            ends.append(type(exc).__name__)

    watcher.recv_until("estimate")
    thread = threading.Thread(target=send)
    last, gaps = time.monotonic(), []
    thread.start()
    while thread.is_alive() or len(gaps) < 200:
        if watcher.recv_json()["type"] == "estimate":
            now = time.monotonic()
            gaps.append(now - last)
            last = now
    thread.join()
    watcher.close()
    sender.close()
    return {
        "bytes": len(big),
        "sender_end": ends[0],
        "watcher_max_gap_ms": round(max(gaps) * 1e3, 1),
    }


def joins(n: int) -> dict[str, int]:
    """`n` pages joining while estimates are published (`last` set 3 ms before each)."""
    session = FakeSession(period_s=0.002, last_lead_s=0.003)
    server = LiveServer(session, bind(0)).start()  # type: ignore[arg-type]
    port = int(server.sock.getsockname()[1])
    bad = 0
    try:
        for _ in range(n):
            page = WsClient.connect(port)
            first = page.recv_json()
            seqs: list[int] = []
            while len(seqs) < 8:
                msg = page.recv_json()
                if msg["type"] == "estimate":
                    seqs.append(msg["seq"])
            bad += first["type"] != "meta" or seqs != list(range(seqs[0], seqs[0] + 8))
            page.close()
    finally:
        server.stop()
    return {"joins": n, "duplicate_or_out_of_order": bad}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--joins", type=int, default=200)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    server = LiveServer(FakeSession(), bind(0)).start()  # type: ignore[arg-type]
    port = int(server.sock.getsockname()[1])
    try:
        out = {
            "hostile": hostile(port),
            "post_400mb": big_post(port, server.token),
            "message_16mb": big_message(port, server.token),
        }
    finally:
        server.stop()
    out["joins"] = joins(args.joins)
    out["limits"] = newer_limits()
    report(figures(out), args.json)


#: Tight limits for the probe: a 1-s header timeout and a cap of 8 (the defaults, 10 s and 64,
#: behave alike, only slower to reach)
PROBE_LIMITS = {"header_timeout_s": 1.0, "max_connections": 8}


def newer_limits() -> dict[str, dict[str, Any]]:
    """The newer limits, on a server of their own (held connections must not touch the
    other checks)."""
    limits = Limits(**PROBE_LIMITS)  # type: ignore[arg-type]
    server = LiveServer(FakeSession(), bind(0), limits=limits).start()  # type: ignore[arg-type]
    try:
        return live_limits.probe(int(server.sock.getsockname()[1]), limits)
    finally:
        server.stop()


def figures(out: dict[str, Any]) -> list[Figure]:
    """Each check as a figure against what it is measured by: refusals against attempts,
    memory after the 400 MB POST against before it, another page's longest gap between
    estimates during the 16 MB message against the estimate period, bad joins against joins."""
    hostile, post, big, join = out["hostile"], out["post_400mb"], out["message_16mb"], out["joins"]
    gap_ms = 1e3 * FakeSession().period_s
    return [
        Figure("hostile requests refused", hostile["refused"], "requests", "requests tried",
               hostile["tried"], hostile["refused"] / hostile["tried"], hostile),
        Figure("RSS after a 400 MB POST", post["rss_after_mb"], "MB", "RSS before",
               post["rss_before_mb"], post["rss_after_mb"] / post["rss_before_mb"], post),
        Figure("another page's longest gap during a 16 MB message", big["watcher_max_gap_ms"],
               "ms", "estimate period", gap_ms, big["watcher_max_gap_ms"] / gap_ms, big),
        Figure("joins with a duplicate or out-of-order estimate",
               join["duplicate_or_out_of_order"], "joins", "joins", join["joins"],
               join["duplicate_or_out_of_order"] / join["joins"], join),
        *[Figure(f"{LIMIT_NAMES[name]} refused", got["refused"], "attempts", "attempts",
                 got["tried"], got["refused"] / got["tried"], got)
          for name, got in out["limits"].items()],
    ]  # fmt: skip


LIMIT_NAMES = {
    "binary_frames": "binary WebSocket frames (a typed refusal)",
    "compressed_frame": "a compressed frame (deflate not negotiated, frame not inflated)",
    "framing_headers": "framing (X-Frame-Options DENY and CSP on every answer)",
    "slow_headers": "headers sent byte by byte (header timeout)",
    "over_cap": "connections beyond the cap",
}


if __name__ == "__main__":
    main()
