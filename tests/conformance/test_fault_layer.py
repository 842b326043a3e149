"""The fault layer itself: URL errors, exact counting of what the device sent, serving."""

from __future__ import annotations

import threading

import pytest
from spectratac.conformance import run_suite
from spectratac.device import Sensor
from spectratac.device.errors import DeviceError
from spectratac.protocol.generated import messages as m
from spectratac.protocol.schema import Message
from spectratac.sim.faults import LATE_STOP_US, ledger
from spectratac.sim.serve import serve_tcp
from spectratac.sim.url import parse_sim_url

WHITE = [[[500, 500, 500]] * 3]


def _stream(url: str, n: int) -> tuple[Sensor, int]:
    with Sensor.open(url) as s:
        s.configure(integration_ms=50, leds=WHITE)
        s.start()
        got = len(s.read(n, timeout=30))
        s.stop()
        got += len(s.read(1 << 20, timeout=0.5))
    return s, got


def test_an_unknown_fault_is_refused_with_the_known_names() -> None:
    with pytest.raises(DeviceError, match=r"fault=nope must be one of wrong_hash\|"):
        Sensor.open("sim://?fault=nope")
    with pytest.raises(DeviceError, match="fault_rate=often is not a number; give"):
        Sensor.open("sim://?fault=corrupt&fault_rate=often")


def test_the_ledger_counts_exactly_what_a_healthy_device_sent() -> None:
    url = "sim://?scene=idle&seed=11&speed=max&fault=none"
    _, delivered = _stream(url, 500)
    assert delivered >= 500 and ledger(url).samples_sent == delivered
    assert ledger(url).boots == 1 and ledger(url).bytes_corrupted == 0


def test_corruption_is_rejected_by_crc_and_every_lost_sample_is_counted() -> None:
    url = "sim://?scene=idle&seed=12&speed=max&fault=corrupt&fault_rate=1e-3"
    s, delivered = _stream(url, 2000)
    book = ledger(url)
    assert book.frames_corrupted > 0 and s.stats.crc_errors + s.stats.cobs_errors > 0
    # the last sample before STOP may be the corrupted one: no later sample reveals it
    assert 0 <= book.samples_sent - delivered - s.stats.sample_gaps <= book.frames_corrupted
    assert s.stats.sample_gaps > 0


@pytest.mark.slow
def test_a_served_device_is_faulty_too() -> None:
    stop, address = threading.Event(), []
    opts = parse_sim_url("sim://?scene=idle&fault=flag_fault")
    server = threading.Thread(
        target=serve_tcp, args=(opts, 0), kwargs={"announce": address.append, "stop": stop}
    )
    server.start()
    try:
        while not address:
            stop.wait(0.05)
        result = run_suite(address[0])
    finally:
        stop.set()
        server.join()
    assert [n for n, o in result.rows if not o.passed] == ["sensor status flags"]


def test_a_late_stop_device_streams_on_for_its_own_time_whatever_the_host_sends() -> None:
    """The STOP is held for LATE_STOP_US of device time, and a request sent at once waits
    behind it (the device reads commands in order): the late samples all come before the
    reply, however soon the host asked."""
    wire: list[Message] = []
    with Sensor.open("sim://?scene=idle&fault=late_stop") as s:
        s.link.add_listener(lambda frame, _now: wire.append(frame.message))
        s.configure(integration_ms=50, leds=WHITE)
        s.start()
        s.read(3, timeout=30)
        s.stop()
        s.status()  # at once: before, this released the STOP
    ack = next(
        i for i, x in enumerate(wire) if isinstance(x, m.Ack) and x.acked_type == m.Stop.TYPE_ID
    )
    end = next(i for i, x in enumerate(wire) if isinstance(x, m.Status))
    late = [x for x in wire[ack:end] if isinstance(x, m.Sample)]
    assert len(late) >= LATE_STOP_US // 50_000 - 1
    span = (late[-1].t_end_us - late[0].t_end_us) & 0xFFFF_FFFF
    assert LATE_STOP_US - 100_000 <= span <= LATE_STOP_US
