"""ROS 2 stamps: (sec, nanosec) from nanoseconds and back, exactly, nanosec never negative."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from spectratac.ft.ros_time import (
    NS_PER_S,
    SEC_MAX,
    SEC_MIN,
    StampRangeError,
    from_stamp,
    seconds_to_ns,
    split_ns,
    to_stamp,
)

STAMPABLE = st.integers(SEC_MIN * NS_PER_S, SEC_MAX * NS_PER_S + NS_PER_S - 1)


@given(STAMPABLE)
def test_a_stamp_round_trips_and_its_nanosec_is_never_negative(ns: int) -> None:
    sec, nanosec = to_stamp(ns)
    assert 0 <= nanosec < NS_PER_S
    assert SEC_MIN <= sec <= SEC_MAX
    assert from_stamp(sec, nanosec) == ns


@given(st.lists(STAMPABLE, max_size=50))
def test_the_array_split_agrees_with_the_scalar_one(values: list[int]) -> None:
    sec, nanosec = split_ns(np.array(values, dtype=np.int64))
    assert [(int(s), int(n)) for s, n in zip(sec, nanosec, strict=True)] == [
        to_stamp(v) for v in values
    ]
    assert (nanosec >= 0).all()


@given(st.floats(-1e6, 1e6, allow_nan=False), st.integers(0, 2**62))
def test_seconds_become_nanoseconds_to_the_nearest_one(seconds: float, offset: int) -> None:
    ns = int(seconds_to_ns(np.array([seconds]), offset)[0])
    assert abs((ns - offset) - seconds * 1e9) <= 0.5 + abs(seconds) * 1e9 * 2**-52


def test_times_a_stamp_cannot_hold_are_refused() -> None:
    with pytest.raises(StampRangeError, match="int32"):
        to_stamp((SEC_MAX + 1) * NS_PER_S)
    with pytest.raises(StampRangeError, match="int32"):
        split_ns(np.array([0, SEC_MIN * NS_PER_S - 1]))
    with pytest.raises(StampRangeError, match="nanosec"):
        from_stamp(1, NS_PER_S)
