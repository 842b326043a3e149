"""The live server against hostile and careless clients (issue 25): other sites and other
Host names are refused on every request, control needs the served page's token, inputs are
bounded and answered with typed refusals, and a page joining mid-stream sees every estimate
once, in order. A fast stand-in session (`FakeSession`) publishes numbered estimates."""

from __future__ import annotations

import contextlib
import gc
import json
import re
import socket
import sys
import threading
import time
from collections.abc import Iterator

import pytest
from spectratac.apps.live import inbound, tuning
from spectratac.apps.live.server import MAX_BODY_BYTES, MAX_MESSAGE_BYTES, LiveServer, bind
from wsproto.events import CloseConnection

from tests.apps.live.clients import Refused, WsClient, http_request
from tests.apps.live.fake_session import FakeSession

EVIL = "http://evil.example"


@pytest.fixture
def served() -> Iterator[tuple[LiveServer, FakeSession]]:
    session = FakeSession()
    server = LiveServer(session, bind(0)).start()  # type: ignore[arg-type]
    try:
        yield server, session
    finally:
        server.stop()


@pytest.fixture
def benchmarked() -> Iterator[tuple[LiveServer, FakeSession]]:
    """A server as the live benchmark starts it (tools/bench/live.py): latency measured."""
    session = FakeSession(benchmark=True)
    server = LiveServer(session, bind(0)).start()  # type: ignore[arg-type]
    try:
        yield server, session
    finally:
        server.stop()


def port_of(server: LiveServer) -> int:
    return int(server.sock.getsockname()[1])


def token_of_page(port: int) -> str:
    page = http_request(port, "GET", "/")
    assert page.status == 200
    (token,) = re.findall(rb'name="spectratac-token" content="([^"]+)"', page.body)
    return token.decode()


def save(port: int, token: str | None, body: bytes = b'{"seconds": 2}', **headers: str):
    hdrs = {"Content-Type": "application/json", **headers}
    if token is not None:
        hdrs["X-SpectraTac-Token"] = token
    return http_request(port, "POST", "/api/save", headers=hdrs, body=body)


# ---------------------------------------------------------------------- item 1: who may talk
@pytest.mark.parametrize("path", ["/", "/api/stats", "/static/app.js", "/static/style.css"])
def test_another_host_name_is_refused_on_every_route(served, path) -> None:
    server, _ = served
    port = port_of(server)
    assert http_request(port, "GET", path).status == 200
    for host in ("evil.example", f"evil.example:{port}", "127.0.0.1:1", f"127.0.0.2:{port}"):
        answer = http_request(port, "GET", path, headers={"Host": host})
        assert answer.status == 403, (host, answer)
        assert answer.json()["code"] == "bad_host" and host in answer.json()["error"]
    assert http_request(port, "GET", path, headers={"Host": f"localhost:{port}"}).status == 200


def test_static_files_stay_inside_the_package(served) -> None:
    server, _ = served
    port = port_of(server)
    for path in ("/static/../server.py", "/static/%2e%2e/server.py", "/static/..%2fserver.py",
                 "/static//etc/passwd", "/static/vendor/../../session.py"):  # fmt: skip
        answer = http_request(port, "GET", path)
        assert answer.status == 404 and b"LiveSession" not in answer.body, path
    assert server.sock.getsockname()[0] == "127.0.0.1"


def test_another_origin_is_refused_and_the_own_origin_served(served) -> None:
    server, _ = served
    port = port_of(server)
    answer = http_request(port, "GET", "/api/stats", headers={"Origin": EVIL})
    assert answer.status == 403 and answer.json()["code"] == "bad_origin"
    own = http_request(port, "GET", "/api/stats", headers={"Origin": f"http://127.0.0.1:{port}"})
    assert own.status == 200


def test_a_websocket_from_another_site_gets_nothing(served) -> None:
    server, _ = served
    port = port_of(server)
    for kwargs in ({"origin": EVIL}, {"host": "evil.example"}, {"origin": "null"}):
        with pytest.raises(Refused) as refused:
            WsClient.connect(port, **kwargs)
        assert refused.value.status == 403
        assert json.loads(refused.value.body)["code"] in ("bad_origin", "bad_host")
        assert b"secret" not in refused.value.body  # no meta


def test_the_page_carries_a_token_and_each_server_its_own(served) -> None:
    server, _ = served
    token = token_of_page(port_of(server))
    assert token == server.token and len(token) >= 32
    other = LiveServer(FakeSession(), bind(0))  # type: ignore[arg-type]
    try:
        assert other.token != token
    finally:
        other.sock.close()


def test_saving_needs_the_token_and_json(served) -> None:
    server, session = served
    port = port_of(server)
    token = token_of_page(port)
    # a cross-site form or fetch without preflight: text/plain, no token
    for answer, code in (
        (save(port, None, **{"Content-Type": "text/plain"}), "bad_token"),
        (save(port, None), "bad_token"),
        (save(port, "x" * len(token)), "bad_token"),
        (save(port, token, **{"Content-Type": "text/plain"}), "bad_content_type"),
    ):
        assert answer.status in (403, 415) and answer.json()["code"] == code, answer
    assert session.saves == []
    assert save(port, token).status == 200
    assert session.saves == [(2.0, "mcap")]


def test_control_messages_need_the_token(served) -> None:
    server, session = served
    port = port_of(server)
    reader = WsClient.connect(port, origin=f"http://127.0.0.1:{port}")
    try:
        assert reader.recv_json()["type"] == "meta"  # reading needs the right origin only
        reader.send_json({"type": "snake_restart"})
        reader.send_json({"type": "latency", "values": [1e5] * 100})
        for _ in range(2):
            refused = reader.recv_until("refused")
            assert refused["code"] == "bad_token"
    finally:
        reader.close()
    assert session.restarts == 0 and session.latency.summary()["n"] == 0
    with pytest.raises(Refused) as wrong:
        WsClient.connect(port, "/ws?token=nope")
    assert wrong.value.status == 403 and json.loads(wrong.value.body)["code"] == "bad_token"
    page = WsClient.connect(port, f"/ws?token={token_of_page(port)}")
    try:
        page.send_json({"type": "snake_restart"})
        assert page.recv_until("snake")["snake"] == {"steps": 0}
    finally:
        page.close()
    assert session.restarts == 1


# ---------------------------------------------------------------------- item 3: limits
def test_post_bodies_are_bounded(served) -> None:
    server, session = served
    port = port_of(server)
    token = token_of_page(port)
    big = save(port, token, body=b" " * (MAX_BODY_BYTES + 1))
    assert big.status == 413 and big.json()["code"] == "too_large"
    # a declared 400 MB body is refused before a byte of it is read
    huge = save(port, token, body=b"{}", **{"Content-Length": str(400 * 2**20)})
    assert huge.status == 413
    for body in (b"[]", b'{"seconds": "abc"}', b'{"seconds": 1e999}', b"{" * 3000,
                 b'{"seconds": NaN}', b'{"format": 3}', b"\xff\xfe"):  # fmt: skip
        answer = save(port, token, body=body)
        assert answer.status == 400 and answer.json()["code"] == "bad_message", body
    assert session.saves == []


def test_a_streamed_body_without_a_length_is_cut_off_at_the_limit(served) -> None:
    server, session = served
    port = port_of(server)
    sock = socket.create_connection(("127.0.0.1", port), timeout=60)
    try:
        sock.sendall(
            f"POST /api/save HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\n"
            f"Content-Type: application/json\r\nX-SpectraTac-Token: {server.token}\r\n"
            "Transfer-Encoding: chunked\r\n\r\n".encode()
        )
        chunk = b"100000\r\n" + b" " * (1 << 20) + b"\r\n"  # 1 MiB chunks, 64 of them
        with contextlib.suppress(OSError):  # answered and closed before the end
            for _ in range(64):
                sock.sendall(chunk)
        answer = sock.recv(4096)
    finally:
        sock.close()
    assert answer.startswith(b"HTTP/1.1 413"), answer[:200]
    assert session.saves == []


MALFORMED = [
    '{"type": "pong", "id": "abc"}',
    '{"type": "pong", "id": 1e999}',
    '{"type": "pong", "id": ' + "9" * 5000 + "}",
    '{"type": "pong", "id": ' + "9" * 4000 + "}",
    '{"type": "pong", "id": true}',
    '{"type": "latency", "values": [1e999]}',
    '{"type": "latency", "values": [NaN]}',
    '{"type": "latency", "values": [' + "9" * 4000 + "]}",
    '{"type": "latency", "values": "fast"}',
    '{"type": "latency", "values": [[1]]}',
    '{"type": "latency", "values": [' + ",".join(["1"] * 5000) + "]}",
    "[" * 20000 + "]" * 20000,
    '{"type": ' * 6000 + "1" + "}" * 6000,
    '"just a string"',
    "[1, 2]",
    "not json",
    '{"type": "format_disk"}',
    '{"id": 3}',
]


def test_malformed_messages_get_a_typed_refusal_and_the_socket_stays_open(served) -> None:
    server, session = served
    port = port_of(server)
    page = WsClient.connect(port, f"/ws?token={server.token}")
    try:
        for text in MALFORMED:
            assert len(text) <= MAX_MESSAGE_BYTES
            page.send_text(text)
            refused = page.recv_until("refused")
            assert refused["code"] in ("bad_message", "too_large"), (text[:60], refused)
        page.send_json({"type": "snake_restart"})
        page.recv_until("snake")  # still served, in order
    finally:
        page.close()
    assert session.restarts == 1


def test_a_16_mb_message_is_refused_while_another_page_keeps_receiving(served) -> None:
    server, _ = served
    port = port_of(server)
    watcher = WsClient.connect(port, f"/ws?token={server.token}")
    sender = WsClient.connect(port, f"/ws?token={server.token}")
    big = '{"type": "latency", "values": [' + ",".join(["1.5"] * 4_000_000) + "]}"
    assert len(big) > 16e6
    closed: list[object] = []

    def send_big() -> None:
        try:
            sender.send_text(big)
            while not isinstance(got := sender.recv(), CloseConnection):
                pass
            closed.append(got)
        except OSError as exc:  # the server closed the socket while we were still sending
            closed.append(exc)

    try:
        seqs = []
        while len(seqs) < 20:
            msg = watcher.recv_json()
            if msg["type"] == "estimate":
                seqs.append(msg["seq"])
        thread = threading.Thread(target=send_big)
        thread.start()
        gaps, last = [], time.monotonic()
        while thread.is_alive() or len(gaps) < 200:
            msg = watcher.recv_json()
            if msg["type"] == "estimate":
                now = time.monotonic()
                gaps.append(now - last)
                last = now
                seqs.append(msg["seq"])
        thread.join()
    finally:
        watcher.close()
        sender.close()
    (end,) = closed
    assert not isinstance(end, CloseConnection) or end.code == 1009, end
    # the watcher was never held up by the big message (generous: estimates come every 5 ms)
    assert max(gaps) < 2.0, f"the watcher got nothing for {max(gaps):.1f} s"
    assert seqs == sorted(set(seqs))


def test_inbound_parse_answers_every_input_with_a_message_or_bad_message() -> None:
    from hypothesis import given, settings
    from hypothesis import strategies as st

    json_values = st.recursive(
        st.none() | st.booleans() | st.integers() | st.floats() | st.text(max_size=8),
        lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=6), inner),
        max_leaves=20,
    )
    messages = st.fixed_dictionaries(
        {"type": st.sampled_from(["latency", "pong", "snake_restart", "x"])},
        optional={"values": json_values, "id": json_values},
    )

    @settings(max_examples=400, deadline=None)
    @given(st.one_of(st.text(max_size=200), json_values.map(json.dumps), messages.map(json.dumps)))
    def check(text: str) -> None:
        try:
            msg = inbound.parse(text)
        except inbound.BadMessage as exc:
            assert exc.code in ("bad_message", "too_large")
            return
        if isinstance(msg, inbound.Latency):
            assert all(abs(v) <= inbound.MAX_LATENCY_MS for v in msg.values)
        elif isinstance(msg, inbound.Pong):
            assert 0 <= msg.id <= inbound.MAX_PING_ID

    check()


# ---------------------------------------------------------------------- item 4: joining
def test_pages_joining_mid_stream_see_each_estimate_once_in_order() -> None:
    # `last` set 3 ms before each publish: the window in which a page joining used to get
    # the latest estimate both from `last` and from the fan-out
    session = FakeSession(period_s=0.002, last_lead_s=0.003)
    server = LiveServer(session, bind(0)).start()  # type: ignore[arg-type]
    port = port_of(server)
    try:
        for _ in range(40):
            page = WsClient.connect(port)
            try:
                first = page.recv_json()
                assert first["type"] == "meta", first
                seqs: list[int] = []
                while len(seqs) < 8:
                    msg = page.recv_json()
                    if msg["type"] == "estimate":
                        seqs.append(msg["seq"])
                assert seqs == list(range(seqs[0], seqs[0] + len(seqs))), seqs
            finally:
                page.close()
    finally:
        server.stop()


# ---------------------------------------------------------------------- issue 26: the tail
def test_serving_shortens_the_gil_switch_and_freezes_start_up_objects_then_restores() -> None:
    # each estimate crosses three threads; a woken thread waited up to CPython's 5 ms for the
    # GIL at each crossing, and a full collection walked every start-up object with it held
    before = sys.getswitchinterval()
    server = LiveServer(FakeSession(), bind(0)).start()  # type: ignore[arg-type]
    try:
        assert sys.getswitchinterval() == tuning.SWITCH_INTERVAL_S < before
        assert gc.get_freeze_count() > 10_000  # the modules, the app, the session
    finally:
        server.stop()
    assert sys.getswitchinterval() == before and gc.get_freeze_count() == 0


def test_each_estimate_is_timed_through_the_server_and_the_pages_reports_are_kept(
    benchmarked,
) -> None:
    server, _ = benchmarked
    client = WsClient.connect(port_of(server), f"/ws?token={server.token}")
    try:
        got = 0
        while got < 20:
            got += client.recv_json()["type"] == "estimate"
        client.send_json({"type": "latency", "values": [4.0], "handle": [0.5, 0.7],
                          "redraw": [2.0]})  # fmt: skip
        deadline = time.monotonic() + 30
        while server.hub.stages.summary()["page_redraw"]["n"] == 0:
            assert time.monotonic() < deadline, "the page's redraw times were not kept"
            time.sleep(0.02)
    finally:
        client.close()
    stages = server.hub.stages.summary()
    assert stages["loop"]["n"] >= 20 and stages["sent"]["n"] >= 19
    assert stages["page_handle"]["n"] == 2 and stages["page_redraw"]["max_ms"] == 2.0
    for bad in ('{"type": "latency", "values": [], "handle": 3}',
                '{"type": "latency", "values": [], "redraw": [NaN]}'):  # fmt: skip
        with pytest.raises(inbound.BadMessage):
            inbound.parse(bad)


def test_a_users_server_sends_no_probe_or_ping_and_takes_no_latency_reports(served) -> None:
    """The benchmark's instruments are off unless a benchmark asks (issue 37): over a
    hundred estimates no probe and no ping reaches the page, nothing is timed, the page is
    told not to report, and a report or a pong is refused."""
    server, session = served
    port = port_of(server)
    page = WsClient.connect(port, f"/ws?token={server.token}")
    try:
        meta = page.recv_json()
        assert meta["type"] == "meta" and meta["benchmark"] is False
        kinds: list[str] = []
        while kinds.count("estimate") < 100:
            kinds.append(page.recv_json()["type"])
        assert set(kinds) == {"estimate"}, set(kinds)
        for msg in ({"type": "latency", "values": [3.5], "bare": [1.0]}, {"type": "pong", "id": 1}):
            page.send_json(msg)
            refused = page.recv_until("refused")
            assert refused["code"] == "not_measuring", refused
    finally:
        page.close()
    assert not server.hub.benchmark and server.hub.pings == {}
    assert [log["n"] for log in server.hub.stages.summary().values()] == [0, 0, 0, 0]
    assert session.latency.values() == [] and session.bare.values() == []


def test_the_reference_is_a_probe_in_each_estimates_own_message_timed_one_way() -> None:
    # the reference was the echo's half round trip of a 30-byte ping at its own moment: a
    # stall on one way counted half, and a message of its own met the page's redraws
    session = FakeSession(period_s=0.01, counts=250, benchmark=True)
    server = LiveServer(session, bind(0)).start()  # type: ignore[arg-type]
    client = WsClient.connect(port_of(server), f"/ws?token={server.token}")
    try:
        probed = 0
        while probed < 20:
            text = client.recv()
            assert isinstance(text, str), text
            data = json.loads(text)
            batch = data if isinstance(data, list) else [data]
            kinds = [m["type"] for m in batch]
            if "probe" not in kinds:
                assert "estimate" not in kinds or kinds[0] == "meta", kinds  # given on joining
                continue
            # each estimate fanned out, with its probe right behind it in the same message,
            # stamped then on the clock the page times estimates with (Unix ms)
            for k, msg in enumerate(batch):
                if msg["type"] == "estimate" and k + 1 < len(batch):
                    assert batch[k + 1]["type"] == "probe", kinds
                    assert abs(batch[k + 1]["sent_ms"] - time.time() * 1e3) < 60_000
                    probed += 1
        client.send_json({"type": "latency", "values": [], "bare": [3.0, 4.5]})
        deadline = time.monotonic() + 30
        while session.bare.summary()["n"] == 0:
            assert time.monotonic() < deadline, "the page's one-way times were not kept"
            time.sleep(0.02)
    finally:
        client.close()
        server.stop()
    assert session.bare.values() == [3.0, 4.5]
    with pytest.raises(inbound.BadMessage, match="'slow' is not a finite number"):
        inbound.parse('{"type": "latency", "values": [], "bare": ["slow"]}')


def test_what_piles_up_in_one_event_loop_turn_goes_in_one_message(served) -> None:
    # after a stall each estimate went out as a message of its own: one receipt, one parse
    # and one task on the page each, the last one waiting for all the others
    server, _ = served
    client = WsClient.connect(port_of(server), f"/ws?token={server.token}")
    inside, gate = threading.Event(), threading.Event()

    def stall() -> None:  # the event loop held, as a descheduled loop thread is
        inside.set()
        gate.wait(30)

    try:
        client.recv_json()  # meta: the socket is served
        assert server.hub.loop is not None
        server.hub.loop.call_soon_threadsafe(stall)
        assert inside.wait(30), "the event loop did not run the stall"
        for k in range(5):
            server.hub.publish({"type": "estimate", "seq": -1 - k})
        gate.set()
        while True:
            text = client.recv()
            assert isinstance(text, str), text
            data = json.loads(text)
            batch = data if isinstance(data, list) else [data]
            tagged = [m["seq"] for m in batch if m["type"] == "estimate" and m["seq"] < 0]
            if tagged:
                break
        assert tagged == [-1, -2, -3, -4, -5], batch
    finally:
        gate.set()
        client.close()
