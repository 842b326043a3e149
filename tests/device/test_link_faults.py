"""A hostile link: impossible sample windows, a frame of another major, stray bytes and lost
commands on the way to the device, and device text meant to drive the terminal. Every fault
goes through a real transport (the simulated device's) with a wrapper that damages it."""

from __future__ import annotations

import dataclasses
import logging
from pathlib import Path

import numpy as np
import pytest
from spectratac.dataset.build import build_datasets
from spectratac.dataset.frames import recorded_samples
from spectratac.device import DeviceError, ProtocolMismatchError, Sensor
from spectratac.device import sensor as sensor_module
from spectratac.device.records import SAMPLE_TIME_INVERTED, SAMPLE_WINDOW_CLIPPED
from spectratac.device.transport import open_transport
from spectratac.protocol import Frame, encode_frame
from spectratac.protocol.generated import messages as m
from spectratac.record import Recorder, RecordOptions
from spectratac.record.reader import read_recording
from spectratac.sim.transport import SimTransport

from .faults import LineNoiseTransport, RewritingTransport

FAST = "sim://?scene=tour&seed=3&speed=max"


def _inverted_every_fifth(frame: Frame) -> bytes:
    """SAMPLEs with sample_seq 2, 7, 12... end before they start (as after a clock fault)."""
    msg = frame.message
    if isinstance(msg, m.Sample) and msg.sample_seq % 5 == 2:
        msg = dataclasses.replace(msg, t_start_us=(msg.t_end_us + 1000) & 0xFFFF_FFFF)
    return encode_frame(msg, frame.seq, frame.version)


def test_inverted_sample_windows_are_flagged_not_raised() -> None:
    link = RewritingTransport(SimTransport(FAST), _inverted_every_fifth)
    with Sensor.attach(link) as sensor:
        sensor.start()
        got = sensor.read(20, timeout=30)
        sensor.stop()
        stats = sensor.stats
    assert got["sequence"].tolist() == list(range(20))
    flagged = (got["flags"] & SAMPLE_TIME_INVERTED) != 0
    assert flagged.tolist() == [s % 5 == 2 for s in range(20)]
    assert np.all(got["t_start_us"][flagged] == got["device_time_us"][flagged])
    assert np.all(got["device_time_us"][~flagged] - got["t_start_us"][~flagged] >= 50_000)
    assert stats.sample_time_errors >= 4  # counted (more came before the STOP's ACK)


def test_a_window_reaching_back_across_an_unseen_wrap_is_clipped() -> None:
    def before_the_wrap(frame: Frame) -> bytes:  # the first window began before 2^32 µs
        msg = frame.message
        if isinstance(msg, m.Sample) and msg.sample_seq == 0:
            msg = dataclasses.replace(msg, t_start_us=0xFFFF_FFFF - 500)
        return encode_frame(msg, frame.seq, frame.version)

    with Sensor.attach(RewritingTransport(SimTransport(FAST), before_the_wrap)) as sensor:
        sensor.start()
        got = sensor.read(3, timeout=30)
        sensor.stop()
    assert got["flags"].tolist() == [SAMPLE_WINDOW_CLIPPED, 0, 0]
    assert got["t_start_us"][0] == 0


def test_a_failed_conversion_leaves_the_samples_in_the_buffer(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    real = sensor_module.to_array
    calls = []

    def fails_once(samples: list) -> np.ndarray:  # type: ignore[type-arg]
        calls.append(len(samples))
        if len(calls) == 1:
            raise OverflowError("a value did not fit")
        return real(samples)

    with Sensor.open(FAST) as sensor:
        sensor.start()
        sensor.read(0, timeout=0)  # nothing taken yet
        while sensor.buffered < 10:
            sensor.read(0, timeout=0.05)
        monkeypatch.setattr(sensor_module, "to_array", fails_once)
        with pytest.raises(OverflowError):
            sensor.read(10, timeout=5)
        again = sensor.read(10, timeout=5)
        sensor.stop()
    assert again["sequence"].tolist() == list(range(10))  # the failed batch is still there


def test_record_keeps_going_over_inverted_windows(tmp_path: Path) -> None:
    link = RewritingTransport(SimTransport(FAST), _inverted_every_fifth)
    with Sensor.attach(link) as sensor:
        summary = Recorder(sensor, tmp_path / "s.mcap", RecordOptions(samples=30)).run()
    assert summary.stopped_by == "samples" and summary.error is None
    assert summary.samples >= 30
    assert summary.sensor_stats["sample_time_errors"] >= 6
    # the dataset keeps those samples, with empty windows and no target, never a window
    # reaching 2^32 us back
    rec = read_recording(tmp_path / "s.mcap")
    table = recorded_samples(rec.frames, rec.frame_host_times)
    bad = table["sequence"] % 5 == 2
    assert np.all(table["flags"][bad] == SAMPLE_TIME_INVERTED) and not table["flags"][~bad].any()
    assert np.all(table["t_start_us"][bad] == table["t_end_us"][bad])
    assert np.all(table["t_end_us"] - table["t_start_us"] <= 60_000)
    [ds] = build_datasets([tmp_path / "s.mcap"])
    assert ds.n == len(table) and np.all(np.abs(ds.t_end - ds.t_start) < 1.0)


def test_one_frame_of_another_major_does_not_kill_the_sensor() -> None:
    state = {"sent": False}

    def one_from_major_2(frame: Frame) -> bytes:
        msg = frame.message
        if isinstance(msg, m.Sample) and msg.sample_seq == 3 and not state["sent"]:
            state["sent"] = True
            return encode_frame(msg, frame.seq, (2, 0))
        return encode_frame(msg, frame.seq, frame.version)

    with Sensor.attach(RewritingTransport(SimTransport(FAST), one_from_major_2)) as sensor:
        sensor.start()
        got = sensor.read(10, timeout=30)
        status = sensor.status()  # a later command is answered as usual
        sensor.stop()
        assert sensor.stats.version_mismatches == 1
    assert state["sent"] and status.streaming == 1
    assert got["sequence"].tolist() == [0, 1, 2, *range(4, 11)]  # the foreign frame is dropped


def test_stray_bytes_before_a_command_do_not_swallow_it() -> None:
    link = LineNoiseTransport(SimTransport(FAST))
    with Sensor.attach(link, timeout=1.0) as sensor:
        sensor.start()
        sensor.read(5, timeout=10)
        link.noise = b"\x55\xaa\x13\x37"  # noise on the line just before STOP
        sensor.stop()
        assert sensor.stats.command_retries == 0  # the first STOP got through
        sensor.read(1 << 20, timeout=0.2)  # drain what came before the ACK
        assert len(sensor.read(1, timeout=0.3)) == 0  # and nothing after it


def test_a_lost_stop_is_sent_again_with_a_new_sequence_number() -> None:
    link = LineNoiseTransport(SimTransport(FAST))
    with Sensor.attach(link, timeout=6.0) as sensor:
        sensor.start()
        sensor.read(5, timeout=10)
        link.drop = 1  # the STOP is lost on its way to the device
        sensor.stop()
        assert sensor.stats.command_retries == 1
        sensor.read(1 << 20, timeout=0.2)
        assert len(sensor.read(1, timeout=0.3)) == 0
        sensor.stop()  # again, and while stopped: idempotent
        assert sensor.status().streaming == 0
    [lost] = link.dropped
    assert lost[0] == 0  # every command starts with a delimiter


def test_device_text_cannot_drive_the_terminal(caplog: pytest.LogCaptureFixture) -> None:
    def hostile(frame: Frame) -> bytes:
        msg = frame.message
        if isinstance(msg, m.Info):
            msg = dataclasses.replace(msg, board="ev\x1b]0;x\x07\x1b[2J")
        out = encode_frame(msg, frame.seq, frame.version)
        if isinstance(msg, m.Info):  # and a LOG line that tries to clear the screen
            out += encode_frame(m.Log(level=2, text="hi\x1b[2J\r"), 0xFFFF)
        return out

    link = RewritingTransport(SimTransport(FAST), hostile)
    with caplog.at_level(logging.WARNING, logger="spectratac.device"), Sensor.attach(link) as s:
        s.status()
        board, logs = s.info.board, list(s.logs)
    assert board == "ev\\x1b]0;x\\x07\\x1b[2J"
    assert logs[0].text == "hi\\x1b[2J\\r"
    assert not any("\x1b" in r.getMessage() for r in caplog.records)


@pytest.mark.parametrize(
    ("url", "says"),
    [
        ("socket://localhost:notaport", r"port 'notaport' is not a number"),
        ("socket://localhost", r"no port"),
        ("socket://localhost:99999", r"port 99999 is out of range"),
    ],
)
def test_a_bad_socket_address_is_a_clear_error(url: str, says: str) -> None:
    with pytest.raises(DeviceError, match=says + r".*socket://HOST:PORT") as caught:
        open_transport(url)
    assert type(caught.value).__name__ == "BadAddressError"


def test_a_reply_in_another_major_fails_that_command_only() -> None:
    def status_from_major_2(frame: Frame) -> bytes:
        version = (2, 0) if isinstance(frame.message, m.Status) else frame.version
        return encode_frame(frame.message, frame.seq, version)

    link = RewritingTransport(SimTransport(FAST), status_from_major_2)
    with Sensor.attach(link, timeout=0.5) as sensor:
        with pytest.raises(ProtocolMismatchError, match=r"speaks protocol 2\.0, this host"):
            sensor.status()
        assert sensor.get_config().config_id == 0  # the sensor still works
        assert sensor.stats.version_mismatches == 1 and sensor.stats.command_retries == 0


def _without_first_sample(frame: Frame) -> bytes:
    """The first SAMPLE of every stream (sample_seq 0) lost on the line."""
    if isinstance(frame.message, m.Sample) and frame.message.sample_seq == 0:
        return b""
    return encode_frame(frame.message, frame.seq, frame.version)


def test_a_sample_lost_at_the_start_of_a_stream_is_counted() -> None:
    link = RewritingTransport(SimTransport("sim://?scene=idle&speed=max"), _without_first_sample)
    with Sensor.attach(link) as sensor:
        for _ in range(2):  # every START counts from sample_seq 0 again
            sensor.start()
            got = sensor.read(10, timeout=30)
            sensor.stop()
            sensor.read(100_000, timeout=0.3)
            assert got["sequence"][0] == 1
        assert sensor.stats.sample_gaps == 2
