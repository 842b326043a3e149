"""A third party's bag as the reference F/T, through `record` and the dataset builder: the
F/T's header stamps are fitted to the bag's receive times with the builder's clock fit, and
each optical window gets the wrench of the moments it really covered."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
from spectratac.dataset.build import build_datasets
from spectratac.fusion import window_average
from spectratac.record import RecordOptions, record_url
from spectratac.record.reader import read_recording

from tests.ros2.bags import write_wrench_bag

RATE_HZ = 200
LATENCY_NS = 500_000  # the shortest path from the F/T driver to the bag recorder
DRIFT = 100e-6  # the F/T's clock runs 100 ppm fast and started 1000 s before the epoch


def fz(t_wall_s: np.ndarray, t0_s: float) -> np.ndarray:
    return 2.0 + np.sin(2 * np.pi * (t_wall_s - t0_s) / 1.0)


def test_a_ros_bag_reference_lines_up_with_the_optical_windows(tmp_path: Path) -> None:
    # a bag as `ros2 bag record` on this machine writes it while the optical sensor records:
    # receive times on the wall clock, header stamps on the F/T's own clock
    t0 = time.time_ns()
    true_ns = t0 - 10**9 + np.arange(60 * RATE_HZ, dtype=np.int64) * (10**9 // RATE_HZ)
    rng = np.random.default_rng(0)
    jitter = rng.lognormal(np.log(1e6), 1.0, true_ns.size).astype(np.int64)
    received = true_ns + LATENCY_NS + jitter
    stamps = (1000 * 10**9 + (true_ns - t0) * (1 + DRIFT)).astype(np.int64)
    wrench = np.zeros((true_ns.size, 6))
    wrench[:, 2] = fz(true_ns / 1e9, t0 / 1e9)
    bag = write_wrench_bag(tmp_path / "ft_bag", received, stamps, wrench)

    path = tmp_path / "s.mcap"
    record_url(
        "sim://?scene=idle&speed=1",
        path,
        RecordOptions(samples=40),
        ft_url=f"rosbag://{bag}?topic=/ft_sensor/wrench",
    )
    rec = read_recording(path)
    assert rec.ft is not None and len(rec.ft) == true_ns.size  # every message replayed
    # in the F/T clock's order, though jitter made the recorder receive some out of order
    assert (np.diff(received) < 0).any()
    np.testing.assert_allclose(rec.ft["sensor_time"], np.sort(stamps) / 1e9, rtol=0, atol=1e-6)
    [ds] = build_datasets([path])
    assert ds.target_valid.mean() > 0.9

    # the truth: each window's average over the F/T samples truly inside it
    true_host = (true_ns - rec.clock.unix_minus_monotonic_ns) / 1e9

    def error(shift_s: float) -> float:
        want, ok, _ = window_average(true_host + shift_s, wrench, ds.t_start, ds.t_end)
        rows = ok & ds.target_valid
        return float(np.mean(np.abs(ds.targets[rows, 2] - want[rows, 2])))

    aligned, off_by_20ms = error(0.0), error(0.020)
    assert aligned < 0.01, f"targets differ from the true window averages by {aligned:.4f} N"
    assert aligned < 0.2 * off_by_20ms, (aligned, off_by_20ms)
