"""Reliability: corruption on the link, a device killed mid-stream, missing and silent ports,
another protocol major, and an unplugged-and-replugged pty with auto-reconnect."""

from __future__ import annotations

import os
import signal
import time
from pathlib import Path

import numpy as np
import pytest
from spectratac.device import (
    DeviceNotFoundError,
    DeviceTimeoutError,
    DisconnectedError,
    PermissionDeniedError,
    ProtocolMismatchError,
    Sensor,
)
from spectratac.protocol.generated import messages as m
from spectratac.sim.transport import SimTransport

from .conftest import Served
from .faults import CorruptingTransport, FutureMajorTransport


def test_one_percent_byte_corruption_is_counted_not_raised() -> None:
    link = CorruptingTransport(SimTransport("sim://?scene=tour&speed=max"), rate=0.01)
    with Sensor.attach(link) as sensor:
        sensor.start()
        link.armed = True
        got = sensor.read(2000, timeout=60)
        link.armed = False
        sensor.stop()
        stats = sensor.stats
    assert link.flipped > 500
    damaged = stats.crc_errors + stats.cobs_errors + stats.other_frame_errors
    assert damaged > 300 and stats.sample_gaps > 300
    seq = got["sequence"].astype(np.int64)
    assert len(seq) == 2000 and np.all(np.diff(seq) > 0)  # what arrives is whole and in order
    assert np.all(got["counts"][:, :, 3] > 1000)  # no corrupted sample slipped through


def test_device_killed_mid_stream(tcp_device: Served) -> None:
    sensor = Sensor.open(tcp_device.url)
    sensor.start()
    before = sensor.read(10, timeout=5)
    assert len(before) == 10
    time.sleep(0.3)  # more samples arrive and wait in the buffer
    tcp_device.signal(signal.SIGKILL)
    tcp_device.process.wait(timeout=10)
    kept = sensor.read(10_000, timeout=3)
    assert len(kept) >= 3 and kept["sequence"][0] == 10  # received before the loss: readable
    with pytest.raises(DisconnectedError, match="lost the link"):
        sensor.read(1, timeout=3)
    with pytest.raises(DisconnectedError):
        sensor.status()
    sensor.close()


def test_path_that_does_not_exist_lists_ports() -> None:
    with pytest.raises(
        DeviceNotFoundError, match=r"no device at '/dev/ttyNOPE'\. ([Nn]o s|S)erial ports"
    ):
        Sensor.open("/dev/ttyNOPE")


def test_silent_device_times_out_clearly(no_reply_pty: str) -> None:
    with pytest.raises(DeviceTimeoutError, match=r"no reply to GET_INFO .* within 0\.3 s"):
        Sensor.open(no_reply_pty, timeout=0.3)


def test_wrong_protocol_major_names_both_versions() -> None:
    link = FutureMajorTransport(SimTransport("sim://?scene=idle&speed=1"))
    with pytest.raises(
        ProtocolMismatchError,
        match=rf"speaks protocol 2\.1, this host library 1\.{m.PROTOCOL_MINOR}",
    ):
        Sensor.attach(link, timeout=1.0)


def test_unknown_scene_is_a_clear_error() -> None:
    with pytest.raises(Exception, match="unknown scene 'nope'; choose one of"):
        Sensor.open("sim://?scene=nope")


@pytest.mark.skipif(os.geteuid() != 0, reason="needs root to drop to another user")
def test_permission_denied_says_how_to_fix(tmp_path: Path) -> None:
    port = tmp_path / "port"
    port.touch(mode=0o600)  # owned by root: another user may not open it
    tmp_path.chmod(0o755)
    read_end, write_end = os.pipe()
    pid = os.fork()
    if pid == 0:  # child: become 'nobody' (no exec, so the venv need not be readable)
        try:
            os.setgid(65534)
            os.setuid(65534)
            Sensor.open(str(port))
            message = b"opened"
        except PermissionDeniedError as exc:
            message = str(exc).encode()
        except BaseException as exc:
            message = repr(exc).encode()
        os.write(write_end, message)
        os._exit(0)
    os.close(write_end)
    os.waitpid(pid, 0)
    message = os.read(read_end, 4096).decode()
    os.close(read_end)
    assert "permission denied opening" in message and "dialout" in message


def test_unplug_and_replug_with_reconnect(pty_device: Served) -> None:
    with Sensor.open(pty_device.url, reconnect=True, timeout=2.0) as sensor:
        sensor.configure(integration_ms=50)
        sensor.start()
        assert len(sensor.read(5, timeout=5)) == 5
        pty_device.signal(signal.SIGUSR1)  # the adapter is pulled out, then plugged in again
        deadline = time.monotonic() + 20
        while sensor.stats.reconnects == 0 and time.monotonic() < deadline:
            sensor.read(100, timeout=0.2)
        assert sensor.stats.reconnects == 1
        resumed = sensor.read(5, timeout=10)
        seq = resumed["sequence"].astype(int)
        assert len(seq) == 5 and np.all(np.diff(seq) == 1)
        assert seq[0] < 10  # a freshly booted device, configured and started again by the host
        sensor.stop()


def test_reconnect_starts_a_new_epoch(pty_device: Served) -> None:
    """After an unplug the device may have restarted: its clock and sample numbers start
    afresh, and every sample and time sync names the connection epoch it belongs to."""
    with Sensor.open(pty_device.url, reconnect=True, timeout=2.0) as sensor:
        sensor.configure(integration_ms=50)
        sensor.start()
        parts = [sensor.read(10, timeout=5)]
        sensor.sync_clock(2)
        pty_device.signal(signal.SIGUSR1)
        deadline = time.monotonic() + 20
        while sensor.stats.reconnects == 0 and time.monotonic() < deadline:
            parts.append(sensor.read(100, timeout=0.2))
        parts.append(sensor.read(10, timeout=10))
        sensor.sync_clock(2)
        sensor.stop()
        assert sensor.epoch == 1
        epochs_of_syncs = [e.epoch for e in sensor.time_sync]
    got = np.concatenate(parts)
    epoch = got["epoch"]
    assert epoch[0] == 0 and epoch[-1] == 1 and np.all(np.diff(epoch.astype(int)) >= 0)
    for e in (0, 1):  # within an epoch, device time only moves forward
        assert np.all(np.diff(got["device_time_us"][epoch == e].astype(np.int64)) > 0)
    new = got[epoch == 1]
    assert new["sequence"][0] < 10 and new["device_time_us"][0] < 1 << 32
    assert epochs_of_syncs == [0, 0, 1, 1]
