"""The shared I/O thread: one selector reads every serial/pty/socket link of the process."""

from __future__ import annotations

import contextlib
import os
import queue
import threading
import time
import tty
from collections.abc import Iterator

import pytest
from spectratac.device import Sensor
from spectratac.device.errors import DisconnectedError
from spectratac.device.iohub import IoHub, shared_hub
from spectratac.device.transport import SerialTransport
from spectratac.protocol import encode_frame
from spectratac.protocol.generated import messages as m
from spectratac.sim.device import SimDevice
from spectratac.sim.named_scenes import make_scene
from spectratac.sim.serve import serve_tcp
from spectratac.sim.url import parse_sim_url


def _threads(name: str) -> list[threading.Thread]:
    return [t for t in threading.enumerate() if t.name == name and t.is_alive()]


def _eventually(check, timeout: float = 5.0) -> bool:  # type: ignore[no-untyped-def]
    deadline = time.monotonic() + timeout
    while not check():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.01)
    return True


# --- the hub on plain pipes ---------------------------------------------------------------


@pytest.fixture
def pipes() -> Iterator[list[tuple[int, int]]]:
    made = [os.pipe() for _ in range(3)]
    yield made
    for r, w in made:
        for fd in (r, w):
            with contextlib.suppress(OSError):
                os.close(fd)


def test_hub_delivers_each_link_its_bytes_and_reports_eof_once(
    pipes: list[tuple[int, int]],
) -> None:
    hub = IoHub()
    got: dict[int, queue.Queue[bytes]] = {i: queue.Queue() for i in range(3)}
    lost: queue.Queue[tuple[int, OSError]] = queue.Queue()
    links = [
        hub.add(r, lambda d, _t, i=i: got[i].put(d), lambda e, i=i: lost.put((i, e)), f"p{i}")
        for i, (r, _) in enumerate(pipes)
    ]
    for i, (_, w) in enumerate(pipes):
        os.write(w, bytes([65 + i]) * 3)
    assert [got[i].get(timeout=5) for i in range(3)] == [b"AAA", b"BBB", b"CCC"]
    os.close(pipes[1][1])  # EOF on link 1 only
    which, exc = lost.get(timeout=5)
    assert which == 1 and isinstance(exc, OSError) and links[1].closed
    os.write(pipes[0][1], b"more")
    assert got[0].get(timeout=5) == b"more" and hub.links == 2
    for link in links:
        link.close()
    assert _eventually(lambda: not hub.running)
    assert lost.empty()


def test_a_failing_callback_is_logged_and_the_link_keeps_working(
    pipes: list[tuple[int, int]], caplog: pytest.LogCaptureFixture
) -> None:
    hub = IoHub()
    got: queue.Queue[bytes] = queue.Queue()

    def on_data(data: bytes, _t: float) -> None:
        if data == b"boom":
            raise ValueError("owner bug")
        got.put(data)

    r, w = pipes[0]
    link = hub.add(r, on_data, lambda e: None, "flaky")
    os.write(w, b"boom")
    assert _eventually(lambda: "owner bug" in caplog.text)
    os.write(w, b"fine")
    assert got.get(timeout=5) == b"fine"
    link.close()
    assert _eventually(lambda: not hub.running)


def test_remove_waits_for_a_running_callback_then_no_more_calls(
    pipes: list[tuple[int, int]],
) -> None:
    hub = IoHub()
    entered, release = threading.Event(), threading.Event()
    calls: list[bytes] = []

    def slow(data: bytes, _t: float) -> None:
        entered.set()
        release.wait(5)
        calls.append(data)

    r, w = pipes[0]
    link = hub.add(r, slow, lambda e: None, "slow")
    os.write(w, b"x")
    assert entered.wait(60), "the hub did not call the slow handler within 60 s"
    closer = threading.Thread(target=link.close)
    closer.start()
    time.sleep(0.1)
    assert closer.is_alive()  # blocked until the callback returns
    release.set()
    closer.join(5)
    assert not closer.is_alive() and calls == [b"x"]
    os.write(w, b"late")
    time.sleep(0.1)
    assert calls == [b"x"]
    assert _eventually(lambda: not hub.running)


def test_hub_thread_ends_with_its_last_link_and_comes_back(
    pipes: list[tuple[int, int]],
) -> None:
    hub = IoHub()
    for _ in range(2):
        got: queue.Queue[bytes] = queue.Queue()
        link = hub.add(pipes[0][0], lambda d, _t, q=got: q.put(d), lambda e: None)
        os.write(pipes[0][1], b"hi")
        assert got.get(timeout=5) == b"hi" and hub.running
        link.close()
        assert _eventually(lambda: not hub.running)


# --- sensors over sockets to simulated devices ---------------------------------------------


class _Server:
    """`spectratac sim serve --tcp` run in this process (a thread per device)."""

    def __init__(self, seed: int) -> None:
        self.stop = threading.Event()
        urls: queue.Queue[str] = queue.Queue()
        opts = parse_sim_url(f"sim://?scene=idle&seed={seed}&speed=10")  # 200 samples/s
        self.thread = threading.Thread(
            target=serve_tcp, args=(opts, 0), kwargs={"announce": urls.put, "stop": self.stop}
        )
        self.thread.start()
        self.url = urls.get(timeout=10)

    def close(self) -> None:
        self.stop.set()
        self.thread.join(10)


@pytest.fixture
def servers() -> Iterator[list[_Server]]:
    made = [_Server(i) for i in range(8)]
    yield made
    for s in made:
        s.close()


def _assert_streaming(sensor: Sensor, n: int) -> None:
    batch = sensor.read(n, timeout=10)
    assert len(batch) == n
    seq = batch["sequence"].tolist()
    assert seq == list(range(seq[0], seq[0] + n))


def test_many_sensors_share_one_io_thread_and_close_cleanly(servers: list[_Server]) -> None:
    readers_before = len(_threads("spectratac-reader"))
    sensors = [Sensor.open(s.url, timeout=10) for s in servers]
    try:
        for s in sensors:
            s.start()
        for s in sensors:
            _assert_streaming(s, 40)
        assert len(_threads("spectratac-io")) == 1
        assert len(_threads("spectratac-reader")) == readers_before  # no thread per link
        assert shared_hub().links == len(sensors)
        assert all(s.stats.sample_gaps == 0 for s in sensors)
    finally:
        for s in sensors:
            s.close()
            s.close()  # idempotent
    assert shared_hub().links == 0
    assert _eventually(lambda: not _threads("spectratac-io"))


def test_one_device_lost_does_not_disturb_the_others(servers: list[_Server]) -> None:
    sensors = [Sensor.open(s.url, timeout=10) for s in servers[:3]]
    try:
        for s in sensors:
            s.start()
            _assert_streaming(s, 10)
        servers[1].close()  # the device goes away: its socket reaches EOF
        with pytest.raises(DisconnectedError, match="lost the link"):
            while True:  # samples from before the loss stay readable first
                sensors[1].read(1000, timeout=5)
        for s in (sensors[0], sensors[2]):
            s.read(10_000, timeout=0)
            _assert_streaming(s, 30)
            assert s.stats.sample_gaps == 0
        assert shared_hub().links == 2
    finally:
        for s in sensors:
            s.close()
    assert shared_hub().links == 0


def test_a_listener_may_close_its_sensor_from_the_io_thread(servers: list[_Server]) -> None:
    a, b = (Sensor.open(s.url, timeout=10) for s in servers[:2])
    try:
        seen = threading.Event()

        def close_on_first(_frame: object, _t: float) -> None:
            seen.set()
            a.close()

        for s in (a, b):
            s.start()
        a.add_listener(close_on_first)
        assert seen.wait(60), "no frame from the first sensor within 60 s"
        assert _eventually(lambda: shared_hub().links == 1)
        _assert_streaming(b, 20)
    finally:
        a.close()
        b.close()


# --- a pty whose device end vanishes (EIO) ---------------------------------------------------


def test_pty_device_gone_is_a_disconnect_with_earlier_samples_readable() -> None:
    out: list[bytes] = []
    dev = SimDevice(make_scene("idle"), 1, on_tx=lambda d, _t: out.append(d))
    dev.feed(b"\x00" + encode_frame(m.GetInfo(), 1))
    dev.step(0)
    info = out.pop()
    dev.feed(encode_frame(m.Start(), 2))
    dev.step(0)
    out.clear()
    while len(out) < 5:
        dev.run(1)
    master, slave = os.openpty()
    tty.setraw(slave)
    path = os.ttyname(slave)

    def answer() -> None:  # the INFO reply when the host asks, then five samples
        data = b""
        while b"\x00" not in data[1:]:
            data += os.read(master, 4096)
        os.write(master, info)

    threading.Thread(target=answer, daemon=True).start()
    sensor = Sensor.attach(SerialTransport(path), timeout=5)
    try:
        os.close(slave)
        os.write(master, b"".join(out))
        assert _eventually(lambda: sensor.buffered == 5)
        os.close(master)  # the device side is gone: the host's reads fail with EIO
        assert len(sensor.read(10, timeout=5)) == 5
        with pytest.raises(DisconnectedError, match="lost the link"):
            sensor.read(1, timeout=5)
    finally:
        sensor.close()
