"""A simulated recording is a function of its URL and options: the scene clock starts with the
first stream, windows fall on the scene's grid from t=0, the duration ends on the device clock,
and a simulated F/T's samples fall on its own grid in scene time. Two recordings of one scene
hold the same device times, counts, ground truth and F/T values; only host times differ."""

from __future__ import annotations

from pathlib import Path

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
