"""Read a SpectraTac recording back: every channel into arrays and lists.

A file that ends early (SIGKILL, power loss, disk full) yields its readable prefix, every
complete chunk, and a `TruncatedRecordingWarning` saying how much was read; `truncated` and
`problem` on the result say the same for programs. A damaged chunk inside the file (a flipped
bit: its CRC no longer matches) is skipped and the chunks after it are kept; a
`CorruptedRecordingWarning` and `corrupted_chunks` / `lost_messages` (by topic) say how much
was lost. Damage and truncation are reported apart: one is expected of a killed recorder,
the other is not.

>>> import tempfile, warnings
>>> path = tempfile.mkdtemp() + "/cut.mcap"
>>> from spectratac.record.writer import RecordingWriter
>>> with RecordingWriter(path, {}, unix_minus_monotonic_ns=0) as w:
...     w.frames([(bytes([1, 0, 0x84, i, 0]), float(i)) for i in range(3)])
...     w.flush()
...     safe = w.bytes_written
...     w.frames([(bytes([1, 0, 0x84, 3, 0]), 3.0)])
>>> data = open(path, "rb").read()
>>> _ = open(path, "wb").write(data[: safe + 20])  # as if killed while writing chunk 2
>>> with warnings.catch_warnings(record=True) as caught:
...     warnings.simplefilter("always")
...     rec = read_recording(path)
>>> rec.truncated, len(rec.frames), caught[0].category.__name__
(True, 3, 'TruncatedRecordingWarning')
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from mcap.records import Channel, Message

from spectratac.bounds import loads_bounded
from spectratac.device.link_info import LinkInfo
from spectratac.record.errors import (
    CorruptedRecordingWarning,
    RecordingError,
    TruncatedRecordingWarning,
)
from spectratac.record.format import (
    CONFIG,
    END,
    EPOCH,
    FORMAT,
    FRAMES,
    FT_INFO,
    FT_SAMPLES,
    GROUND_TRUTH,
    INFO,
    JSON_TOPICS,
    LABELS,
    SESSION,
    STATS,
    TIME_SYNC,
    VERSION,
    HostClock,
    dtype_from_json,
)
from spectratac.record.salvage import READ_ERRORS, salvage
from spectratac.record.schemas import DECODED_TOPICS, ESTIMATES
from spectratac.record.wrapped import ENCODING as WRAPPED
from spectratac.record.wrapped import unwrap

#: Decoded copies of the compact channels this reader reads: passed over unparsed
_MIRRORS = frozenset(DECODED_TOPICS) - {ESTIMATES}
_COMPACT = frozenset((FRAMES, FT_SAMPLES, GROUND_TRUTH))


@dataclass
class Recording:
    """Everything in one recording file. Host times are time.monotonic() seconds."""

    path: Path
    session: dict[str, Any] = field(default_factory=dict)
    frames: list[bytes] = field(default_factory=list)  # decoded frames, in arrival order
    frame_host_times: np.ndarray = field(default_factory=lambda: np.empty(0))
    ft: np.ndarray | None = None  # FT_RECORD rows (dtype from the file); None: no F/T channel
    time_sync: list[dict[str, Any]] = field(default_factory=list)
    info: dict[str, Any] | None = None
    configs: dict[int, dict[str, Any]] = field(default_factory=dict)  # by config id
    ft_info: dict[str, Any] | None = None
    labels: list[dict[str, Any]] = field(default_factory=list)
    epochs: list[dict[str, Any]] = field(default_factory=list)  # EPOCH messages, in order
    # GROUND_TRUTH_RECORD rows (dtype from the file); None: the link carried no ground truth
    ground_truth: np.ndarray | None = None
    # estimates in the file (/spectratac/estimates: the device's, or the live page's in a
    # clip), as their JSON objects (record.schemas.SCHEMAS[ESTIMATES]), in file order
    estimates: list[dict[str, Any]] = field(default_factory=list)
    stats: dict[str, Any] | None = None  # the last stats message
    end: dict[str, Any] | None = None  # present when the recorder finished cleanly
    truncated: bool = False
    problem: str = ""  # why reading stopped early
    corrupted_chunks: int = 0  # damaged chunks skipped inside the file
    lost_messages: dict[str, int] = field(default_factory=dict)  # by topic, in those chunks
    corruption: str = ""  # what the damage cost, in words ("" when none)

    @property
    def clock(self) -> HostClock:
        return HostClock(int(self.session.get("unix_minus_monotonic_ns", 0)))

    @property
    def link(self) -> LinkInfo:
        """What the device's link knew about itself (FORMAT.md: "link"; files before
        version 3 say it in their "sim" block: a paced scene's speed, "max" unpaced)."""
        if "link" in self.session:
            return LinkInfo.from_dict(self.session["link"] or {})
        sim = self.session.get("sim")
        if not sim:
            return LinkInfo()
        speed = sim.get("speed")
        scale = None if isinstance(speed, str) else float(speed)
        return LinkInfo(clock_scale=scale, ground_truth=True)

    @property
    def truth(self) -> dict[str, Any]:
        """The ground truth's description (scene, seed, speed...); {} for hardware."""
        return dict(self.session.get("truth", self.session.get("sim")) or {})


def read_recording(path: str | Path) -> Recording:
    """Read `path`; raises RecordingError if it is not a SpectraTac recording at all."""
    path = Path(path)
    rec = Recording(path)
    try:
        found = salvage(path.read_bytes(), skip_topics=_MIRRORS)
    except OSError as exc:
        raise RecordingError(f"cannot open recording {path}: {exc}") from None
    rec.truncated, rec.problem = found.truncated, found.problem
    if not found.finished and not rec.truncated:
        rec.truncated, rec.problem = True, "the file ends without an MCAP footer"
    topics: dict[int, Channel] = {c.id: c for c in found.summary_channels}
    topics.update({r.id: r for r in found.records if isinstance(r, Channel)})
    log_times: list[int] = []
    ft_parts: list[bytes] = []
    truth_parts: list[bytes] = []
    unreadable: dict[str, int] = {}  # messages intact on disk that do not parse: counted, skipped
    # compact channels of version 5 wrap their bytes in a one-field protobuf message
    wrapped = {i for i, c in topics.items() if c.message_encoding == WRAPPED}
    for record in found.records:
        if not isinstance(record, Message) or record.channel_id not in topics:
            continue
        topic = topics[record.channel_id].topic
        data = record.data
        if topic in _COMPACT and record.channel_id in wrapped:
            try:
                data = unwrap(data)
            except ValueError:
                unreadable[topic] = unreadable.get(topic, 0) + 1
                continue
        if topic == FRAMES:
            rec.frames.append(data)
            # the host's arrival time (log_time is on the sensor's clock: record.timeline);
            # files before the timeline wrote it to both
            log_times.append(record.publish_time)
        elif topic == FT_SAMPLES:
            ft_parts.append(data)
        elif topic == GROUND_TRUTH:
            truth_parts.append(data)
        elif topic in JSON_TOPICS or topic == ESTIMATES:
            try:
                _take_json(rec, topic, loads_bounded(record.data, what=topic))
            except (*READ_ERRORS, TypeError, AttributeError):
                unreadable[topic] = unreadable.get(topic, 0) + 1
        # the other decoded channels copy compact ones; other topics come from a newer
        # minor revision: both ignored
    ft_dtype = _dtype_of(topics, FT_SAMPLES, path)
    truth_dtype = _dtype_of(topics, GROUND_TRUTH, path)
    for topic, parts, dtype in ((FT_SAMPLES, ft_parts, ft_dtype),
                                (GROUND_TRUTH, truth_parts, truth_dtype)):  # fmt: skip
        whole = [b for b in parts if dtype is not None and len(b) % dtype.itemsize == 0]
        if len(whole) < len(parts):
            unreadable[topic] = unreadable.get(topic, 0) + len(parts) - len(whole)
            parts[:] = whole
    if found.corrupted_chunks or unreadable:
        rec.corrupted_chunks = found.corrupted_chunks
        rec.lost_messages = {
            topics[c].topic if c in topics else f"channel {c}": k
            for c, k in sorted(found.lost_by_channel.items())
            # the decoded channels copy the compact ones, whose loss is counted
            if c not in topics or topics[c].topic not in DECODED_TOPICS
        }
        for topic, k in unreadable.items():
            rec.lost_messages[topic] = rec.lost_messages.get(topic, 0) + k
        lost = ", ".join(f"{k} {t}" for t, k in rec.lost_messages.items()) or "none counted"
        rec.corruption = (
            f"{rec.corrupted_chunks} damaged chunk(s) skipped; messages lost: {lost}"
            + (" (and an uncounted number more)" if found.lost_uncounted else "")
        )
    if not rec.session:
        why = f" ({rec.problem})" if rec.truncated else ""
        raise RecordingError(
            f"{path} is not a readable SpectraTac recording{why}: no session message. A "
            f"recording killed within its first moments holds nothing; record again"
        )
    if rec.session.get("format") != FORMAT:
        raise RecordingError(f"{path} is an MCAP file but not a SpectraTac recording")
    version = rec.session.get("version", VERSION)
    if not isinstance(version, int) or version > VERSION:
        raise RecordingError(
            f"{path} is recording format version {rec.session['version']}; this library "
            f"reads up to {VERSION}: update spectratac"
        )
    rec.frame_host_times = rec.clock.monotonic_array(np.array(log_times, dtype=np.int64))
    if ft_dtype is not None:
        rec.ft = np.frombuffer(b"".join(ft_parts), dtype=ft_dtype)
    if truth_dtype is not None:
        rec.ground_truth = np.frombuffer(b"".join(truth_parts), dtype=truth_dtype)
    if rec.corruption:
        warnings.warn(
            CorruptedRecordingWarning(
                f"{path} is damaged: {rec.corruption}; the chunks after the damage are "
                f"kept: {len(rec.frames)} frames read. Re-copy it if another copy exists",
                str(path),
                rec.corrupted_chunks,
                rec.lost_messages,
            ),
            stacklevel=2,
        )
    if rec.truncated:
        warnings.warn(
            f"{path} is truncated ({rec.problem}); using its readable prefix: "
            f"{len(rec.frames)} frames, {0 if rec.ft is None else len(rec.ft)} F/T samples",
            TruncatedRecordingWarning,
            stacklevel=2,
        )
    return rec


def _dtype_of(topics: dict[int, Channel], topic: str, path: Path) -> np.dtype | None:
    """The record dtype a binary channel declares; None when the file has no such channel."""
    channel = next((c for c in topics.values() if c.topic == topic), None)
    if channel is None:
        return None
    try:
        return dtype_from_json(channel.metadata["dtype"])
    except (KeyError, ValueError, TypeError) as exc:
        raise RecordingError(f"{path}: channel {topic} has no usable dtype ({exc})") from None


def _take_json(rec: Recording, topic: str, obj: Any) -> None:
    if not isinstance(obj, dict):
        raise TypeError(f"a {topic} message is a JSON {type(obj).__name__}, not an object")
    if topic == SESSION:
        rec.session = obj
    elif topic == TIME_SYNC:
        rec.time_sync.extend(obj["exchanges"])
    elif topic == INFO:
        rec.info = obj
    elif topic == CONFIG:
        rec.configs[int(obj["config_id"])] = obj
    elif topic == FT_INFO:
        rec.ft_info = obj
    elif topic == LABELS:
        rec.labels.append(obj)
    elif topic == EPOCH:
        rec.epochs.append(obj)
    elif topic == STATS:
        rec.stats = obj
    elif topic == END:
        rec.end = obj
    elif topic == ESTIMATES:
        rec.estimates.append(obj)
