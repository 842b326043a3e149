"""The Foxglove bridge as Foxglove meets it: a protocol client (tests/apps/foxglove_client.py)
connects, reads serverInfo and the advertisements, subscribes, and decodes messageData
frames with the advertised JSON schemas."""

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

TOPICS = ("/spectratac/counts", "/spectratac/estimates", "/ft/wrench")
ROOT = Path(__file__).resolve().parents[2]


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
    client.subscribe("/ft/wrench")
    from spectratac.ft import FT_RECORD

    rows = np.zeros(3, FT_RECORD)
    rows["host_time"] = time.monotonic()
    rows["wrench"][:, 2] = -2.0
    bridge.ft(rows)
    bridge.frame(b"\x01\x00\x84\x00\x00", time.monotonic())  # not subscribed: not decoded
    got = client.receive(1.0)
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
