"""`RecordingWriter`: the MCAP file of one session, written crash-safe.

Data go into small zstd chunks; a chunk reaches the disk as soon as it fills and at least
every `flush_s` seconds (`maybe_flush`), so a process killed with SIGKILL leaves a file whose
every complete chunk is readable (`spectratac.record.reader` returns that prefix). Not
thread-safe: one thread (the recorder's loop) writes.

The compact channels (frames, F/T batches, ground-truth batches) hold their bytes in a
one-field protobuf message (`record.wrapped`), so players decode every channel. Beside each
compact channel the writer puts
every row once more, decoded, on a channel with a JSON schema (`spectratac.record.schemas`:
`/spectratac/counts`, `/spectratac/estimates`, `/ft/wrench`, `/spectratac/truth`), so any
MCAP tool plots the file: every row up to `schemas.RATE_CAP_HZ` rows per second of host
time, an even subset of faster streams. `decoded=False` writes the compact channels alone
(benchmarks).

>>> import tempfile, numpy as np
>>> path = tempfile.mkdtemp() + "/s.mcap"
>>> with RecordingWriter(path, {"url": "sim://"}, unix_minus_monotonic_ns=0) as w:
...     w.frames([(b"\\x01\\x00\\x84\\x00\\x00", 1.0)])
...     w.json(LABELS, {"region": 5}, 1.5)
>>> from spectratac.record.reader import read_recording
>>> rec = read_recording(path)
>>> rec.frame_host_times.tolist(), rec.labels, rec.truncated
([1.0], [{'region': 5}], False)
"""

from __future__ import annotations

import io
import json
import os
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from mcap.writer import CompressionType, Writer

from spectratac import __version__, host_clock
from spectratac.device.records import Unwrapper
from spectratac.protocol.bulk import payload_dtype
from spectratac.protocol.framing import HEADER
from spectratac.protocol.generated import messages as m
from spectratac.record.errors import RecordingError
from spectratac.record.format import (
    COMPACT,
    EPOCH,
    FORMAT,
    FRAMES,
    FT_SAMPLES,
    GROUND_TRUTH,
    GROUND_TRUTH_RECORD,
    JSON_TOPICS,
    LABELS,
    SESSION,
    VERSION,
    HostClock,
    dtype_to_json,
)
from spectratac.record.schemas import (
    COUNTS,
    ESTIMATES,
    SCHEMAS,
    TRUTH,
    WRENCH,
    RateCap,
    counts_messages,
    device_estimate_messages,
    host_estimate_message,
    metadata_schema,
    schema_bytes,
    split_frames,
    truth_messages,
    wrench_messages,
)
from spectratac.record.timeline import LiveClock, Timeline
from spectratac.record.wrapped import ENCODING as WRAPPED
from spectratac.record.wrapped import schema as wrapped_schema
from spectratac.record.wrapped import wrap

__all__ = ["LABELS", "RecordingWriter"]

_LABEL_TIMES = ("t_start", "t_end")
CHUNK_BYTES = 64 * 1024  # small chunks: little is lost to a crash, zstd still works well
_SAMPLE, _ESTIMATE = m.Sample.TYPE_ID, m.Estimate.TYPE_ID
#: Byte offset of t_end_us (u32 LE) in a decoded frame of the types whose payload has it.
_T_END_AT = {
    kind: HEADER.size + int(payload_dtype(message).fields["t_end_us"][1])  # type: ignore[index]
    for kind, message in ((_SAMPLE, m.Sample), (_ESTIMATE, m.Estimate))
}


class RecordingWriter:
    def __init__(
        self,
        path: str | Path,
        session: dict[str, Any],
        *,
        ft_dtype: np.dtype | None = None,
        ground_truth: bool = False,
        unix_minus_monotonic_ns: int | None = None,
        flush_s: float = 1.0,
        chunk_bytes: int = CHUNK_BYTES,
        decoded: bool = True,
    ) -> None:
        """Create `path` and write the session message. `session` is free-form JSON (URLs,
        sim scene, request); format, version, library version and clocks are added.
        `ground_truth`: the link carries ground truth (GROUND_TRUTH channel). `decoded`:
        write the decoded channels beside the compact ones (FORMAT.md)."""
        self.path = Path(path)
        if unix_minus_monotonic_ns is None:
            unix_minus_monotonic_ns = host_clock.unix_minus_monotonic_ns()
        self.clock = HostClock(unix_minus_monotonic_ns)
        # log_time is on the sensor's clock (record.timeline); publish_time the host arrival
        scale = (session.get("link") or {}).get("clock_scale", 1.0)
        now = time.monotonic()
        self.timeline = Timeline(unix_minus_monotonic_ns, now, 1.0 if scale is None else scale)
        self._device = LiveClock(scale)
        self._ft_clock = LiveClock(scale)
        self._unwrap = Unwrapper()
        declared = (session.get("truth") or {}).get("ft_clock")
        self._ft_declared = (
            None if not declared else (float(declared["offset_s"]), float(declared["drift"]))
        )
        try:
            self._file: io.BufferedWriter = open(self.path, "wb")  # noqa: SIM115
        except OSError as exc:
            raise RecordingError(
                f"cannot create {self.path}: {exc}; give a writable path"
            ) from None
        self._mcap = Writer(self._file, chunk_size=chunk_bytes, compression=CompressionType.ZSTD)
        self._mcap.start(profile="", library=f"spectratac/{__version__}")
        self._channels = {topic: self._json_channel(topic, metadata_schema(topic))
                          for topic in JSON_TOPICS}  # fmt: skip
        self.decoded = decoded
        self._caps = {topic: RateCap() for topic in (COUNTS, ESTIMATES, WRENCH, TRUTH)}
        if decoded:
            self._channels[COUNTS] = self._json_channel(COUNTS, SCHEMAS[COUNTS])
            self._channels[ESTIMATES] = self._json_channel(ESTIMATES, SCHEMAS[ESTIMATES])
            if ft_dtype is not None:
                self._channels[WRENCH] = self._json_channel(WRENCH, SCHEMAS[WRENCH])
            if ground_truth:
                self._channels[TRUTH] = self._json_channel(TRUTH, SCHEMAS[TRUTH])
        self._channels[FRAMES] = self._compact_channel(
            FRAMES, {"content": "COBS-decoded frame: header, payload, CRC-32C"}
        )
        if ft_dtype is not None:
            self._channels[FT_SAMPLES] = self._compact_channel(
                FT_SAMPLES, {"dtype": dtype_to_json(ft_dtype)}
            )
        if ground_truth:
            self._channels[GROUND_TRUTH] = self._compact_channel(
                GROUND_TRUTH, {"dtype": dtype_to_json(GROUND_TRUTH_RECORD)}
            )
        #: the last log_time per channel: a live clock's refit may move a fit back, and a
        #: player's timeline (Lichtblick, Foxglove) must only advance within a channel
        self._last_log: dict[int, int] = {}
        self.ft_dtype = ft_dtype
        self.flush_s = flush_s
        self._last_flush = time.monotonic()
        self._closed = False
        self.frames_written = 0
        self.ft_rows_written = 0
        header = {
            "format": FORMAT,
            "version": VERSION,
            "library_version": __version__,
            "started_unix": (self.clock.log_time(now)) / 1e9,
            "started_monotonic": now,
            "unix_minus_monotonic_ns": unix_minus_monotonic_ns,
            "timeline": self.timeline.as_dict(),
        }
        self.json(SESSION, {**header, **session}, now)
        self.flush()

    def _json_channel(self, topic: str, schema: dict[str, Any]) -> int:
        schema_id = self._mcap.register_schema(schema["title"], "jsonschema", schema_bytes(schema))
        return self._mcap.register_channel(topic, "json", schema_id)

    def _compact_channel(self, topic: str, metadata: dict[str, str]) -> int:
        name, doc = COMPACT[topic]
        full_name, descriptor = wrapped_schema(name)
        schema_id = self._mcap.register_schema(full_name, WRAPPED, descriptor)
        return self._mcap.register_channel(topic, WRAPPED, schema_id, {**metadata, "about": doc})

    # ------------------------------------------------------------------ messages
    def frames(self, frames: Sequence[tuple[bytes, float]]) -> None:
        """(decoded frame bytes, host receive time) pairs, one MCAP message each; SAMPLE
        and ESTIMATE frames also decoded onto COUNTS and ESTIMATES."""
        add = self._add
        channel = self._channels[FRAMES]
        offset = self.clock.unix_minus_monotonic_ns
        on_clock = self._frame_times(frames)
        logs = self.timeline.ns_array(on_clock).tolist()
        written = np.zeros(len(frames), np.int64)
        for i, ((raw, t), log) in enumerate(zip(frames, logs, strict=True)):
            ns = round(t * 1e9) + offset
            # sequence = the frame's own 16-bit sequence number (header bytes 3-4)
            written[i] = add(
                channel, log, wrap(raw), ns, raw[3] | raw[4] << 8 if len(raw) > 4 else 0
            )
        self.frames_written += len(frames)
        if self.decoded and frames:
            samples, sample_t, estimates, estimate_t = split_frames(frames)
            kinds = np.array([raw[2] if len(raw) > 2 else -1 for raw, _ in frames])
            # a decoded row at its frame's log_time as written: a frame that arrived before
            # it, inside its window's lag, may have moved it forward (never back) on FRAMES
            sample_ns = written[kinds == _SAMPLE]
            estimate_ns = written[kinds == _ESTIMATE]
            first, last = frames[0][1], frames[-1][1]
            keep = self._caps[COUNTS].take(len(samples), last, first)
            self._decoded(
                COUNTS, counts_messages(samples[keep]), sample_t[keep], log_ns=sample_ns[keep]
            )
            keep = self._caps[ESTIMATES].take(len(estimates), last, first)
            self._decoded(
                ESTIMATES,
                device_estimate_messages(estimates[keep]),
                estimate_t[keep],
                log_ns=estimate_ns[keep],
            )

    def _frame_times(self, frames: Sequence[tuple[bytes, float]]) -> np.ndarray:
        """Host seconds on the device's clock of each frame: a SAMPLE's or ESTIMATE's
        window end through the live clock fit, any other frame its arrival time."""
        arrival = np.array([t for _, t in frames], np.float64)
        device = np.full(len(frames), np.nan)
        for i, (raw, _) in enumerate(frames):
            at = _T_END_AT.get(raw[2]) if len(raw) > 2 else None
            if at is not None and len(raw) >= at + 4:
                device[i] = self._unwrap(int.from_bytes(raw[at : at + 4], "little")) / 1e6
        timed = np.isfinite(device)
        if timed.any():
            arrival[timed] = self._device.to_host(device[timed], arrival[timed])
        return arrival

    def _add(
        self, channel: int, log_time: int, data: bytes, publish_time: int, sequence: int = 0
    ) -> int:
        """One message; its log_time never before the channel's last (clamped forward), and
        returned as written."""
        log_time = max(log_time, self._last_log.get(channel, 0))
        self._last_log[channel] = log_time
        self._mcap.add_message(channel, log_time, data, publish_time, sequence)
        return log_time

    def _decoded(
        self,
        topic: str,
        messages: list[bytes],
        host_times: Sequence[float],
        on_clock: Sequence[float] | np.ndarray | None = None,
        log_ns: np.ndarray | None = None,
    ) -> None:
        """One message per row: publish_time its host time, log_time `log_ns` if given, else
        `on_clock` (host seconds on the sensor's clock; default the host time) on the
        timeline."""
        add = self._add
        channel = self._channels[topic]
        offset = self.clock.unix_minus_monotonic_ns
        if log_ns is not None:
            logs = [int(v) for v in log_ns]
        else:
            logs = self.timeline.ns_array(host_times if on_clock is None else on_clock).tolist()
        for data, t, log in zip(messages, host_times, logs, strict=True):
            add(channel, log, data, round(t * 1e9) + offset)

    def estimates(self, rows: Sequence[dict[str, Any]]) -> None:
        """Estimates the host decoded (rows of the live page's history: host_time,
        device_time_s, Fx..Tz, region, region_prob, contact, ood, invalid) on ESTIMATES;
        rows no model decoded (region None) are not estimates and are left out."""
        rows = [r for r in rows if r.get("region") is not None]
        if self.decoded:
            self._decoded(ESTIMATES, [host_estimate_message(r) for r in rows],
                          [float(r["host_time"]) for r in rows])  # fmt: skip

    def ft(self, rows: np.ndarray) -> None:
        """A batch of F/T rows as one message; log_time is the last row's host time."""
        if not len(rows):
            return
        if self.ft_dtype is None or rows.dtype != self.ft_dtype:
            raise RecordingError(
                f"F/T rows of dtype {rows.dtype} given to a recording opened for "
                f"{self.ft_dtype}: open the writer with ft_dtype=FT_RECORD"
            )
        ns = self.clock.log_time(float(rows["host_time"][-1]))
        on_clock = self._ft_clock.to_host(rows["sensor_time"], rows["host_time"])
        if self._ft_declared is not None:  # a simulated F/T's clock is the device's, declared
            offset_s, drift = self._ft_declared
            exact = self._device.map((rows["sensor_time"] - offset_s) / (1.0 + drift))
            on_clock = on_clock if exact is None else exact
        log = self.timeline.ns(float(on_clock[-1]))
        self._add(self._channels[FT_SAMPLES], log, wrap(rows.tobytes()), ns)
        self.ft_rows_written += len(rows)
        if self.decoded:
            times = rows["host_time"]
            keep = self._caps[WRENCH].take(len(rows), float(times[-1]), float(times[0]))
            kept = rows[keep]
            self._decoded(WRENCH, wrench_messages(kept), kept["host_time"].tolist(), on_clock[keep])

    def ground_truth(self, rows: np.ndarray, host_time: float) -> None:
        """A batch of GROUND_TRUTH_RECORD rows as one message stamped `host_time`. Written
        before the batch's frames, so any readable prefix of the file has the truth of
        every sample in it."""
        if not len(rows):
            return
        channel = self._channels.get(GROUND_TRUTH)
        if channel is None or rows.dtype != GROUND_TRUTH_RECORD:
            raise RecordingError(
                "ground truth given to a recording opened without it, or rows of another "
                "dtype: open the writer with ground_truth=True and give GROUND_TRUTH_RECORD rows"
            )
        ns = self.clock.log_time(host_time)
        log = self.timeline.ns(host_time)
        self._add(channel, log, wrap(rows.tobytes()), ns)
        if self.decoded:
            kept = rows[self._caps[TRUTH].take(len(rows), host_time)]
            self._decoded(TRUTH, truth_messages(kept), [host_time] * len(kept))

    def json(self, topic: str, obj: Any, host_time: float) -> None:
        """One JSON message on a JSON topic, stamped with host monotonic time `host_time`
        (publish_time; log_time: that time on the timeline)."""
        ns = self.clock.log_time(host_time)
        if topic == LABELS and isinstance(obj, dict):  # a time not known is absent, not null
            obj = {k: v for k, v in obj.items() if not (v is None and k in _LABEL_TIMES)}
        data = json.dumps(obj, default=_jsonable).encode()
        self._add(self._channels[topic], self.timeline.ns(host_time), data, ns)
        if topic == EPOCH:  # a new connection: the device clock may have restarted
            self._device.reset()
            self._unwrap = Unwrapper()

    # ------------------------------------------------------------------ durability
    @property
    def bytes_written(self) -> int:
        """Bytes handed to the file so far (all of them readable after a crash once flushed)."""
        return self._file.tell()

    def maybe_flush(self) -> bool:
        """Close the chunk in progress if `flush_s` passed since the last flush; push any
        chunk already closed (because it filled) to the OS. True if a chunk was closed."""
        if time.monotonic() - self._last_flush >= self.flush_s:
            self.flush()
            return True
        self._file.flush()
        return False

    def flush(self) -> None:
        """Write the chunk in progress and hand everything to the OS (survives SIGKILL)."""
        self._mcap.flush()
        self._last_flush = time.monotonic()

    def close(self) -> None:
        """Write the summary section and close the file (a finished, indexed MCAP)."""
        if self._closed:
            return
        self._closed = True
        try:
            self._mcap.finish()
            self._file.flush()
            os.fsync(self._file.fileno())
        finally:
            self._file.close()

    def __enter__(self) -> RecordingWriter:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _jsonable(obj: Any) -> Any:
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, bytes):
        return obj.hex()
    if isinstance(obj, Path):
        return str(obj)
    raise TypeError(f"{type(obj).__name__} is not JSON serialisable")
