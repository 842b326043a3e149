"""The live server's low items (issue 36): binary WebSocket messages get a typed refusal,
permessage-deflate is not negotiated, a client that sends its headers byte by byte is cut
off, open connections are capped (each limit said once on the log, not per connection),
every answer forbids framing and outside content, and a dead session is shown to the page
and said once on stderr."""

from __future__ import annotations

import http.client
import logging
import re
import socket
import subprocess
import sys
import time
from collections.abc import Iterator

import pytest
from spectratac.apps.live.limits import Limits
from spectratac.apps.live.server import LiveServer, bind
from spectratac.apps.live.session import LiveSession
from wsproto import ConnectionType, WSConnection
from wsproto.events import AcceptConnection, Message, Request
from wsproto.extensions import PerMessageDeflate

from tests.apps.live.clients import WsClient
from tests.apps.live.fake_session import FakeSession
from tools.bench.live_limits import closed_by_server

pytestmark = pytest.mark.subprocess  # one test runs `spectratac live`

HANG_GUARD_S = 60.0


@pytest.fixture
def served(request: pytest.FixtureRequest) -> Iterator[tuple[LiveServer, FakeSession]]:
    limits = getattr(request, "param", None)
    session = FakeSession()
    given = {} if limits is None else {"limits": limits}
    server = LiveServer(session, bind(0), **given).start()  # type: ignore[arg-type]
    try:
        yield server, session
    finally:
        server.stop()


def port_of(server: LiveServer) -> int:
    return int(server.url.rstrip("/").rsplit(":", 1)[1])


def test_a_binary_message_gets_a_typed_refusal_and_the_socket_stays_open(served) -> None:
    server, _ = served
    client = WsClient.connect(port_of(server))
    client.sock.sendall(client.conn.send(Message(data=b"\x00\x01binary")))
    refused = client.recv_json()
    while refused["type"] != "refused":  # estimates keep coming meanwhile
        refused = client.recv_json()
    assert refused["code"] == "binary" and "8 bytes" in refused["message"]
    assert "JSON text" in refused["message"]
    client.send_text("not json")
    again = client.recv_json()
    while again["type"] != "refused":
        again = client.recv_json()
    assert again["code"] == "bad_message"  # still served


def test_permessage_deflate_is_not_negotiated(served) -> None:
    """A compressed frame of 61 KB inflated to 60 MB before the size check closed it."""
    server, _ = served
    port = port_of(server)
    sock = socket.create_connection(("127.0.0.1", port), timeout=HANG_GUARD_S)
    conn = WSConnection(ConnectionType.CLIENT)
    sock.sendall(conn.send(Request(host=f"127.0.0.1:{port}", target="/ws",
                                   extensions=[PerMessageDeflate()])))  # fmt: skip
    accepted = None
    while accepted is None:
        conn.receive_data(sock.recv(65536))
        accepted = next((e for e in conn.events() if isinstance(e, AcceptConnection)), None)
    sock.close()
    assert accepted.extensions == []


def headers_of(port: int, path: str, host: str | None = None) -> tuple[int, dict[str, str]]:
    conn = http.client.HTTPConnection("127.0.0.1", port, timeout=HANG_GUARD_S)
    try:
        conn.putrequest("GET", path, skip_host=host is not None)
        if host is not None:
            conn.putheader("Host", host)
        conn.endheaders()
        r = conn.getresponse()
        r.read()
        return r.status, {k.lower(): v for k, v in r.getheaders()}
    finally:
        conn.close()


@pytest.mark.parametrize(
    ("path", "host", "status"),
    [("/", None, 200), ("/static/app.js", None, 200), ("/api/stats", None, 200),
     ("/nothing", None, 404), ("/", "evil.example", 403)],
)  # fmt: skip
def test_every_answer_forbids_framing_and_outside_content(served, path, host, status) -> None:
    server, _ = served
    got, headers = headers_of(port_of(server), path, host)
    assert got == status
    assert headers["x-frame-options"] == "DENY"
    csp = dict(d.strip().split(" ", 1) for d in headers["content-security-policy"].split(";"))
    assert csp["frame-ancestors"] == "'none'" and csp["default-src"] == "'none'"
    assert csp["script-src"] == "'self'" and "http" not in csp["script-src"]
    assert f"ws://127.0.0.1:{port_of(server)}" in csp["connect-src"]


@pytest.mark.parametrize("served", [Limits(header_timeout_s=1.0)], indirect=True)
def test_headers_sent_byte_by_byte_are_cut_off_with_one_log_line(served, caplog) -> None:
    server, _ = served
    port = port_of(server)
    slow = b"GET / HTTP/1.1\r\nHost: 127.0.0.1:%d\r\nX-Slow: " % port + b"a" * 10_000
    caplog.set_level(logging.WARNING, "spectratac.live")
    for _ in range(3):
        with socket.create_connection(("127.0.0.1", port), timeout=HANG_GUARD_S) as s:
            assert closed_by_server(s, slow)
    assert server.limits.timed_out == 3
    said = [r for r in caplog.records if r.name == "spectratac.live"]
    assert len(said) == 1 and "no complete request headers within 1 s" in said[0].getMessage()
    assert headers_of(port, "/")[0] == 200  # a real request is served as before


@pytest.mark.parametrize("served", [Limits(max_connections=4)], indirect=True)
def test_connections_beyond_the_cap_are_closed_with_one_log_line(served, caplog) -> None:
    server, _ = served
    port = port_of(server)
    caplog.set_level(logging.WARNING, "spectratac.live")
    held = [socket.create_connection(("127.0.0.1", port)) for _ in range(4)]
    try:
        time.sleep(0.5)  # the server has taken them all
        for _ in range(10):
            with socket.create_connection(("127.0.0.1", port), timeout=HANG_GUARD_S) as s:
                assert closed_by_server(s)
        assert server.limits.over_cap == 10
        said = [r for r in caplog.records if r.name == "spectratac.live"]
        assert len(said) == 1 and "4 connections are open" in said[0].getMessage()
    finally:
        for s in held:
            s.close()
    deadline = time.monotonic() + HANG_GUARD_S
    while True:  # once they are gone, pages are served again
        try:
            if headers_of(port, "/")[0] == 200:
                break
        except (ConnectionError, http.client.HTTPException):
            pass
        assert time.monotonic() < deadline, "no page after the held connections closed"
        time.sleep(0.1)


UNPLUGGED = "sim://?scene=idle&seed=4&speed=10&fault=unplug&fault_unplug=0.5"


def test_a_dead_session_is_shown_to_pages_that_join_later() -> None:
    session = LiveSession(None, UNPLUGGED)
    server = LiveServer(session, bind(0)).start()
    try:
        deadline = time.monotonic() + HANG_GUARD_S
        while session.error is None:
            assert time.monotonic() < deadline, "the unplug was never noticed"
            time.sleep(0.1)
        client = WsClient.connect(port_of(server))
        meta = client.recv_json()
        assert meta["type"] == "meta" and UNPLUGGED in meta["error"]
    finally:
        server.stop()


def test_live_says_once_on_stderr_that_the_session_died() -> None:
    argv = [sys.executable, "-m", "spectratac", "live", UNPLUGGED, "--no-browser",
            "--port", "0", "--duration", "6"]  # fmt: skip
    run = subprocess.run(argv, capture_output=True, text=True, timeout=120)
    told = re.findall(r"the session ended: [^\n]*", run.stderr)
    assert len(told) == 1, run.stderr
    assert "simulated device" in told[0] and "Ctrl-C" in told[0]
