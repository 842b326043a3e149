"""Read a SpectraTac recording back: every channel into arrays and lists.

A file that ends early (SIGKILL, power loss, disk full) yields its readable prefix, every
complete chunk, and a `TruncatedRecordingWarning` saying how much was read; `truncated` and
`problem` on the result say the same for programs.

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

import json
import struct
import warnings
import zlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from mcap.exceptions import McapError
from mcap.records import Channel, Footer, Message
from mcap.stream_reader import StreamReader

from spectratac.record.errors import RecordingError, TruncatedRecordingWarning
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

try:  # zstd errors are raised by the decompressor, not wrapped by mcap
    from zstandard import ZstdError
except ImportError:  # pragma: no cover - mcap's writer needs zstandard anyway
    ZstdError = McapError  # type: ignore[misc,assignment]

_READ_ERRORS = (McapError, struct.error, ValueError, EOFError, zlib.error, ZstdError)


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
    stats: dict[str, Any] | None = None  # the last stats message
    end: dict[str, Any] | None = None  # present when the recorder finished cleanly
    truncated: bool = False
    problem: str = ""  # why reading stopped early

    @property
    def clock(self) -> HostClock:
        return HostClock(int(self.session.get("unix_minus_monotonic_ns", 0)))


def read_recording(path: str | Path) -> Recording:
    """Read `path`; raises RecordingError if it is not a SpectraTac recording at all."""
    path = Path(path)
    rec = Recording(path)
    try:
        f = open(path, "rb")  # noqa: SIM115
    except OSError as exc:
        raise RecordingError(f"cannot open recording {path}: {exc}") from None
    topics: dict[int, Channel] = {}
    log_times: list[int] = []
    ft_parts: list[bytes] = []
    ft_dtype: np.dtype | None = None
    truth_parts: list[bytes] = []
    truth_dtype: np.dtype | None = None
    finished = False
    with f:
        try:
            for record in StreamReader(f, skip_magic=False, validate_crcs=True).records:
                if isinstance(record, Message):
                    channel = topics.get(record.channel_id)
                    if channel is None:
                        continue
                    topic = channel.topic
                    if topic == FRAMES:
                        rec.frames.append(record.data)
                        log_times.append(record.log_time)
                    elif topic == FT_SAMPLES:
                        ft_parts.append(record.data)
                    elif topic == GROUND_TRUTH:
                        truth_parts.append(record.data)
                    elif topic in JSON_TOPICS:
                        _take_json(rec, topic, json.loads(record.data))
                    # other topics come from a newer minor revision: ignored
                elif isinstance(record, Channel):
                    topics[record.id] = record
                    if record.topic == FT_SAMPLES:
                        ft_dtype = dtype_from_json(record.metadata["dtype"])
                    elif record.topic == GROUND_TRUTH:
                        truth_dtype = dtype_from_json(record.metadata["dtype"])
                elif isinstance(record, Footer):
                    finished = True
        except _READ_ERRORS as exc:
            rec.truncated, rec.problem = True, f"{type(exc).__name__}: {exc}"
    if not finished and not rec.truncated:
        rec.truncated, rec.problem = True, "the file ends without an MCAP footer"
    if not rec.session:
        why = f" ({rec.problem})" if rec.truncated else ""
        raise RecordingError(
            f"{path} is not a readable SpectraTac recording{why}: no session message. A "
            f"recording killed within its first moments holds nothing; record again"
        )
    if rec.session.get("format") != FORMAT:
        raise RecordingError(f"{path} is an MCAP file but not a SpectraTac recording")
    if rec.session.get("version", VERSION) > VERSION:
        raise RecordingError(
            f"{path} is recording format version {rec.session['version']}; this library "
            f"reads up to {VERSION}: update spectratac"
        )
    rec.frame_host_times = rec.clock.monotonic_array(np.array(log_times, dtype=np.int64))
    if ft_dtype is not None:
        rec.ft = np.frombuffer(b"".join(ft_parts), dtype=ft_dtype)
    if truth_dtype is not None:
        rec.ground_truth = np.frombuffer(b"".join(truth_parts), dtype=truth_dtype)
    if rec.truncated:
        warnings.warn(
            f"{path} is truncated ({rec.problem}); using its readable prefix: "
            f"{len(rec.frames)} frames, {0 if rec.ft is None else len(rec.ft)} F/T samples",
            TruncatedRecordingWarning,
            stacklevel=2,
        )
    return rec


def _take_json(rec: Recording, topic: str, obj: Any) -> None:
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
