"""A third party's bag as the reference F/T, through the dataset builder: the F/T's header
stamps are fitted to the bag's receive times with the builder's clock fit, and each optical
window gets the wrench of the moments it really covered. Two ways in: `record --ft
rosbag://…` and `dataset build --ft rosbag://…` (the bag recorded beside the sensor)."""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
from spectratac.cli import main
from spectratac.dataset import Dataset
from spectratac.dataset.align import ft_host_times
from spectratac.dataset.build import build_datasets
from spectratac.dataset.external_ft import load_external_ft
from spectratac.dataset.schema import DatasetError
from spectratac.fusion import window_average
from spectratac.record import RecordOptions, record_url
from spectratac.record.reader import read_recording

from tests.ros2.bags import write_wrench_bag

RATE_HZ = 200
LATENCY_NS = 500_000  # the shortest path from the F/T driver to the bag recorder
DRIFT = 100e-6  # the F/T's clock runs 100 ppm fast and started 1000 s before t0


@dataclass
class FTBag:
    path: Path
    true_ns: np.ndarray  # when each wrench really acted (wall clock)
    stamps_ns: np.ndarray
    received_ns: np.ndarray
    wrench: np.ndarray


def ft_bag(folder: Path, t0_ns: int, seconds: float) -> FTBag:
    """A bag as `ros2 bag record` on this machine writes it: receive times on the wall clock
    (latency 0.5 ms + heavy-tailed jitter, so some arrive out of order), header stamps on the
    F/T's own clock; Fz a 1 Hz sine around 2 N."""
    true_ns = t0_ns + np.arange(int(seconds * RATE_HZ), dtype=np.int64) * (10**9 // RATE_HZ)
    jitter = np.random.default_rng(0).lognormal(np.log(1e6), 1.0, true_ns.size).astype(np.int64)
    received = true_ns + LATENCY_NS + jitter
    stamps = (1000 * 10**9 + (true_ns - t0_ns) * (1 + DRIFT)).astype(np.int64)
    wrench = np.zeros((true_ns.size, 6))
    wrench[:, 2] = 2.0 + np.sin(2 * np.pi * (true_ns - t0_ns) / 1e9)
    path = write_wrench_bag(folder / "ft_bag", received, stamps, wrench)
    return FTBag(path, true_ns, stamps, received, wrench)


def alignment_lag(ds: Dataset, rec_path: Path, bag: FTBag) -> tuple[float, float]:
    """How far (s) the builder put the bag's samples from where they truly were, found as the
    shift of the truth that best explains the targets, and the mean |Fz error| (N) there."""
    true_host = (bag.true_ns - read_recording(rec_path).clock.unix_minus_monotonic_ns) / 1e9

    def error(shift_s: float) -> float:
        want, ok, _ = window_average(true_host + shift_s, bag.wrench, ds.t_start, ds.t_end)
        rows = ok & ds.target_valid
        return float(np.mean(np.abs(ds.targets[rows, 2] - want[rows, 2])))

    shifts = np.arange(-20e-3, 20.1e-3, 0.25e-3)
    errors = [error(float(s)) for s in shifts]
    # the error is flat while no sample crosses a window edge: take the best plateau's middle
    best = np.flatnonzero(np.asarray(errors) <= min(errors) + 1e-9)
    return float(np.median(shifts[best])), min(errors)


def assert_aligned(ds: Dataset, rec_path: Path, bag: FTBag, ft_rows: np.ndarray) -> None:
    # the F/T side, exactly: the builder's fit of header stamps to receive times places each
    # sample at most the recorder's shortest latency (0.5 ms) plus jitter's floor late
    rec = read_recording(rec_path)
    true_host = (bag.true_ns - rec.clock.unix_minus_monotonic_ns) / 1e9
    placed, _ = ft_host_times(ft_rows, 1.0)
    late = placed - np.sort(true_host)
    assert late.min() >= 0.0 and late.max() <= 1.5e-3, (late.min(), late.max())
    # the windows: targets are the true averages, up to the optical clock fit's own error
    assert ds.target_valid.mean() > 0.9
    lag, residual = alignment_lag(ds, rec_path, bag)
    # The optical windows sit on the host clock as well as its TIME_SYNC exchanges allow: within
    # 0.75x the shortest round trip (sub-ms on a quiet host, over 10 ms beside busy loops), and
    # the sine's mean slope (4 N/s) turns that into N; a fixed 1 mN judged the scheduler.
    rtt = min(
        (e["host_received"] - e["host_sent"]) - (e["device_tx_us"] - e["device_rx_us"]) / 1e6
        for e in rec.time_sync
    )
    bound = 1e-3 + 4.0 * 0.75 * rtt
    assert residual < bound, (
        f"targets differ from the truth by {residual:.4f} N at best, more than the optical "
        f"clock's exchanges explain ({bound:.4f} N: shortest round trip {rtt * 1e3:.2f} ms)"
    )
    assert abs(lag) <= 10e-3, f"targets fit the truth {lag * 1e3:.2f} ms off at best"


def test_record_with_a_bag_as_the_reference(tmp_path: Path) -> None:
    bag = ft_bag(tmp_path, time.time_ns() - 10**9, 60.0)  # covers the recording to come
    path = tmp_path / "s.mcap"
    url = f"rosbag://{bag.path}?topic=/ft_sensor/wrench"
    record_url("sim://?scene=idle&speed=1", path, RecordOptions(samples=40), ft_url=url)
    rec = read_recording(path)
    assert rec.ft is not None and len(rec.ft) == bag.true_ns.size  # every message replayed
    # in the F/T clock's order, though jitter made the recorder receive some out of order
    assert (np.diff(bag.received_ns) < 0).any()
    np.testing.assert_allclose(rec.ft["sensor_time"], bag.stamps_ns / 1e9, rtol=0, atol=1e-6)
    [ds] = build_datasets([path])
    assert_aligned(ds, path, bag, rec.ft)


def test_dataset_build_takes_a_bag_recorded_beside_the_sensor(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "s.mcap"
    started = time.time_ns()
    record_url("sim://?scene=idle&speed=1", path, RecordOptions(samples=40))
    assert read_recording(path).ft is None  # the optical sensor alone
    bag = ft_bag(tmp_path, started - 2 * 10**9, (time.time_ns() - started) / 1e9 + 4)
    out = tmp_path / "d.npz"
    url = f"rosbag://{bag.path}?topic=/ft_sensor/wrench"
    assert main(["dataset", "build", str(path), "--ft", url, "-o", str(out), "--json"]) == 0
    capsys.readouterr()
    ds = Dataset.load(out)
    assert ds.meta["sessions"][0]["ft_url"] == url
    rows = load_external_ft(url).on_clock(read_recording(path).clock.unix_minus_monotonic_ns)
    assert_aligned(ds, path, bag, rows)


def test_dataset_build_refuses_a_replay_stamped_as_it_is_read(tmp_path: Path) -> None:
    bag = ft_bag(tmp_path, time.time_ns(), 1.0)
    with pytest.raises(DatasetError, match="stamp rows with the time they are read"):
        load_external_ft(f"rosbag://{bag.path}?host_time=now")
