"""Bags that lie are read bounded (issue 36): a damaged payload is a typed error, values no
F/T sensor measures are counted and dropped, one wild header stamp costs that message only,
and a bag with nothing usable says so. Each failed before: SerdeError with a traceback,
1e300 passed as a target, one stamp moved by +1 h took the session's targets to 0 %."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from spectratac.ft.errors import FTBagError
from spectratac.ft.rosbag import load_wrenches
from spectratac.ros2.messages import TYPESTORE, WRENCH_STAMPED

from tests.ros2.bags import write_wrench_bag

N = 2000


def bag(tmp_path: Path, wrench: np.ndarray, stamps: np.ndarray | None = None) -> Path:
    received = time.time_ns() + np.arange(len(wrench), dtype=np.int64) * 1_000_000
    stamps = received - 500_000 if stamps is None else stamps
    return write_wrench_bag(tmp_path / "b", received, stamps, wrench)


def test_values_no_sensor_measures_are_counted_and_dropped(tmp_path: Path) -> None:
    w = np.ones((N, 6))
    w[10, 2] = 1e300
    w[11, 4] = -1e300
    w[12, 0] = np.nan
    w[13, 5] = np.inf
    dropped: dict[str, int] = {}
    rows, *_ = load_wrenches(bag(tmp_path, w), None, dropped=dropped)
    assert len(rows) == N - 4 and np.abs(rows["wrench"]).max() == 1.0
    assert dropped == {"not_finite": 2, "beyond_range": 2, "stamp_jumps": 0}


def test_one_stamp_an_hour_off_costs_that_message_only(tmp_path: Path) -> None:
    received = time.time_ns() + np.arange(N, dtype=np.int64) * 1_000_000
    stamps = received - 500_000
    stamps[N // 2] += 3600 * 10**9
    dropped: dict[str, int] = {}
    path = write_wrench_bag(tmp_path / "b", received, stamps, np.ones((N, 6)))
    rows, *_ = load_wrenches(path, None, dropped=dropped)
    assert len(rows) == N - 1 and dropped["stamp_jumps"] == 1
    assert np.ptp(rows["sensor_time"]) < N * 1e-3


@settings(max_examples=20, deadline=None)
@given(st.integers(0, N - 1), st.integers(2, 10**6))
def test_a_drifting_clock_keeps_every_stamp_and_a_jump_is_found(at: int, jump_ms: int) -> None:
    import tempfile

    received = 10**18 + np.arange(N, dtype=np.int64) * 1_000_000
    stamps = 5 * 10**9 + (np.arange(N) * 1_000_000 * (1 + 1e-4)).astype(np.int64)  # 100 ppm
    stamps[at] += jump_ms * 1_000_000
    with tempfile.TemporaryDirectory() as d:
        dropped: dict[str, int] = {}
        path = write_wrench_bag(Path(d) / "b", received, stamps, np.ones((N, 6)))
        rows, *_ = load_wrenches(path, None, dropped=dropped)
    assert dropped["stamp_jumps"] == (1 if jump_ms > 1000 else 0)
    assert len(rows) == N - dropped["stamp_jumps"]


def test_an_all_nan_bag_is_an_error(tmp_path: Path) -> None:
    with pytest.raises(FTBagError, match="none of the 2000 wrenches"):
        load_wrenches(bag(tmp_path, np.full((N, 6), np.nan)), None)


def test_a_damaged_payload_is_a_typed_error(tmp_path: Path) -> None:
    from rosbags.rosbag2 import Writer

    good = bytes(TYPESTORE.serialize_cdr(
        TYPESTORE.types[WRENCH_STAMPED](
            header=TYPESTORE.types["std_msgs/msg/Header"](
                stamp=TYPESTORE.types["builtin_interfaces/msg/Time"](sec=1, nanosec=0),
                frame_id="x" * 8),
            wrench=TYPESTORE.types["geometry_msgs/msg/Wrench"](
                force=TYPESTORE.types["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.0),
                torque=TYPESTORE.types["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.0))),
        WRENCH_STAMPED))  # fmt: skip
    path = tmp_path / "b"
    with Writer(path, version=8) as writer:
        conn = writer.add_connection("/w", WRENCH_STAMPED, typestore=TYPESTORE)
        writer.write(conn, 1, good)
        writer.write(conn, 2, good[:20])  # cut short: the CDR decoder runs out of bytes
    with pytest.raises(FTBagError, match="cannot read ROS 2 bag"):
        load_wrenches(path, "/w")
