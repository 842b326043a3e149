"""Link: the public request API that the model store, clock sync and conformance use."""

from __future__ import annotations

import queue
import time

import pytest
from spectratac.device import DeviceTimeoutError, DisconnectedError, Sensor, SensorStats
from spectratac.device.link import Link
from spectratac.protocol import encode_frame
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
