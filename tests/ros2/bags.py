"""Bags as a third party writes them: rosbags' own Writer and typestore, message by message,
the way a ROS user's script (or `ros2 bag record`) would. Nothing of spectratac's exporter."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore

STORE = get_typestore(Stores.ROS2_JAZZY)
_T = STORE.types


def wrench_msg(stamp_ns: int | None, w: np.ndarray, frame_id: str = "ft_sensor_link") -> object:
    v = _T["geometry_msgs/msg/Vector3"]
    wrench = _T["geometry_msgs/msg/Wrench"](
        force=v(x=float(w[0]), y=float(w[1]), z=float(w[2])),
        torque=v(x=float(w[3]), y=float(w[4]), z=float(w[5])),
    )
    if stamp_ns is None:
        return wrench
    sec, nanosec = divmod(int(stamp_ns), 1_000_000_000)
    header = _T["std_msgs/msg/Header"](
        stamp=_T["builtin_interfaces/msg/Time"](sec=sec, nanosec=nanosec), frame_id=frame_id
    )
    return _T["geometry_msgs/msg/WrenchStamped"](header=header, wrench=wrench)


def write_wrench_bag(
    path: Path,
    received_ns: np.ndarray,
    stamps_ns: np.ndarray | None,
    wrenches: np.ndarray,
    *,
    topic: str = "/ft_sensor/wrench",
    storage: StoragePlugin = StoragePlugin.SQLITE3,
    extra_topics: bool = True,
) -> Path:
    """A bag with `topic` (WrenchStamped, or Wrench when stamps_ns is None) and, like a real
    robot's bag, other topics beside it."""
    msgtype = "geometry_msgs/msg/Wrench" if stamps_ns is None else "geometry_msgs/msg/WrenchStamped"
    with Writer(path, version=9, storage_plugin=storage) as writer:
        conn = writer.add_connection(topic, msgtype, typestore=STORE)
        if extra_topics and len(received_ns):
            other = writer.add_connection(
                "/joint_states/effort", "std_msgs/msg/Float64", typestore=STORE
            )
            writer.write(
                other,
                int(received_ns[0]),
                STORE.serialize_cdr(_T["std_msgs/msg/Float64"](data=1.0), "std_msgs/msg/Float64"),
            )
        for i, recv in enumerate(received_ns):
            stamp = None if stamps_ns is None else int(stamps_ns[i])
            raw = STORE.serialize_cdr(wrench_msg(stamp, wrenches[i]), msgtype)
            writer.write(conn, int(recv), raw)
    return path
