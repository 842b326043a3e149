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

A bag `spectratac export rosbag` wrote holds its timeline in its metadata (custom_data
"spectratac.timeline", `spectratac.record.timeline`): its stamps are on the sensor's clock
(a simulation at speed=15 spans 15x the host's seconds), so its receive times are mapped back
onto the recording's host clock through it.

What a bag cannot be trusted with is dropped and counted (info.extra, `dropped`): wrenches
that are not finite or beyond `max_force` (N, default 1e4) / `max_torque` (N·m, default 1e3),
which no six-axis F/T sensor measures; header stamps that jump away from the line the others
draw against receive time (a robust fit; more than `max_jump` s, default 1). Errors
(FTBagError, FTNotFoundError) name what was wrong: no such path, a file or payload the reader
cannot parse (truncated, damaged, not a bag), no messages on the topic, none usable, a topic
that does not exist or has another type (the message lists every topic with its type).
"""

from __future__ import annotations

import json
import sqlite3
import struct
from pathlib import Path
from typing import Any
from urllib.parse import parse_qsl

import numpy as np

from spectratac import host_clock
from spectratac.ft.errors import FTBagError, FTNotFoundError, FTURLError
from spectratac.ft.options import RATE, REALTIME, SPEED, Options, Param
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


#: Beyond any six-axis F/T sensor's range (N, N·m): a value past them is a damaged message.
MAX_FORCE_N, MAX_TORQUE_NM = 1e4, 1e3
#: How far (s) a header stamp may sit from the line of the others against receive time.
MAX_JUMP_S = 1.0
#: rosbag:// options (spectratac.ft.options).
URL_PARAMS = {
    "topic": Param("text", meaning="the WrenchStamped topic"),
    "host_time": Param(
        "choice", meaning="host times: the bag's receive times, or now", choices=("bag", "now")
    ),
    "rate": RATE,
    "max_force": Param("number", 1e-3, 1e6, "larger forces are not readings, N"),
    "max_torque": Param("number", 1e-3, 1e5, "larger torques are not readings, N*m"),
    "max_jump": Param("number", 1e-3, 3600.0, "a stamp this far from the receive-time fit, s"),
    "realtime": REALTIME,
    "speed": SPEED,
}
#: The bag metadata key of an exported bag's timeline (spectratac.record.timeline.KEY).
TIMELINE_KEY = "spectratac.timeline"


def _reader_errors() -> tuple[type[BaseException], ...]:
    from rosbags.rosbag2 import ReaderError
    from rosbags.serde import SerdeError

    return (ReaderError, SerdeError, *_UNREADABLE)


def describe_topics(topics: dict[str, str]) -> str:
    """'topic (type), …' for error messages; '(none)' for a bag without topics."""
    return ", ".join(f"{t} ({m})" for t, m in sorted(topics.items())) or "(none)"


def load_wrenches(
    path: Path,
    topic: str | None,
    *,
    max_force: float = MAX_FORCE_N,
    max_torque: float = MAX_TORQUE_NM,
    max_jump: float = MAX_JUMP_S,
    dropped: dict[str, int] | None = None,
    custom: dict[str, str] | None = None,
) -> tuple[np.ndarray, str, str, float]:
    """FT_RECORD rows of the bag's wrench topic (host_time: receive time as Unix seconds,
    replaced by the caller), the topic, its message type and its nominal rate (Hz, from the
    median stamp step in whole nanoseconds; 0 when unknown). Rows dropped are counted by
    reason into `dropped`; the bag's custom_data is copied into `custom`."""
    from rosbags.rosbag2 import Reader
    from rosbags.typesys import Stores, get_typestore

    if not path.exists():
        raise FTNotFoundError(
            f"no such ROS 2 bag: {path} (give the bag's folder, or its .db3 or .mcap file)"
        )
    try:
        with Reader(path) as reader:
            if custom is not None:
                # the storage plug-in's metadata: rosbags 0.11 has no public accessor
                meta = getattr(getattr(reader, "storage", None), "metadata", None)
                custom.update(getattr(meta, "custom", None) or {})
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
    counts = {} if dropped is None else dropped
    wrench = np.array(wrenches, dtype=np.float64)
    stamp_ns = np.array(stamps, dtype=np.int64)
    arrived_ns = np.array(received, dtype=np.int64)
    finite = np.all(np.isfinite(wrench), axis=1)
    with np.errstate(invalid="ignore"):
        inside = (np.abs(wrench[:, :3]) <= max_force).all(axis=1) & (
            np.abs(wrench[:, 3:]) <= max_torque
        ).all(axis=1)
    counts["not_finite"] = int(np.count_nonzero(~finite))
    counts["beyond_range"] = int(np.count_nonzero(finite & ~inside))
    keep: np.ndarray = finite & inside
    if not keep.any():
        raise FTBagError(
            f"{path}: none of the {len(stamps)} wrenches on {topic} is usable "
            f"({counts['not_finite']} not finite, {counts['beyond_range']} beyond ±{max_force:g} N"
            f" / ±{max_torque:g} N·m); is it the F/T sensor's topic?"
        )
    jumped = keep & _jumped(stamp_ns, arrived_ns, keep, max_jump)
    counts["stamp_jumps"] = int(np.count_nonzero(jumped))
    keep = keep & ~jumped
    stamp_ns, arrived_ns, wrench = stamp_ns[keep], arrived_ns[keep], wrench[keep]
    # a bag is in receive order; the F/T stream is in its own clock's order (a message that
    # overtook another on the way to the recorder goes back to its place)
    order = np.argsort(stamp_ns, kind="stable")
    stamp_ns = stamp_ns[order]
    rows = np.zeros(len(stamp_ns), dtype=FT_RECORD)
    rows["sensor_time"] = _seconds(stamp_ns)
    rows["host_time"] = _seconds(arrived_ns[order])
    rows["sequence"] = np.arange(len(rows))
    rows["wrench"] = wrench[order]
    step = float(np.median(np.diff(stamp_ns))) if len(stamp_ns) > 1 else 0.0
    return rows, topic, msgtype, NS_PER_S / step if step > 0 else 0.0


def _jumped(
    stamp_ns: np.ndarray, recv_ns: np.ndarray, ok: np.ndarray, max_jump: float
) -> np.ndarray:
    """Stamps farther than `max_jump` s from the robust line of (receive - stamp) against
    receive time: a median level first, then a least-squares line through the points near
    it (a clock's drift), so that one wild stamp moves neither."""
    r = _seconds(recv_ns) - _seconds(recv_ns[ok][0])
    gap = (recv_ns - stamp_ns).astype(np.float64) / NS_PER_S
    near = ok & (np.abs(gap - np.median(gap[ok])) <= max_jump)
    if np.count_nonzero(near) >= 2 and np.ptp(r[near]) > 0:
        line = np.polyval(np.polyfit(r[near], gap[near], 1), r)
    else:
        line = np.full(len(r), np.median(gap[ok]))
    jumped: np.ndarray = np.abs(gap - line) > max_jump
    return jumped


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
        opts = Options(url, {**dict(parse_qsl(query)), **options}, URL_PARAMS)
        topic = opts.text("topic")
        host_mode = opts.text("host_time", "bag")
        rate = opts.number("rate")
        max_force = opts.number("max_force", MAX_FORCE_N)
        max_torque = opts.number("max_torque", MAX_TORQUE_NM)
        max_jump = opts.number("max_jump", MAX_JUMP_S)
        realtime = opts.flag("realtime")
        speed = opts.number("speed", 1.0)
        dropped: dict[str, int] = {}
        custom: dict[str, str] = {}
        rows, topic, msgtype, nominal = load_wrenches(
            path, topic, max_force=max_force, max_torque=max_torque, max_jump=max_jump,
            dropped=dropped, custom=custom,
        )  # fmt: skip
        timeline = _timeline(path, custom)
        if timeline is None:
            # the bag's wall-clock receive times onto this host's monotonic clock
            unix_minus_monotonic_ns = host_clock.unix_minus_monotonic_ns()
            rows["host_time"] -= unix_minus_monotonic_ns / NS_PER_S
        else:  # an exported bag: back through its timeline onto its recording's host clock
            unix_minus_monotonic_ns = int(timeline["unix_minus_monotonic_ns"])
            anchor, scale = float(timeline["anchor_monotonic"]), float(timeline["scale"])
            t = rows["host_time"] - unix_minus_monotonic_ns / NS_PER_S
            rows["host_time"] = anchor + (t - anchor) / scale
        info = FTInfo("rosbag", model=f"ROS 2 bag {msgtype}", serial=str(path))
        info.rate_hz = rate or nominal
        info.extra.update(rows=len(rows), path=str(path), topic=topic, msgtype=msgtype)
        info.extra.update(dropped=dropped, timeline=timeline)
        if host_mode == "bag":  # how to put the rows on another process's clock
            info.extra["unix_minus_monotonic_ns"] = unix_minus_monotonic_ns
        sensor = cls(url, info, timeout=timeout, buffer_size=buffer_size)
        sensor._setup(rows, keep_host=host_mode == "bag", rate=rate, realtime=realtime, speed=speed)
        return sensor


def _timeline(path: Path, custom: dict[str, str]) -> dict[str, float] | None:
    """The timeline an exported bag declares (None: a bag on the wall clock)."""
    text = custom.get(TIMELINE_KEY)
    if text is None:
        return None
    try:
        t = json.loads(text)
        values = {k: float(t[k]) for k in ("unix_minus_monotonic_ns", "anchor_monotonic", "scale")}
    except (ValueError, TypeError, KeyError) as exc:
        raise FTBagError(f"{path}: its {TIMELINE_KEY} metadata is unreadable ({exc})") from None
    if not all(np.isfinite(v) for v in values.values()) or values["scale"] <= 0:
        raise FTBagError(f"{path}: its {TIMELINE_KEY} metadata is not a timeline: {text[:200]}")
    return values
