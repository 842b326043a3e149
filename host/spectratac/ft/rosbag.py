"""Replay a ROS 2 bag's wrench topic as the reference F/T, without ROS installed:
rosbag://PATH?topic=/ft_sensor/wrench[&host_time=bag|now][&rate=HZ|realtime=1&speed=S].

PATH is a bag folder (with metadata.yaml) or one storage file (.db3 sqlite3 or .mcap); the
`rosbags` package reads it. The topic carries geometry_msgs/msg/WrenchStamped (sensor_time is
the header stamp: the F/T driver's clock) or geometry_msgs/msg/Wrench (no header: sensor_time
is the bag's receive time), replayed in stamp order. `topic` may be left out when the bag
has exactly one such topic.

host_time is the bag's receive time of each message (what `ros2 bag record` logged: the
recording machine's wall clock), put on this host's monotonic clock through the wall clock
(`host_time=bag`, the default). So a bag recorded on this machine while the optical sensor
was recorded, or on one whose clock is synchronised (NTP, PTP), lines up with the optical
samples, and `spectratac dataset build` fits header stamps to receive times with the same
clock fit (`spectratac.fusion.fit_clock`) as any F/T sensor's own clock to its arrival
times. `host_time=now` stamps each row as it is released instead: with `realtime=1` the bag
plays as a live sensor. Pacing options are csv://'s (`spectratac.ft.replay`).

Errors (FTBagError, FTNotFoundError) name what was wrong: no such path, a file the reader
cannot parse (truncated, damaged, not a bag), no messages on the topic, a topic that does not
exist or has another type (the message lists every topic with its type).
"""

from __future__ import annotations

import sqlite3
import struct
from pathlib import Path
from typing import Any
from urllib.parse import parse_qsl

import numpy as np

from spectratac import host_clock
from spectratac.ft.errors import FTBagError, FTNotFoundError, FTURLError
from spectratac.ft.options import Options
from spectratac.ft.records import FT_RECORD, FTInfo
from spectratac.ft.replay import ReplayFTSensor
from spectratac.ft.ros_time import NS_PER_S, from_stamp

STAMPED = "geometry_msgs/msg/WrenchStamped"
BARE = "geometry_msgs/msg/Wrench"
WRENCH_TYPES = (STAMPED, BARE)
#: What rosbags raises for a file it cannot parse: its own ReaderError, sqlite's errors, and
#: the decoding errors of a damaged MCAP or CDR payload.
_UNREADABLE: tuple[type[BaseException], ...] = (
    sqlite3.Error,
    struct.error,
    ValueError,
    KeyError,
    IndexError,
    EOFError,
    OSError,
    AssertionError,
    ArithmeticError,
)


def bag_path(url: str) -> tuple[Path, str]:
    """The bag path and query of a rosbag:// URL (relative paths allowed)."""
    rest = url[len("rosbag://") :]
    path, _, query = rest.partition("?")
    if not path:
        raise FTURLError(f"{url}: no bag; example: rosbag://my_bag?topic=/ft_sensor/wrench")
    return Path(path), query


def _reader_errors() -> tuple[type[BaseException], ...]:
    from rosbags.rosbag2 import ReaderError

    return (ReaderError, *_UNREADABLE)


def describe_topics(topics: dict[str, str]) -> str:
    """'topic (type), …' for error messages; '(none)' for a bag without topics."""
    return ", ".join(f"{t} ({m})" for t, m in sorted(topics.items())) or "(none)"


def load_wrenches(path: Path, topic: str | None) -> tuple[np.ndarray, str, str, float]:
    """FT_RECORD rows of the bag's wrench topic (host_time: receive time as Unix seconds,
    replaced by the caller), the topic, its message type and its nominal rate (Hz, from the
    median stamp step in whole nanoseconds; 0 when unknown)."""
    from rosbags.rosbag2 import Reader
    from rosbags.typesys import Stores, get_typestore

    if not path.exists():
        raise FTNotFoundError(
            f"no such ROS 2 bag: {path} (give the bag's folder, or its .db3 or .mcap file)"
        )
    try:
        with Reader(path) as reader:
            topics = {t: info.msgtype or "(mixed types)" for t, info in reader.topics.items()}
            topic, msgtype = _pick_topic(path, topics, topic)
            conns = [c for c in reader.connections if c.topic == topic]
            store = get_typestore(Stores.ROS2_HUMBLE)
            stamps: list[int] = []
            received: list[int] = []
            wrenches: list[tuple[float, ...]] = []
            for _, recv_ns, raw in reader.messages(connections=conns):
                msg: Any = store.deserialize_cdr(raw, msgtype)  # typed by msgtype
                if msgtype == STAMPED:
                    stamp = msg.header.stamp
                    stamps.append(from_stamp(stamp.sec, stamp.nanosec))
                    w = msg.wrench
                else:
                    stamps.append(recv_ns)
                    w = msg
                received.append(recv_ns)
                f, t = w.force, w.torque
                wrenches.append((f.x, f.y, f.z, t.x, t.y, t.z))
    except FTBagError:
        raise
    except _reader_errors() as exc:
        raise FTBagError(
            f"cannot read ROS 2 bag {path}: {type(exc).__name__}: {exc}. Is it a complete "
            f"rosbag2 bag (a folder with metadata.yaml, a .db3 or a .mcap)? A bag cut short "
            f"while recording may need `ros2 bag reindex` first"
        ) from None
    if not stamps:
        raise FTBagError(f"{path}: topic {topic} ({msgtype}) has no messages; nothing to replay")
    # a bag is in receive order; the F/T stream is in its own clock's order (a message that
    # overtook another on the way to the recorder goes back to its place)
    stamp_ns = np.array(stamps, dtype=np.int64)
    order = np.argsort(stamp_ns, kind="stable")
    stamp_ns = stamp_ns[order]
    rows = np.zeros(len(stamps), dtype=FT_RECORD)
    rows["sensor_time"] = _seconds(stamp_ns)
    rows["host_time"] = _seconds(np.array(received, dtype=np.int64)[order])
    rows["sequence"] = np.arange(len(rows))
    rows["wrench"] = np.array(wrenches, dtype=np.float64)[order]
    finite = np.all(np.isfinite(rows["wrench"]), axis=1)
    step = float(np.median(np.diff(stamp_ns))) if len(stamp_ns) > 1 else 0.0
    return rows[finite], topic, msgtype, NS_PER_S / step if step > 0 else 0.0


def _seconds(ns: np.ndarray) -> np.ndarray:
    """int64 ns as float seconds, whole and fractional parts apart (no int64->f8 rounding)."""
    whole, frac = np.divmod(ns, NS_PER_S)
    return whole.astype(np.float64) + frac.astype(np.float64) / NS_PER_S


def _pick_topic(path: Path, topics: dict[str, str], topic: str | None) -> tuple[str, str]:
    if not topics:
        raise FTBagError(f"{path}: the bag holds no topics; nothing to replay")
    if topic is None:
        found = [t for t, m in topics.items() if m in WRENCH_TYPES]
        if len(found) != 1:
            raise FTBagError(
                f"{path}: name the wrench topic with ?topic=… ("
                f"{'no' if not found else len(found)} topics of type {STAMPED} or {BARE}); "
                f"the bag has: {describe_topics(topics)}"
            )
        topic = found[0]
    if topic not in topics:
        raise FTBagError(f"{path}: no topic {topic!r}; the bag has: {describe_topics(topics)}")
    if topics[topic] not in WRENCH_TYPES:
        raise FTBagError(
            f"{path}: topic {topic} is {topics[topic]}, not {STAMPED} or {BARE}; the bag "
            f"has: {describe_topics(topics)}"
        )
    return topic, topics[topic]


class RosbagFTSensor(ReplayFTSensor):
    """Replays a ROS 2 bag's wrench topic (see the module documentation)."""

    scheme = "rosbag"

    @classmethod
    def connect(
        cls, url: str, *, timeout: float, buffer_size: int, **options: Any
    ) -> RosbagFTSensor:
        path, query = bag_path(url)
        opts = Options(url, {**dict(parse_qsl(query)), **options})
        topic = opts.text("topic")
        host_mode = opts.text("host_time", "bag")
        rate = opts.number("rate")
        realtime = opts.flag("realtime")
        speed = opts.number("speed", 1.0)
        opts.done()
        if host_mode not in ("bag", "now"):
            raise FTURLError(f"{url}: host_time={host_mode!r}: use bag or now")
        if (rate is not None and rate <= 0) or speed <= 0:
            raise FTURLError(f"{url}: rate and speed must be > 0")
        rows, topic, msgtype, nominal = load_wrenches(path, topic)
        # the bag's wall-clock receive times onto this host's monotonic clock
        unix_minus_monotonic_ns = host_clock.unix_minus_monotonic_ns()
        rows["host_time"] -= unix_minus_monotonic_ns / NS_PER_S
        info = FTInfo("rosbag", model=f"ROS 2 bag {msgtype}", serial=str(path))
        info.rate_hz = rate or nominal
        info.extra.update(rows=len(rows), path=str(path), topic=topic, msgtype=msgtype)
        if host_mode == "bag":  # how to put the rows on another process's clock
            info.extra["unix_minus_monotonic_ns"] = unix_minus_monotonic_ns
        sensor = cls(url, info, timeout=timeout, buffer_size=buffer_size)
        sensor._setup(rows, keep_host=host_mode == "bag", rate=rate, realtime=realtime, speed=speed)
        return sensor
