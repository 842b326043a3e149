"""Link: the public request API that the model store, clock sync and conformance use."""

from __future__ import annotations

import queue
import threading
import time

import pytest
from spectratac.device import DeviceTimeoutError, DisconnectedError, Sensor, SensorStats
from spectratac.device.link import Link
from spectratac.protocol import encode_frame
from spectratac.protocol.framing import decode_frame
from spectratac.protocol.generated import messages as m
from spectratac.protocol.schema import Message

FAST = "sim://?scene=idle&speed=max"


class SilentTransport:
    """A link whose device never answers; it sends only what a test puts in `incoming`."""

    url = "silent://"

    def __init__(self) -> None:
        self.incoming: queue.Queue[bytes] = queue.Queue()
        self.written: list[bytes] = []
        self.closed = False

    def read(self, timeout: float) -> bytes:
        if self.closed:
            raise DisconnectedError("closed")
        try:
            return self.incoming.get(timeout=min(timeout, 0.01))
        except queue.Empty:
            return b""

    def write(self, data: bytes) -> None:
        self.written.append(data)

    def close(self) -> None:
        self.closed = True


def _silent_link(
    stats: SensorStats, data: queue.Queue[list[Message]], transport: SilentTransport | None = None
) -> Link:
    return Link(
        transport or SilentTransport(),
        stats=stats,
        on_data=lambda msgs, now, epoch: data.put(msgs),
        on_lost=lambda exc: None,
        on_new_epoch=lambda: None,
        on_resume=lambda: None,
        timeout=0.05,
    )


def test_request_returns_the_typed_reply() -> None:
    with Sensor.open(FAST) as sensor:
        status = sensor.link.request(m.GetStatus(), m.Status)
        assert isinstance(status, m.Status)
        before = time.monotonic()
        info, at = sensor.link.request_at(m.GetInfo(), m.Info)
        assert info.protocol_major == m.PROTOCOL_MAJOR
        assert before <= at <= time.monotonic()


def test_command_returns_the_ack_naming_it() -> None:
    with Sensor.open(FAST) as sensor:
        ack = sensor.link.command(m.ResetStats())
        assert ack.acked_type == m.ResetStats.TYPE_ID


def test_an_unanswered_request_is_sent_twice_then_times_out() -> None:
    stats = SensorStats()
    link = _silent_link(stats, queue.Queue())
    try:
        with pytest.raises(DeviceTimeoutError, match=r"no reply to GET_STATUS from silent://"):
            link.request(m.GetStatus(), m.Status)
        assert stats.command_retries == 1
        with pytest.raises(DeviceTimeoutError, match=r"START \(sent twice\)"):
            link.command(m.Start())
        assert stats.command_retries == 2
        with pytest.raises(DeviceTimeoutError):
            link.request(m.GetStatus(), m.Status, attempts=1)
        assert stats.command_retries == 2
    finally:
        link.close()


def test_data_frames_go_to_the_owner_and_logs_stay_on_the_link() -> None:
    stats = SensorStats()
    data: queue.Queue[list[Message]] = queue.Queue()
    transport = SilentTransport()
    link = _silent_link(stats, data, transport)
    try:
        sample = m.Sample(sample_seq=4, t_start_us=1, t_end_us=2)
        log = m.Log(level=1, text="hello")
        transport.incoming.put(b"\x00" + encode_frame(sample, 1) + encode_frame(log, 2))
        assert data.get(timeout=5) == [sample]
        assert [x.text for x in link.logs] == ["hello"]
        assert stats.frames_received == 2 and stats.logs == 1
    finally:
        link.close()


def test_data_sent_before_a_reply_is_buffered_when_the_reply_wakes_its_caller() -> None:
    """A SAMPLE and the ACK of STOP in one read: the owner has the sample before `command`
    returns, even when the reader thread runs the owner's handler late (a loaded host)."""
    data: queue.Queue[list[Message]] = queue.Queue()
    transport = SilentTransport()

    def slow_owner(msgs: list[Message], _now: float, _epoch: int) -> None:
        time.sleep(0.3)  # the reader thread descheduled in the middle of a chunk
        data.put(msgs)

    link = Link(
        transport,
        stats=SensorStats(),
        on_data=slow_owner,
        on_lost=lambda exc: None,
        on_new_epoch=lambda: None,
        on_resume=lambda: None,
        timeout=30,
    )
    sample = m.Sample(sample_seq=7, t_start_us=1, t_end_us=2)

    def device() -> None:
        for _ in range(3000):  # the command is written within a moment; bound 30 s
            if transport.written:
                break
            time.sleep(0.01)
        else:
            raise AssertionError("the host never wrote STOP within 30 s")
        frame = decode_frame(next(x for x in transport.written[0].split(b"\x00") if x))
        ack = m.Ack(acked_type=m.Stop.TYPE_ID, acked_seq=frame.seq)
        transport.incoming.put(b"\x00" + encode_frame(sample, 1) + encode_frame(ack, 2))

    feeder = threading.Thread(target=device)
    feeder.start()
    try:
        link.command(m.Stop(), attempts=1)
        assert data.get_nowait() == [sample]
    finally:
        feeder.join()
        link.close()
