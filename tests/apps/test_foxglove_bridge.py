"""The Foxglove bridge as Foxglove meets it: a protocol client (tests/apps/foxglove_client.py)
connects offering one subprotocol as Lichtblick or the SDK's clients do, reads serverInfo
and the advertisements (judged by Lichtblick's parse rules: tests/lichtblick_rules.py),
subscribes, and decodes messageData frames with the advertised JSON schemas. The bridge is
as closed as the live page (Host, Origin) and survives what a subscriber triggers."""

from __future__ import annotations

import json
import os
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest
from spectratac.apps.foxglove_bridge import BridgeError, FoxgloveBridge
from spectratac.apps.live.history import History
from spectratac.device import Sensor
from spectratac.ft import FTSensor

from tests.apps.conftest import PRESSES_URL
from tests.apps.foxglove_client import FoxgloveClient
from tests.lichtblick_rules import parse_channel

TOPICS = ("/spectratac/counts", "/spectratac/estimates", "/ft/wrench")
ROOT = Path(__file__).resolve().parents[2]


def subscribed(client: FoxgloveClient, bridge: FoxgloveBridge, *topics: str) -> None:
    """Subscribe and wait until the bridge has taken the subscription: messages published
    before it arrives are not for anyone (a loaded CI lost the first batch so)."""
    client.subscribe(*topics)
    deadline = time.monotonic() + 30.0  # a hang guard
    while not set(topics) <= bridge.subscribed_topics:
        assert time.monotonic() < deadline, f"the bridge never took the subscription {topics}"
        time.sleep(0.01)


def port_is_free(port: int) -> bool:
    """Whether a server could listen on `port` again (as servers bind: SO_REUSEADDR)."""
    with socket.socket() as s:
        s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            s.bind(("127.0.0.1", port))
        except OSError:
            return False
        return True


def test_without_a_model_the_bridge_serves_raw_counts_and_the_reference() -> None:
    """The bridge fed as the live session feeds its history: device frames and F/T rows
    (no decoder), from a simulated press with its simulated Bota."""
    url = "sim://?scene=press&seed=0&speed=4&ft=bota"
    history = History()
    with FoxgloveBridge(port=0) as bridge, Sensor.open(url) as sensor, FTSensor.open(url) as ft:
        port = bridge.port
        assert bridge.url == f"ws://127.0.0.1:{port}"
        history.add_tap(bridge)
        sensor.add_listener(lambda frame, t: history.add_frame(frame.raw, t))
        client = FoxgloveClient(bridge.url).connect(TOPICS)
        assert client.server_info["name"] == "SpectraTac"
        client.subscribe("/spectratac/counts", "/ft/wrench")
        sensor.configure()
        sensor.start()
        ft.start()
        got = []
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:  # the press peaks ~2.5 s of scene in
            history.add_ft(ft.read_available())
            sensor.read(1 << 20, timeout=0)
            got += client.receive(0.1)
            fz = [r.message["force"]["z"] for r in got if r.topic == "/ft/wrench"]
            if fz and min(fz) < -1.0 and sum(r.topic == "/spectratac/counts" for r in got) > 20:
                break
        counts = [r for r in got if r.topic == "/spectratac/counts"]
        wrench = [r for r in got if r.topic == "/ft/wrench"]
        assert wrench and min(r.message["force"]["z"] for r in wrench) < -1.0, (
            f"no loaded reference within 60 s: {len(wrench)} F/T messages"
        )
        assert len(counts) > 20 and all(r.message["s0"]["IR"] > 0 for r in counts)
        seqs = [r.message["sequence"] for r in counts]
        assert seqs == list(range(seqs[0], seqs[0] + len(seqs)))  # every sample, in order
        now_ns = time.time_ns()  # log times are host receive times, Unix ns
        assert all(0 < now_ns - r.log_time < 120e9 for r in got)
        assert np.all(np.diff([r.log_time for r in wrench]) >= 0)
    assert client.closed_by_server(), "the connection outlives the bridge"
    client.close()
    assert not [t for t in threading.enumerate() if t.name == "spectratac-foxglove"]
    assert port_is_free(port), "the bridge's port is still bound after close()"
    FoxgloveBridge(port).start().close()  # a restart on the same port, as a user would


def test_a_taken_port_is_a_typed_error_saying_what_to_do() -> None:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        s.listen()
        port = s.getsockname()[1]
        with pytest.raises(BridgeError, match=f"127.0.0.1:{port}.*--foxglove {port + 1}"):
            FoxgloveBridge(port).start()


def test_an_unsubscribed_channel_costs_nothing_and_close_is_idempotent() -> None:
    bridge = FoxgloveBridge(port=0).start()
    client = FoxgloveClient(bridge.url).connect(TOPICS)
    subscribed(client, bridge, "/ft/wrench")
    from spectratac.ft import FT_RECORD

    rows = np.zeros(3, FT_RECORD)
    rows["host_time"] = time.monotonic()
    rows["wrench"][:, 2] = -2.0
    bridge.ft(rows)
    bridge.frame(b"\x01\x00\x84\x00\x00", time.monotonic())  # not subscribed: not decoded
    got = client.receive(30.0, until=3)
    assert [r.message["force"]["z"] for r in got] == [-2.0] * 3
    assert bridge.sent["/ft/wrench"] == 3 and bridge.sent["/spectratac/counts"] == 0
    bridge.close()
    bridge.close()
    client.close()


@pytest.mark.slow
@pytest.mark.subprocess
def test_live_foxglove_serves_estimates_beside_the_reference(press_model, tmp_path) -> None:
    """`spectratac live MODEL URL --foxglove PORT` as a user runs it: the page and the bridge."""
    env = os.environ | {"PYTHONPATH": str(ROOT / "host")}
    proc = subprocess.Popen(
        [sys.executable, "-m", "spectratac", "live", str(press_model),
         PRESSES_URL + "&speed=4&ft=bota", "--foxglove", "0", "--no-browser", "--json",
         "--duration", "15", "-o", str(tmp_path)],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env, cwd=tmp_path,
    )  # fmt: skip
    try:
        assert proc.stdout is not None
        line = json.loads(proc.stdout.readline() or "{}")
        assert line.get("foxglove", "").startswith("ws://127.0.0.1:"), line
        client = FoxgloveClient(line["foxglove"]).connect(TOPICS)
        client.subscribe(*TOPICS)
        got = []
        deadline = time.monotonic() + 14
        while time.monotonic() < deadline:
            got += client.receive(0.5)
            est = [r.message for r in got if r.topic == "/spectratac/estimates"]
            if [e for e in est if e["contact"] and e["force"]["z"] < -1.0]:
                break
        est = [r.message for r in got if r.topic == "/spectratac/estimates"]
        pressed = [e for e in est if e["contact"] and e["force"]["z"] < -1.0]
        assert pressed, f"no decoded press in {len(est)} estimates"
        assert {e["source"] for e in est} == {"host"} and pressed[0]["region"] in range(1, 10)
        assert min(r.message["force"]["z"] for r in got if r.topic == "/ft/wrench") < -1.0
        assert any(r.topic == "/spectratac/counts" for r in got)
        assert client.closed_by_server(timeout=60), "the bridge outlived --duration"
        client.close()
        assert proc.wait(timeout=60) == 0, proc.stderr.read() if proc.stderr else ""
        port = int(line["foxglove"].rsplit(":", 1)[1])
        assert port_is_free(port)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()


@pytest.mark.slow
def test_live_prints_where_foxglove_connects_and_frees_it_after(
    press_model, capsys, tmp_path
) -> None:
    from spectratac.cli import main

    code = main(["live", str(press_model), PRESSES_URL + "&speed=1", "--no-browser",
                 "--foxglove", "0", "--duration", "2", "-o", str(tmp_path)])  # fmt: skip
    assert code == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].startswith("SpectraTac live: http://127.0.0.1:")
    assert lines[1].startswith("Foxglove bridge: ws://127.0.0.1:") and "Open connection" in lines[1]
    port = int(lines[1].split()[2].rsplit(":", 1)[1])
    assert port_is_free(port)
    assert not [t for t in threading.enumerate() if t.name == "spectratac-foxglove"]


# ---------------------------------------------------------------------- issue 33 / 36
@pytest.mark.parametrize("subprotocol", ["foxglove.websocket.v1", "foxglove.sdk.v1"])
def test_both_subprotocols_connect_and_every_channel_opens_in_lichtblick(
    subprotocol: str,
) -> None:
    with FoxgloveBridge(port=0) as bridge:
        client = FoxgloveClient(bridge.url, subprotocol=subprotocol).connect(TOPICS)
        assert set(client.channels) == set(TOPICS)
        for topic, channel in client.channels.items():  # as Lichtblick's player parses them
            parsed = parse_channel(
                channel["encoding"],
                channel["schemaName"],
                channel["schemaEncoding"],
                channel["schema"].encode(),
            )
            assert parsed.datatypes, topic
        subscribed(client, bridge, "/ft/wrench")
        bridge.ft(_wrench_rows(4, -2.0))
        assert [r.message["force"]["z"] for r in client.receive(30.0, until=4)] == [-2.0] * 4
        client.close()


def _handshake_refusal(url: str, **options: object) -> tuple[int, dict[str, str]]:
    import websocket

    with pytest.raises(websocket.WebSocketBadStatusException) as caught:
        websocket.create_connection(url, subprotocols=["foxglove.websocket.v1"], timeout=10,
                                    **options)  # fmt: skip
    return caught.value.status_code, json.loads(caught.value.resp_body)


def test_another_origin_or_host_is_refused_with_a_reason() -> None:
    """A page of another site (its Origin) or a DNS-rebinding page (its Host) is refused
    before the handshake, as the live page refuses them; a client that offers no Foxglove
    subprotocol is told which to offer."""
    with FoxgloveBridge(port=0) as bridge:
        status, body = _handshake_refusal(bridge.url, origin="http://evil.example")
        assert status == 403 and body["code"] == "bad_origin" and "evil.example" in body["error"]
        status, body = _handshake_refusal(bridge.url, host=f"attacker.example:{bridge.port}")
        assert status == 403 and body["code"] == "bad_host"
        import websocket

        with pytest.raises(websocket.WebSocketBadStatusException) as caught:
            websocket.create_connection(bridge.url, timeout=10)
        assert caught.value.status_code == 400
        assert "foxglove.websocket.v1" in json.loads(caught.value.resp_body)["error"]
        # the served address itself, and a client sending no Origin (desktop apps), pass
        FoxgloveClient(bridge.url).connect(TOPICS).close()
        ws = websocket.create_connection(bridge.url, subprotocols=["foxglove.websocket.v1"],
                                         suppress_origin=True, timeout=10)  # fmt: skip
        assert json.loads(ws.recv())["op"] == "serverInfo"
        ws.close()


def _wrench_rows(n: int, fz: float) -> np.ndarray:
    from spectratac.ft import FT_RECORD

    rows = np.zeros(n, FT_RECORD)
    rows["host_time"] = time.monotonic()
    rows["wrench"][:, 2] = fz
    return rows


def _live_session_with_bridge(
    decoder: object, url: str, history_s: float = 120.0
) -> tuple[object, FoxgloveBridge]:
    from spectratac.apps.live.session import LiveSession

    session = LiveSession(decoder, url, ft_url=url, history_s=history_s)
    bridge = FoxgloveBridge(port=0).start()
    session.history.add_tap(bridge)
    return session, bridge


@pytest.mark.slow
@pytest.mark.parametrize("with_model", [False, True])
def test_a_subscriber_on_every_channel_gets_messages_with_and_without_a_model(
    with_model: bool, request: pytest.FixtureRequest
) -> None:
    """The live session feeds the bridge (history taps); a client subscribes to every
    advertised channel. Without a model the rows carry no estimate (it raised TypeError
    on the send thread, and the bridge then sent nothing to anyone)."""
    decoder = None
    if with_model:
        from spectratac.decode import Decoder

        decoder = Decoder.load(request.getfixturevalue("press_model"))
    session, bridge = _live_session_with_bridge(decoder, PRESSES_URL + "&speed=4&ft=bota")
    try:
        client = FoxgloveClient(bridge.url).connect(TOPICS)
        client.subscribe(*TOPICS)
        session.start(lambda _msg: None)
        got: dict[str, list] = {t: [] for t in TOPICS}
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and not all(len(v) > 5 for v in got.values()):
            for r in client.receive(0.2):
                got[r.topic].append(r.message)
        assert all(len(v) > 5 for v in got.values()), {t: len(v) for t, v in got.items()}
        est = got["/spectratac/estimates"]
        if with_model:
            assert any(e["decoded"] and e["region"] != -1 for e in est)
        else:
            assert all(not e["decoded"] and e["region"] == -1 and e["invalid"] for e in est)
        assert bridge.stats["errors"] == 0
        client.close()
    finally:
        session.stop()
        bridge.close()


def test_an_exception_while_encoding_is_logged_once_and_later_messages_arrive(
    monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    import spectratac.apps.foxglove_bridge as fb

    real = fb.wrench_messages
    failures = {"left": 3}

    def flaky(rows: np.ndarray) -> list[bytes]:
        if failures["left"]:
            failures["left"] -= 1
            raise TypeError("injected")
        return real(rows)

    monkeypatch.setattr(fb, "wrench_messages", flaky)
    with FoxgloveBridge(port=0) as bridge:
        client = FoxgloveClient(bridge.url).connect(TOPICS)
        subscribed(client, bridge, "/ft/wrench")
        for _ in range(3):  # three batches, each failing
            bridge.ft(_wrench_rows(2, -1.0))
        bridge.ft(_wrench_rows(5, -3.0))
        got = client.receive(30.0, until=5)
        assert [r.message["force"]["z"] for r in got] == [-3.0] * 5
        assert bridge.stats["errors"] == 3
        client.close()
    logged = [r for r in caplog.records if "could not be sent" in r.getMessage()]
    assert len(logged) == 1 and "TypeError" in logged[0].getMessage()


def test_the_queues_are_bounded_the_oldest_dropped_and_counted(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    import spectratac.apps.foxglove_bridge as fb

    monkeypatch.setattr(fb, "TAP_LIMIT", 100)
    bridge = FoxgloveBridge(port=0)  # not started: nothing drains its taps
    for i in range(250):
        bridge.frame(bytes([1, 0, 0x84, i % 256, 0]), float(i))
    assert bridge.stats["dropped"] == 150
    kept = bridge._frames.drain()
    assert len(kept) == 100 and kept[0][1] == 150.0  # the newest kept


def test_drops_are_said_in_one_log_line_per_period(
    monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    import spectratac.apps.foxglove_bridge as fb

    monkeypatch.setattr(fb, "TAP_LIMIT", 10)
    monkeypatch.setattr(fb, "DROP_REPORT_S", 0.2)
    bridge = FoxgloveBridge(port=0)
    for i in range(1000):  # before it starts: nothing drains them
        bridge.frame(bytes([1, 0, 0x84, i % 256, 0]), float(i))
    with bridge:
        deadline = time.monotonic() + 10
        while not any("dropped" in r.getMessage() for r in caplog.records):
            assert time.monotonic() < deadline, "no log line about the drops"
            time.sleep(0.05)
        time.sleep(0.5)  # no new drops: no new line
    lines = [r.getMessage() for r in caplog.records if "dropped" in r.getMessage()]
    assert len(lines) == 1 and lines[0].startswith("Foxglove bridge: 990 messages dropped")


def _rss_mb() -> float:
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20


@pytest.mark.slow
def test_memory_stays_flat_over_a_minute_at_speed_10_with_a_subscriber() -> None:
    """A minute of `speed=10` (10 kHz of simulated F/T) fed to the bridge as the live
    session feeds it (history taps: device frames, F/T batches, rows without a model), a
    client subscribed to every channel: RSS after the first 10 s grows by less than 30 MB
    (it grew 70 MB a minute once the send thread died). The history keeps 5 s, so that it
    is full before the measure starts; the sensor is drained as the session drains it."""
    url = "sim://?scene=presses&seed=0&speed=10&ft=bota"
    history = History(keep_s=5.0)
    with FoxgloveBridge(port=0) as bridge, Sensor.open(url) as sensor, FTSensor.open(url) as ft:
        history.add_tap(bridge)
        sensor.add_listener(lambda frame, t: history.add_frame(frame.raw, t))
        client = FoxgloveClient(bridge.url).connect(TOPICS)
        client.subscribe(*TOPICS)
        sensor.configure()
        sensor.start()
        ft.start()
        start = time.monotonic()
        received, key, base = 0, 0, None
        while time.monotonic() - start < 60:
            history.add_ft(ft.read_available())
            for sample in sensor.read(1 << 20, timeout=0):
                history.add_row(key, {"host_time": float(sample["host_time"]),
                                      "device_time_s": float(sample["device_time_us"]) / 1e6,
                                      "region": None, "contact": None, "ood": None,
                                      "invalid": None})  # fmt: skip
                key += 1
            received += len(client.receive(0.2))
            if base is None and time.monotonic() - start > 10:
                base = _rss_mb()
        assert base is not None
        growth = _rss_mb() - base
        print(f"RSS growth {growth:.1f} MB over 50 s; {received} messages; {bridge.stats}")
        assert growth < 30, f"RSS grew {growth:.1f} MB"
        assert received > 1000 and bridge.stats["errors"] == 0
        client.close()
