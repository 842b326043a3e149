"""Recording sessions end to end: what the file holds, how sessions end, bad links."""

from __future__ import annotations

import threading
from pathlib import Path

import numpy as np
import pytest
from spectratac.dataset.frames import recorded_samples
from spectratac.device import Sensor
from spectratac.device.errors import DisconnectedError
from spectratac.hardware.generated import vocabulary as vocab
from spectratac.record import (
    GuidedProtocol,
    Recorder,
    Recording,
    RecordingError,
    RecordingSummary,
    RecordOptions,
    read_recording,
    record_url,
)
from spectratac.record.format import VERSION
from spectratac.sim.transport import SimTransport
from spectratac.twin.geometry import region_of


def test_the_file_holds_every_channel(tour_session: tuple[RecordingSummary, Recording]) -> None:
    summary, rec = tour_session
    assert summary.stopped_by == "duration" and summary.error is None
    assert rec.end is not None and rec.end["samples"] == summary.samples
    # session: URLs, what the link knows, the simulated world, both clocks, versions
    s = rec.session
    assert s["url"] == s["ft_url"] and "ft=bota" in s["url"]
    assert s["version"] == VERSION and "sim" not in s
    assert s["link"] == {"clock_scale": 10.0, "paired_ft_url": s["url"], "ground_truth": True}
    assert rec.link.clock_scale == 10.0 and rec.link.ground_truth
    assert s["truth"]["scene"] == "tour" and s["truth"]["seed"] == 1 and s["truth"]["speed"] == 10.0
    assert s["unix_minus_monotonic_ns"] > 0 and s["library_version"]
    assert s["labels"] == "scene"
    # device identity and the acknowledged configuration, keyed by its id
    assert rec.info is not None and len(rec.info["unit_id"]) == 24
    assert list(rec.configs) == [summary.config_id]
    config = rec.configs[summary.config_id]
    assert config["reply"]["integration_ms"] == 50 and config["config"]["leds"] == [[[500] * 3] * 3]
    # every sample frame, contiguous, under that configuration
    samples = recorded_samples(rec.frames, rec.frame_host_times)
    assert len(samples) == summary.samples >= 200
    assert np.all(np.diff(samples["sequence"].astype(np.int64)) == 1)
    assert set(samples["config_id"]) == {summary.config_id}
    assert np.all(np.diff(rec.frame_host_times) >= 0)
    # clock sync: before streaming, every second (sync_every_s=1.0) and at the end
    assert len(rec.time_sync) >= 8 * 3
    # F/T batches: rows in order; what is missing by sequence is what the driver lost
    assert rec.ft is not None and len(rec.ft) == summary.ft_samples > 10_000
    gaps = np.diff(rec.ft["sequence"].astype(np.int64)) - 1
    assert gaps.min() >= 0 and gaps.sum() == summary.ft_lost
    assert rec.ft_info is not None and rec.ft_info["kind"] == "bota"
    assert rec.stats is not None and rec.stats["samples"] == summary.samples


def test_scene_labels_match_the_scene(tour_session: tuple[RecordingSummary, Recording]) -> None:
    _, rec = tour_session
    from spectratac.sim.world import rebuild_scene

    scene = rebuild_scene(rec.truth)
    p = scene.presses
    last_scene_s = recorded_samples(rec.frames, rec.frame_host_times)["t_end_us"][-1] / 1e6
    indices = [e["index"] for e in rec.labels]
    assert indices == list(range(len(indices)))  # every press, in order, once
    assert len(indices) >= np.count_nonzero(p.end <= last_scene_s) >= 15
    for e in rec.labels:
        i = e["index"]
        assert e["source"] == "scene"
        assert e["region"] == int(region_of(p.x[i], p.y[i]))
        assert e["scene_start"] == pytest.approx(p.start[i]) and e["scene_end"] == pytest.approx(
            p.end[i]
        )
        # host times from the scene's epoch (its first START, after the session message)
        epoch, speed = rec.labels[0]["t_start"] - p.start[0] / 10.0, 10.0
        assert e["t_start"] == pytest.approx(epoch + p.start[i] / speed)
    assert rec.epochs[0]["host_time"] <= epoch
    assert [e["region"] for e in rec.labels[:9]] == list(vocab.REGIONS)  # the tour's order


def test_a_stop_request_finishes_the_file(tmp_path: Path) -> None:
    stop = threading.Event()
    path = tmp_path / "stopped.mcap"
    with Sensor.open("sim://?scene=tour&speed=20") as sensor:  # duration: sensor seconds
        timer = threading.Timer(0.5, stop.set)
        timer.start()
        summary = Recorder(sensor, path, RecordOptions(duration_s=1200)).run(stop)
    assert summary.stopped_by == "interrupt" and summary.samples > 0
    rec = read_recording(path)
    assert not rec.truncated and rec.end is not None and rec.end["stopped_by"] == "interrupt"


class CuttingTransport:
    """Passes the device's bytes through, then loses the link after `limit` bytes."""

    def __init__(self, inner: SimTransport, limit: int) -> None:
        self.inner, self.url, self.limit, self.passed = inner, inner.url, limit, 0

    def read(self, timeout: float) -> bytes:
        if self.passed >= self.limit:
            raise DisconnectedError(f"{self.url}: cable pulled (test)")
        data = self.inner.read(timeout)
        self.passed += len(data)
        return data

    def write(self, data: bytes) -> None:
        if self.passed >= self.limit:
            raise DisconnectedError(f"{self.url}: cable pulled (test)")
        self.inner.write(data)

    def close(self) -> None:
        self.inner.close()


def test_a_lost_link_ends_the_session_and_keeps_what_arrived(tmp_path: Path) -> None:
    path = tmp_path / "lost.mcap"
    transport = CuttingTransport(SimTransport("sim://?scene=tour&speed=max"), 20_000)
    with Sensor.attach(transport) as sensor:
        summary = Recorder(sensor, path, RecordOptions(duration_s=60)).run()
    assert summary.stopped_by == "error" and "cable pulled" in (summary.error or "")
    rec = read_recording(path)  # finished properly: no truncation warning
    assert not rec.truncated and rec.end is not None and rec.end["stopped_by"] == "error"
    samples = recorded_samples(rec.frames, rec.frame_host_times)
    assert len(samples) == summary.samples > 100  # every sample that arrived is in the file
    assert np.all(np.diff(samples["sequence"].astype(np.int64)) == 1)


def test_a_session_that_cannot_start_is_an_error(tmp_path: Path) -> None:
    transport = CuttingTransport(SimTransport("sim://?scene=idle&speed=max"), 0)
    transport.passed = -10_000  # let the handshake through, then cut before CONFIGURE's ACK
    sensor = Sensor.attach(transport, timeout=1.0)
    transport.limit = transport.passed
    with sensor, pytest.raises(RecordingError, match="could not start"):
        Recorder(sensor, tmp_path / "x.mcap", RecordOptions(samples=5)).run()
    assert read_recording(tmp_path / "x.mcap").end["stopped_by"] == "error"  # type: ignore[index]


def test_guided_labels_are_recorded(tmp_path: Path) -> None:
    """The prompts run on the sensor's clock: at speed=max 3 prompts of 2 s take ~0.1 s."""
    import io

    out = io.StringIO()
    guided = GuidedProtocol(3, regions=[2, 5, 9], countdown_s=1, hold_s=0.5, rest_s=0.5, out=out)
    path = tmp_path / "guided.mcap"
    with Sensor.open("sim://?scene=idle&speed=max") as sensor:
        summary = Recorder(sensor, path, RecordOptions(duration_s=3600), guided=guided).run()
    assert summary.stopped_by == "guided" and summary.labels == 3
    rec = read_recording(path)
    assert rec.session["labels"] == "guided"
    assert [(e["region"], e["index"]) for e in rec.labels] == [(2, 0), (5, 1), (9, 2)]
    for e in rec.labels:
        assert e["t_end"] - e["t_start"] == pytest.approx(0.5)
        assert e["clock"] == "device"
    text = out.getvalue()
    assert "PRESS region 5" in text and " 4 [5] 6" in text and text.count("release") == 3


def test_options_are_checked() -> None:
    with pytest.raises(RecordingError, match="duration"):
        RecordOptions(duration_s=-1).validate()
    with pytest.raises(RecordingError, match="samples"):
        RecordOptions(samples=0).validate()
    with pytest.raises(RecordingError, match="at least one prompt"):
        GuidedProtocol(0)


def test_a_simulated_session_ends_with_its_scene(tmp_path: Path) -> None:
    from spectratac.record import record_url

    path = tmp_path / "press.mcap"
    summary = record_url("sim://?scene=press&speed=10", path, RecordOptions())
    rec = read_recording(path)
    duration = rec.truth["duration_s"]
    assert summary.stopped_by == "scene_end"
    last = recorded_samples(rec.frames, rec.frame_host_times)["t_end_us"][-1] / 1e6
    assert duration <= last < duration + 2.0  # within a loop pass (20 ms x speed) or so
    assert [e["index"] for e in rec.labels] == [0]  # the scene's one press


def test_a_lost_device_keeps_the_ft_rows_too(tmp_path: Path) -> None:
    from spectratac.ft import FTSensor

    url = "sim://?scene=tour&seed=3&speed=10&ft=netft"
    path = tmp_path / "lost_ft.mcap"
    transport = CuttingTransport(SimTransport(url), 12_000)
    with Sensor.attach(transport) as sensor, FTSensor.open(url) as ft:
        summary = Recorder(sensor, path, RecordOptions(duration_s=60), ft=ft).run()
    assert summary.stopped_by == "error"
    rec = read_recording(path)
    assert rec.ft is not None and len(rec.ft) == summary.ft_samples > 1000
    last_frame = rec.frame_host_times[-1]
    # F/T written up to the loss (the in-process simulated F/T thread may lag a loaded
    # machine's recorder by a few of its 20 ms passes: a generous bound)
    assert rec.ft["host_time"][-1] > last_frame - 0.5


def test_every_sample_carries_the_scenes_truth(
    tour_session: tuple[RecordingSummary, Recording],
) -> None:
    """The ground-truth channel: one row per SAMPLE frame, in frame order, holding the
    scene's contact at the centre of the sample's window on the device (= scene) clock."""
    from spectratac.sim.world import rebuild_scene

    _, rec = tour_session
    truth = rec.ground_truth
    samples = recorded_samples(rec.frames, rec.frame_host_times)
    assert truth is not None and len(truth) == len(samples) > 200
    for key in ("sequence", "t_start_us", "t_end_us"):
        np.testing.assert_array_equal(truth[key], samples[key])
    scene = rebuild_scene(rec.truth)
    t_mid = (samples["t_start_us"] + samples["t_end_us"]) / 2e6
    contact = scene.contact(t_mid)
    np.testing.assert_array_equal(truth["region"], contact.region)
    np.testing.assert_array_equal(truth["in_contact"], contact.in_contact)
    np.testing.assert_array_equal(truth["press"], scene.press_index(t_mid))
    np.testing.assert_array_equal(truth["force_n"][:, 2], contact.normal)
    np.testing.assert_array_equal(truth["position_mm"][:, 0], contact.x)
    assert set(np.unique(truth["region"])) == {-1, *vocab.REGIONS}


def test_truth_is_written_before_its_frames(tmp_path: Path) -> None:
    """Any readable prefix of a recording (a crash) has the truth of every sample in it."""
    path = tmp_path / "t.mcap"
    record_url("sim://?scene=tour&speed=max", path, RecordOptions(samples=60))
    data = path.read_bytes()
    for cut in range(len(data) // 5, len(data), len(data) // 5):
        (tmp_path / "cut.mcap").write_bytes(data[:cut])
        with pytest.warns(UserWarning):
            rec = read_recording(tmp_path / "cut.mcap")
        n = len(recorded_samples(rec.frames, rec.frame_host_times))
        assert rec.ground_truth is not None and len(rec.ground_truth) >= n


def test_a_link_without_ground_truth_records_no_truth(tmp_path: Path) -> None:
    path = tmp_path / "plain.mcap"
    with Sensor.open("sim://?scene=tour&speed=max") as sensor:
        Recorder(sensor, path, RecordOptions(samples=20)).run()
    rec = read_recording(path)
    assert rec.ground_truth is None and rec.labels == [] and rec.session["labels"] == "none"
