"""ROS 2 time stamps (builtin_interfaces/msg/Time) to and from integer nanoseconds.

A stamp is (sec: int32, nanosec: uint32 < 10**9). Negative times keep nanosec positive
(floor division): -1 ns is (-1, 999_999_999), as rclcpp's Time does. Conversions are exact
on integers; float seconds (FT_RECORD's times) go through `seconds_to_ns`, which rounds to the
nearest nanosecond.

>>> to_stamp(1_700_000_000_123_456_789)
(1700000000, 123456789)
>>> to_stamp(-1), from_stamp(-1, 999_999_999)
((-1, 999999999), -1)
>>> split_ns(np.array([-1, 0, 1_500_000_000]))
(array([-1,  0,  1]), array([999999999,         0, 500000000]))
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from spectratac.ft.errors import FTConfigError

NS_PER_S = 1_000_000_000
#: builtin_interfaces/msg/Time.sec is an int32: stamps beyond 2038 do not fit.
SEC_MIN, SEC_MAX = -(2**31), 2**31 - 1


class StampRangeError(FTConfigError, ValueError):
    """A time does not fit a ROS 2 stamp (int32 seconds)."""


def to_stamp(ns: int) -> tuple[int, int]:
    """(sec, nanosec) of `ns` nanoseconds; StampRangeError if sec leaves int32."""
    sec, nanosec = divmod(int(ns), NS_PER_S)
    if not SEC_MIN <= sec <= SEC_MAX:
        raise StampRangeError(f"time {ns} ns is outside a ROS 2 stamp's int32 seconds")
    return sec, nanosec


def from_stamp(sec: int, nanosec: int) -> int:
    """Nanoseconds of a stamp; StampRangeError for a nanosec outside 0..999,999,999."""
    if not 0 <= nanosec < NS_PER_S:
        raise StampRangeError(f"stamp nanosec {nanosec} is outside 0..999999999")
    return int(sec) * NS_PER_S + int(nanosec)


def split_ns(ns: ArrayLike) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """`to_stamp` over an array of int64 nanoseconds: (sec, nanosec) arrays."""
    a = np.asarray(ns, dtype=np.int64)
    sec, nanosec = np.divmod(a, NS_PER_S)  # floor semantics: nanosec is never negative
    if a.size and (sec.min() < SEC_MIN or sec.max() > SEC_MAX):
        raise StampRangeError("a time is outside a ROS 2 stamp's int32 seconds")
    return sec, nanosec


def seconds_to_ns(seconds: ArrayLike, offset_ns: int = 0) -> NDArray[np.int64]:
    """Float seconds (e.g. host monotonic time) plus an integer offset, as int64 ns. The
    offset is added after rounding, so a large one (the Unix epoch) costs no precision."""
    s = np.asarray(seconds, dtype=np.float64)
    return np.round(s * NS_PER_S).astype(np.int64) + np.int64(offset_ns)
