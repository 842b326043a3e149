"""A simulated recording is a function of its URL and options: the scene clock starts with the
first stream, windows fall on the scene's grid from t=0, the duration ends on the device clock,
and a simulated F/T's samples fall on its own grid in scene time. Two recordings of one scene
hold the same device times, counts, ground truth and F/T values; only host times differ."""

from __future__ import annotations

import select
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from spectratac.dataset.build import build_datasets
from spectratac.dataset.frames import recorded_samples
from spectratac.record import RecordOptions, record_url
from spectratac.record.reader import Recording, read_recording


def _record(url: str, path: Path, duration_s: float) -> Recording:
    record_url(url, path, RecordOptions(duration_s=duration_s))
    return read_recording(path)


def _samples(rec: Recording) -> np.ndarray:
    return recorded_samples(rec.frames, rec.frame_host_times)


@pytest.mark.parametrize("speed", ["10", "max"])
def test_two_recordings_hold_the_same_samples(tmp_path: Path, speed: str) -> None:
    url = f"sim://?scene=tour&seed=3&speed={speed}"
    a, b = (_record(url, tmp_path / f"{k}.mcap", 3.0) for k in "ab")
    sa, sb = _samples(a), _samples(b)
    assert len(sa) == len(sb) == 60, "3 s of 50 ms windows, cut on the device clock"
    assert sa["t_start_us"][0] == 1000, "the first window starts at scene 0 plus the settle time"
    for name in ("t_start_us", "t_end_us", "sequence", "counts"):
        np.testing.assert_array_equal(sa[name], sb[name], err_msg=name)
    assert np.all(np.diff(sa["t_start_us"]) == 50_000), "windows on the scene's time grid"
    da, db = (build_datasets([r.path]) for r in (a, b))
    (xa,), (xb,) = da, db
    host_times = {"t_start", "t_end"}
    assert set(xa.arrays) == set(xb.arrays)
    for name in sorted(set(xa.arrays) - host_times):
        np.testing.assert_array_equal(xa.arrays[name], xb.arrays[name], err_msg=name)


def test_a_simulated_ft_samples_on_its_own_grid_in_scene_time(tmp_path: Path) -> None:
    url = "sim://?scene=tour&seed=1&speed=10&ft=bota"
    a, b = (_record(url, tmp_path / f"{k}.mcap", 2.0) for k in "ab")
    assert a.ft is not None and b.ft is not None
    # the F/T stream starts before the optical one, so it holds from scene 0 on: its clock
    # reads 0.05 s then (ft_offset) and ticks at 1 kHz, the same ticks in both recordings
    for rec in (a, b):
        assert rec.ft is not None
        t = rec.ft["sensor_time"]
        assert 0.05 < t[0] < 0.1, "the F/T's first sample follows the scene's start"
        np.testing.assert_allclose(t * 1000, np.round(t * 1000), atol=1e-6)
    common, ia, ib = np.intersect1d(a.ft["sensor_time"], b.ft["sensor_time"], return_indices=True)
    assert common[-1] > 2.0, "both hold the F/T over the whole recording"
    np.testing.assert_array_equal(a.ft["wrench"][ia], b.ft["wrench"][ib])


def _late_thread(server: Any) -> None:
    """BotaServer._run as a thread the scheduler wakes only every 0.25 s (a busy machine):
    each wake handles the commands that came, then emits what is due."""
    while not server._stop.is_set():
        time.sleep(0.25)
        readable, _, _ = select.select([server._fd], [], [], 0)
        if readable:
            server._commands()
        if server.running:
            server._emit()


def test_a_late_simulated_ft_thread_changes_nothing(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Issue 22 (b): the demo's table moved with host timing. A simulated F/T's stream began
    when its thread handled 'R', which could come after the optical START had started the
    scene clock (the F/T then began seconds of scene late), and it ended when its thread
    handled 'C', dropping what had come due but was not yet sent. Now the driver waits for
    'R's acknowledgement before the optical stream starts, and the sensor sends what is due
    before it obeys 'C': a recording made beside a starved F/T thread is the same, from its
    first window to its last."""
    from spectratac.sim import ft_bota

    url = "sim://?scene=tour&seed=1&speed=10&ft=bota&ft_rate=500"
    (quick,) = build_datasets([_record(url, tmp_path / "quick.mcap", 3.0).path])
    monkeypatch.setattr(ft_bota.BotaServer, "_run", _late_thread)
    (late,) = build_datasets([_record(url, tmp_path / "late.mcap", 3.0).path])
    assert quick.n == late.n == 60
    assert quick.target_valid[1:].all(), "the F/T covers every window after the first"
    for name in ("targets", "target_valid", "ft_count", "inputs", "region"):
        np.testing.assert_array_equal(quick.arrays[name], late.arrays[name], err_msg=name)


def test_the_same_recording_at_any_pace(tmp_path: Path) -> None:
    """The demo records at a higher speed than before: the dataset of a scene with its
    simulated F/T is the same at 15x and at 60x (the speed paces the host, not the scene)."""
    datasets = []
    for speed in (15, 60):
        url = f"sim://?scene=calibration&duration=20&seed=0&speed={speed}&ft=bota&ft_rate=500"
        (ds,) = build_datasets([_record(url, tmp_path / f"{speed}.mcap", 20.0).path])
        datasets.append(ds)
    a, b = datasets
    assert a.n == b.n == 400
    for name in sorted(set(a.arrays) - {"t_start", "t_end"}):
        np.testing.assert_array_equal(a.arrays[name], b.arrays[name], err_msg=name)


def test_a_late_recorder_reports_the_sensor_time_its_file_holds(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A recorder whose loop runs late (a loaded host: it looks at the duration only every
    0.5 s) receives seconds of samples past the duration before the device obeys STOP. The
    file ends at the duration; the summary's sensor_s says so (it said 11 s for 3 s)."""
    from spectratac.record.recorder import Recorder

    monkeypatch.setattr(Recorder, "_next_wait", lambda self: 0.5)
    url = "sim://?scene=tour&seed=1&speed=10"
    summary = record_url(url, tmp_path / "s.mcap", RecordOptions(duration_s=1.0))
    rec = read_recording(tmp_path / "s.mcap")
    span = _samples(rec)["t_end_us"].max() / 1e6
    assert summary.sensor_s <= span + 0.05 and 1.0 <= summary.sensor_s < 1.1, summary.sensor_s


@pytest.mark.parametrize("speed", ["10", "max"])
def test_a_sample_count_is_cut_on_the_device_too(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, speed: str
) -> None:
    """`samples=N` holds exactly N samples, the same in every recording: the recorder looks at
    its count between polls, so a late loop (a loaded host; here it looks every 0.3 s) kept
    whatever had arrived by then (the tests' tour fixture held 503 to 505 of its 500)."""
    from spectratac.record.recorder import Recorder

    url = f"sim://?scene=tour&seed=1&speed={speed}&ft=bota"
    paths = [tmp_path / "quick.mcap", tmp_path / "late.mcap"]
    quick = record_url(url, paths[0], RecordOptions(samples=40))
    monkeypatch.setattr(Recorder, "_next_wait", lambda self: 0.3)
    late = record_url(url, paths[1], RecordOptions(samples=40))
    a, b = (_samples(read_recording(p)) for p in paths)
    assert len(a) == len(b) == quick.samples == late.samples == 40, (len(a), len(b))
    for name in ("t_start_us", "t_end_us", "sequence", "counts"):
        np.testing.assert_array_equal(a[name], b[name], err_msg=name)
    assert late.sensor_s == pytest.approx((a["t_end_us"][-1] - a["t_start_us"][0]) / 1e6)
    (xa,), (xb,) = (build_datasets([p]) for p in paths)
    for name in sorted(set(xa.arrays) - {"t_start", "t_end"}):
        np.testing.assert_array_equal(xa.arrays[name], xb.arrays[name], err_msg=name)
