"""rosbag://: a third party's ROS 2 bag (written with rosbags' own Writer) as the reference
F/T, and every way a bag can be wrong answered by a typed error that says what to do."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pytest
from rosbags.rosbag2 import StoragePlugin
from spectratac import host_clock
from spectratac.ft import FTSensor, ft_schemes
from spectratac.ft.errors import FTBagError, FTNotFoundError, FTURLError
from spectratac.ft.rosbag import RosbagFTSensor

from tests.ros2.bags import write_wrench_bag

T0 = 1_795_000_000_000_000_000  # a 2026 wall-clock time, ns


def wrenches(n: int) -> np.ndarray:
    return np.arange(n * 6, dtype=np.float64).reshape(n, 6) / 7.0


@pytest.fixture
def stamped(tmp_path: Path) -> Path:
    n = 50
    recv = T0 + np.arange(n) * 2_000_000 + 300_000  # 2 ms apart, 0.3 ms after the stamp
    stamps = T0 + np.arange(n) * 2_000_000 - 999_999_999  # nanosec wraps below the second
    return write_wrench_bag(tmp_path / "bag", recv, stamps, wrenches(n))


def read_all(url: str) -> tuple[np.ndarray, FTSensor]:
    ft = FTSensor.open(url, timeout=2.0)
    with ft:
        rows = ft.read(10_000, timeout=2.0)
    return rows, ft


def test_rosbag_is_a_built_in_scheme() -> None:
    assert "rosbag" in ft_schemes()


@pytest.mark.parametrize("storage", [StoragePlugin.SQLITE3, StoragePlugin.MCAP])
def test_every_wrench_of_the_topic_is_replayed_with_its_header_stamp(
    tmp_path: Path, storage: StoragePlugin
) -> None:
    n = 40
    recv = T0 + np.arange(n) * 1_000_000 + 250_000
    stamps = T0 - 5 * 10**9 + np.arange(n) * 1_000_000  # the sensor's clock: 5 s behind
    bag = write_wrench_bag(tmp_path / "bag", recv, stamps, wrenches(n), storage=storage)
    rows, ft = read_all(f"rosbag://{bag}?topic=/ft_sensor/wrench")
    assert len(rows) == n and ft.info.kind == "rosbag"
    np.testing.assert_array_equal(rows["wrench"], wrenches(n))
    np.testing.assert_allclose(
        rows["sensor_time"] - (T0 - 5 * 10**9) / 1e9, np.arange(n) / 1e3, atol=1e-6
    )
    # receive times on this host's monotonic clock, through the offset the reader read...
    offset = ft.info.extra["unix_minus_monotonic_ns"]
    host = rows["host_time"] + offset / 1e9
    np.testing.assert_allclose(host - T0 / 1e9, np.arange(n) / 1e3 + 250e-6, atol=1e-6)
    # ...which is this host's (read in brackets: a preempted read was 50 µs off under load)
    assert abs(offset - host_clock.unix_minus_monotonic_ns()) < 1_000_000
    assert ft.info.extra["topic"] == "/ft_sensor/wrench" and ft.info.rate_hz == pytest.approx(1000)


def test_the_only_wrench_topic_is_found_without_naming_it(stamped: Path) -> None:
    rows, _ = read_all(f"rosbag://{stamped}")
    assert len(rows) == 50
    assert rows["sensor_time"][0] == pytest.approx((T0 - 999_999_999) / 1e9, abs=1e-6)


def test_a_bare_wrench_takes_the_bags_receive_time(tmp_path: Path) -> None:
    recv = T0 + np.arange(5) * 10_000_000
    bag = write_wrench_bag(tmp_path / "bag", recv, None, wrenches(5), topic="/wrench")
    rows, ft = read_all(f"rosbag://{bag}?topic=/wrench&host_time=now")
    np.testing.assert_allclose(rows["sensor_time"], recv / 1e9, atol=1e-6)
    assert ft.info.model == "ROS 2 bag geometry_msgs/msg/Wrench"
    assert abs(rows["host_time"][0] - time.monotonic()) < 60  # stamped on arrival


def test_a_missing_topic_lists_the_topics_there_are(stamped: Path) -> None:
    with pytest.raises(FTBagError) as err:
        FTSensor.open(f"rosbag://{stamped}?topic=/ft/wrench")
    assert "no topic '/ft/wrench'" in str(err.value)
    assert "/ft_sensor/wrench (geometry_msgs/msg/WrenchStamped)" in str(err.value)
    assert "/joint_states/effort (std_msgs/msg/Float64)" in str(err.value)


def test_a_topic_of_another_type_is_refused_by_name(stamped: Path) -> None:
    with pytest.raises(FTBagError, match=r"/joint_states/effort is std_msgs/msg/Float64, not"):
        FTSensor.open(f"rosbag://{stamped}?topic=/joint_states/effort")


def test_an_empty_topic_and_a_bag_without_topics_are_refused(tmp_path: Path) -> None:
    nothing = np.zeros(0, np.int64)
    empty = write_wrench_bag(tmp_path / "empty", nothing, nothing, np.zeros((0, 6)))
    with pytest.raises(FTBagError, match="has no messages"):
        FTSensor.open(f"rosbag://{empty}?topic=/ft_sensor/wrench")
    from rosbags.rosbag2 import Writer

    with Writer(tmp_path / "none", version=8):
        pass
    with pytest.raises(FTBagError, match="holds no topics"):
        FTSensor.open(f"rosbag://{tmp_path / 'none'}")


def test_a_missing_path_says_what_a_bag_is(tmp_path: Path) -> None:
    with pytest.raises(
        FTNotFoundError, match=r"no such ROS 2 bag: .*nowhere \(give the bag's folder"
    ):
        FTSensor.open(f"rosbag://{tmp_path / 'nowhere'}")


def test_bad_options_are_refused() -> None:
    with pytest.raises(FTURLError, match="no bag"):
        FTSensor.open("rosbag://?topic=/x")
    with pytest.raises(FTURLError, match="unknown parameter"):
        RosbagFTSensor.connect("rosbag://b?colour=red", timeout=1, buffer_size=10)
    with pytest.raises(FTURLError, match=r"host_time=file must be one of bag\|now"):
        RosbagFTSensor.connect("rosbag://b?host_time=file", timeout=1, buffer_size=10)


@pytest.mark.parametrize("storage", [StoragePlugin.SQLITE3, StoragePlugin.MCAP])
@pytest.mark.parametrize("damage", ["truncate", "garble"])
def test_a_damaged_storage_file_is_a_typed_error(
    tmp_path: Path, storage: StoragePlugin, damage: str
) -> None:
    n = 400
    recv = T0 + np.arange(n) * 1_000_000
    bag = write_wrench_bag(tmp_path / "bag", recv, recv, wrenches(n), storage=storage)
    [data_file] = [p for p in bag.iterdir() if p.suffix in (".db3", ".mcap")]
    raw = bytearray(data_file.read_bytes())
    if damage == "truncate":
        raw = raw[: len(raw) // 2]
    else:  # overwrite the middle with noise, as a bad sector would
        mid = len(raw) // 2
        raw[mid - 2000 : mid + 2000] = np.random.default_rng(0).bytes(4000)
    data_file.write_bytes(bytes(raw))
    try:
        rows, _ = read_all(f"rosbag://{bag}")
    except FTBagError as exc:  # refused: says which file and what to try
        assert str(bag) in str(exc) and "reindex" in str(exc)
    else:  # or read what survived: never a wrong value
        assert 0 < len(rows) <= n
        index = np.round((rows["sensor_time"] - T0 / 1e9) * 1e3).astype(int)  # 1 ms apart
        good = wrenches(n)[index]
        np.testing.assert_array_equal(rows["wrench"], good)


def test_a_file_that_is_no_bag_is_a_typed_error(tmp_path: Path) -> None:
    fake = tmp_path / "notes.db3"
    fake.write_bytes(b"this is not sqlite" * 100)
    with pytest.raises(FTBagError, match="cannot read ROS 2 bag"):
        FTSensor.open(f"rosbag://{fake}")
    folder = tmp_path / "folder"
    folder.mkdir()
    with pytest.raises(FTBagError, match="cannot read ROS 2 bag"):
        FTSensor.open(f"rosbag://{folder}")
