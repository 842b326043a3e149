"""Sensor against the simulated device (the real firmware core on the twin), in-process."""

from __future__ import annotations

import threading

import cobs.cobs as cobs
import numpy as np
import pytest
from spectratac.device import (
    SAMPLE_RECORD,
    BufferOverflowError,
    CommandRejectedError,
    Sensor,
)
from spectratac.protocol import Frame, decode_frame
from spectratac.protocol.generated import messages as m
from spectratac.sim.url import parse_sim_url

FAST = "sim://?scene=tour&seed=3&speed=max"


def test_stream_read_and_iterate() -> None:
    with Sensor.open(FAST) as sensor:
        assert sensor.info.board == "native-sim"
        assert sensor.info.capabilities & m.Capabilities.CAP_SIMULATED
        cid = sensor.configure(integration_ms=100, leds=[[[300, 600, 900]] * 3])
        sensor.start()
        batch = sensor.read(30, timeout=10)
        first = next(iter(sensor))
        sensor.stop()
    assert batch.dtype == SAMPLE_RECORD and len(batch) == 30
    assert np.all(batch["config_id"] == cid)
    assert batch["sequence"].tolist() == list(range(30))
    assert np.all(np.diff(batch["device_time_us"].astype(np.int64)) == 100_000)
    assert np.all(batch["device_time_us"] - batch["t_start_us"] >= 100_000)
    assert np.all(batch["counts"][:, :, 3] > 1000)  # clear channel well lit
    assert first.sequence == 30 and len(first.counts) == 3


def test_led_sequence_steps_tagged() -> None:
    steps = [[[1000 if c == k else 0 for c in range(3)]] * 3 for k in range(3)]
    with Sensor.open(FAST) as sensor:
        sensor.configure(integration_ms=50, leds=steps)
        sensor.start()
        batch = sensor.read(12, timeout=10)
        sensor.stop()
    assert batch["step"].tolist() == [0, 1, 2] * 4
    red = batch["counts"][batch["step"] == 0].mean(axis=0)
    blue = batch["counts"][batch["step"] == 2].mean(axis=0)
    assert np.all(red[:, 0] > blue[:, 0]) and np.all(blue[:, 2] > red[:, 2])


def test_local_validation_names_argument() -> None:
    with Sensor.open(FAST) as sensor:
        with pytest.raises(ValueError, match="integration_ms=75"):
            sensor.configure(integration_ms=75)
        with pytest.raises(ValueError, match=r"1\.\.8 steps"):
            sensor.configure(leds=np.zeros((9, 3, 3), dtype=int))
        with pytest.raises(ValueError, match=r"0\.\.1000"):
            sensor.configure(leds=[[[1001, 0, 0]] * 3])


def test_device_nack_raises_with_reason(monkeypatch: pytest.MonkeyPatch) -> None:
    with Sensor.open(FAST) as sensor:
        monkeypatch.setattr(m.Configure, "validate", lambda self: None)  # let it reach the device
        with pytest.raises(CommandRejectedError) as info:
            sensor.configure(settle_us=20_000)
    assert info.value.name == "BAD_SETTLE_TIME" and "0..10000" in str(info.value)


def test_overflow_policies_are_counted() -> None:
    for policy in ("drop_oldest", "drop_newest"):
        with Sensor.open(FAST, buffer_size=5, overflow=policy) as sensor:
            sensor.start()
            while sensor.stats.buffer_overflows < 20:
                threading.Event().wait(0.01)
            sensor.stop()
            kept = sensor.read(100, timeout=0.5)["sequence"]
        assert len(kept) == 5
        assert (kept[0] == 0) == (policy == "drop_newest")
    with Sensor.open(FAST, buffer_size=5, overflow="error") as sensor:
        sensor.start()
        while sensor.stats.buffer_overflows == 0:
            threading.Event().wait(0.01)
        assert len(sensor.read(5, timeout=1)) == 5
        with pytest.raises(BufferOverflowError, match="larger buffer_size"):
            sensor.read(5, timeout=1)
        sensor.stop()


def test_thread_safe_commands_and_idempotent_close() -> None:
    sensor = Sensor.open(FAST)
    sensor.start()
    errors: list[BaseException] = []

    def hammer() -> None:
        try:
            for _ in range(20):
                assert sensor.status().streaming == 1
                sensor.get_config()
        except BaseException as exc:
            errors.append(exc)

    threads = [threading.Thread(target=hammer) for _ in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(timeout=30)
    assert not errors
    sensor.stop()
    sensor.close()
    sensor.close()


def test_clock_sync_round_trip() -> None:
    with Sensor.open("sim://?scene=idle&speed=1") as sensor:
        sync = sensor.sync_clock(exchanges=5)
    assert len(sync.exchanges) == 5 and 0 < sync.round_trip < 0.5
    assert all(e.device_tx_us >= e.device_rx_us for e in sync.exchanges)


def test_absent_sensor_flagged_others_stream() -> None:
    with Sensor.open("sim://?scene=idle&speed=max&absent=1") as sensor:
        assert sensor.info.sensor_present == 0b101
        sensor.start()
        batch = sensor.read(5, timeout=10)
        sensor.stop()
        status = sensor.status()
    assert np.all(batch["status"][:, 1] & m.SensorStatus.SENSOR_ABSENT)
    assert np.all(batch["counts"][:, 1] == 0)
    assert np.all(batch["status"][:, [0, 2]] == 0) and np.all(batch["counts"][:, [0, 2], 3] > 0)
    assert status.sensor_present == 0b101


def test_frame_listener_sees_raw_frames_and_a_failing_one_is_dropped() -> None:
    seen: list[bytes] = []

    def broken(frame: Frame, host_time: float) -> None:
        raise RuntimeError("recorder bug")

    with Sensor.open(FAST) as sensor:
        sensor.add_listener(lambda frame, t: seen.append(frame.raw))
        sensor.add_listener(broken)
        sensor.start()
        samples = sensor.read(20, timeout=10)
        sensor.stop()
    raw_samples = [r for r in seen if r[2] == m.Sample.TYPE_ID]
    assert len(samples) == 20 and len(raw_samples) >= 20
    # the raw bytes are the frame as sent: they decode to the same sample
    first = decode_frame(cobs.encode(raw_samples[0])).message
    assert isinstance(first, m.Sample) and first.sample_seq == samples["sequence"][0]


def test_time_sync_replies_are_stamped_when_answered() -> None:
    # In a paced world device time is (host - epoch) * speed, so every exchange's device
    # stamps must fall inside its own host send/receive bracket (an answer stamped with the
    # time of the device's previous step would fall before host_sent). The clock runs from
    # the first START (scene time waits at 0 before it).
    from spectratac.sim.world import SimWorld

    url = "sim://?scene=idle&seed=7&speed=1"
    with Sensor.open(url) as sensor:
        world = SimWorld.join(parse_sim_url(url))
        try:
            before = sensor.sync_clock(2)
            sensor.start()
            sync = sensor.sync_clock(8)
        finally:
            world.release()
    assert all(ex.device_rx_us == ex.device_tx_us == 0 for ex in before.exchanges)
    epoch = world.epoch
    assert epoch is not None
    for ex in sync.exchanges:
        assert ex.host_sent - 1e-4 <= epoch + ex.device_rx_us / 1e6
        assert epoch + ex.device_tx_us / 1e6 <= ex.host_received + 1e-4
