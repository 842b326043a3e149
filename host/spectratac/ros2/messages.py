"""CDR payloads of the exported messages, a whole topic at a time.

Each topic's messages share everything but their numbers (one frame_id, one array layout),
so the payloads are NumPy records over one fixed layout, taken from a template that the
`rosbags` typestore serialises: tens of times faster than serialising message by message,
and byte-identical to it (tests/ros2/test_messages.py checks with hypothesis).

>>> payloads = wrench_stamped(np.array([5_000_000_001]), np.ones((1, 6)), "spectratac_board")
>>> message = TYPESTORE.deserialize_cdr(payloads[0], WRENCH_STAMPED)
>>> message.header.stamp.sec, message.header.stamp.nanosec, message.wrench.torque.z
(5, 1, 1.0)
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from spectratac.ft.ros_time import split_ns

#: ROS 2 Humble's message definitions (WrenchStamped and the std_msgs arrays are the same
#: in every ROS 2 release).
TYPESTORE = get_typestore(Stores.ROS2_HUMBLE)
WRENCH_STAMPED = "geometry_msgs/msg/WrenchStamped"
UINT16_ARRAY = "std_msgs/msg/UInt16MultiArray"
#: One optical sample's counts with its stamp: a UInt16MultiArray's fields behind a Header.
#: ROS has no stamped array; the definition travels in the bag (rosbag2 message_definitions
#: and its MCAP schema), so readers decode it without a package installed.
COUNTS_STAMPED = "spectratac_msgs/msg/CountsStamped"
COUNTS_STAMPED_MSG = """\
std_msgs/Header header
std_msgs/MultiArrayLayout layout
uint16[] data
"""
TYPESTORE.register(get_types_from_msg(COUNTS_STAMPED_MSG, COUNTS_STAMPED))
_T = TYPESTORE.types


def _wrench_template(frame_id: str) -> bytes:
    v = _T["geometry_msgs/msg/Vector3"]
    msg = _T[WRENCH_STAMPED](
        header=_T["std_msgs/msg/Header"](
            stamp=_T["builtin_interfaces/msg/Time"](sec=0, nanosec=0), frame_id=frame_id
        ),
        wrench=_T["geometry_msgs/msg/Wrench"](
            force=v(x=0.0, y=0.0, z=0.0), torque=v(x=0.0, y=0.0, z=0.0)
        ),
    )
    return bytes(TYPESTORE.serialize_cdr(msg, WRENCH_STAMPED))


def wrench_stamped(stamp_ns: NDArray[Any], wrench: NDArray[Any], frame_id: str) -> list[bytes]:
    """WrenchStamped payloads: stamps (int64 ns), wrench (N, 6) Fx Fy Fz Tx Ty Tz."""
    template = _wrench_template(frame_id)
    head = len(template) - 48  # the six float64 end the message, 8-aligned
    dtype = np.dtype([("head", f"V{head}"), ("wrench", "<f8", (6,))])
    rows = np.zeros(len(stamp_ns), dtype=dtype)
    rows["head"] = np.frombuffer(template[:head], dtype=f"V{head}")[0]
    sec, nanosec = split_ns(stamp_ns)
    stamps = np.empty((len(stamp_ns), 2), dtype="<u4")
    stamps[:, 0] = sec.astype("<i4").view("<u4")
    stamps[:, 1] = nanosec
    raw = rows.view(np.uint8).reshape(len(rows), dtype.itemsize)
    raw[:, 4:12] = stamps.view(np.uint8).reshape(len(rows), 8)  # after the CDR header
    rows["wrench"] = wrench
    blob = rows.tobytes()
    size = dtype.itemsize
    return [blob[i * size : (i + 1) * size] for i in range(len(rows))]


def _array_template(labels: tuple[str, ...], shape: tuple[int, ...]) -> bytes:
    dim = _T["std_msgs/msg/MultiArrayDimension"]
    strides = [int(np.prod(shape[k:])) for k in range(len(shape))]
    layout = _T["std_msgs/msg/MultiArrayLayout"](
        dim=[
            dim(label=lb, size=n, stride=s) for lb, n, s in zip(labels, shape, strides, strict=True)
        ],
        data_offset=0,
    )
    msg = _T[UINT16_ARRAY](layout=layout, data=np.zeros(int(np.prod(shape)), np.uint16))
    return bytes(TYPESTORE.serialize_cdr(msg, UINT16_ARRAY))


def uint16_arrays(values: NDArray[Any], labels: tuple[str, ...]) -> list[bytes]:
    """UInt16MultiArray payloads, one per row of `values` (N, *shape), the layout naming each
    dimension by `labels` (row-major strides, data_offset 0)."""
    shape = tuple(int(n) for n in values.shape[1:])
    template = _array_template(labels, shape)
    n_data = int(np.prod(shape)) * 2
    head = template[: len(template) - n_data]
    flat = np.ascontiguousarray(values, dtype="<u2").reshape(len(values), -1)
    return [head + row.tobytes() for row in flat]


def counts_stamped(
    stamp_ns: NDArray[Any], values: NDArray[Any], labels: tuple[str, ...], frame_id: str
) -> list[bytes]:
    """CountsStamped payloads: one per row of `values` (N, *shape), stamped `stamp_ns`
    (int64 ns), the layout as uint16_arrays'."""
    shape = tuple(int(n) for n in values.shape[1:])
    dim = _T["std_msgs/msg/MultiArrayDimension"]
    strides = [int(np.prod(shape[k:])) for k in range(len(shape))]
    msg = _T[COUNTS_STAMPED](
        header=_T["std_msgs/msg/Header"](
            stamp=_T["builtin_interfaces/msg/Time"](sec=0, nanosec=0), frame_id=frame_id
        ),
        layout=_T["std_msgs/msg/MultiArrayLayout"](
            dim=[
                dim(label=lb, size=n, stride=k)
                for lb, n, k in zip(labels, shape, strides, strict=True)
            ],
            data_offset=0,
        ),
        data=np.zeros(int(np.prod(shape)), np.uint16),
    )
    template = bytes(TYPESTORE.serialize_cdr(msg, COUNTS_STAMPED))
    head = template[: len(template) - int(np.prod(shape)) * 2]
    sec, nanosec = split_ns(np.asarray(stamp_ns, np.int64))
    flat = np.ascontiguousarray(values, dtype="<u2").reshape(len(values), -1)
    out = []
    for s, ns, row in zip(sec.tolist(), nanosec.tolist(), flat, strict=True):
        stamp = int(s).to_bytes(4, "little", signed=True) + int(ns).to_bytes(4, "little")
        out.append(head[:4] + stamp + head[12:] + row.tobytes())
    return out
