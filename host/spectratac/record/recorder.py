"""`Recorder`: one session of a SpectraTac device (and optionally a reference F/T sensor)
into an MCAP file: raw frames, F/T batches, clock-sync exchanges, info, configuration,
labels and stats, until a duration, a sample count, the guided protocol, the end of a
simulated scene or a stop request. A link with ground truth (a simulated device,
spectratac.device.GroundTruth) also gets each sample's truth and its scene's label events
written as the session goes, so the file alone labels its samples.

The device's frames are taken verbatim by a frame listener on the sensor's reader thread
(a deque append per frame); everything else happens on the caller's thread in one loop that
moves what arrived into the file every `poll_s`, re-syncs the device clock every
`sync_every_s` and flushes a chunk at least every `flush_s` (crash safety). Torch-free.

>>> import tempfile
>>> from spectratac.device import Sensor
>>> path = tempfile.mkdtemp() + "/tour.mcap"
>>> with Sensor.open("sim://?scene=tour&speed=max") as sensor:
...     summary = Recorder(sensor, path, RecordOptions(samples=40)).run()
>>> summary.samples >= 40, summary.lost, summary.stopped_by
(True, 0, 'samples')
"""

from __future__ import annotations

import collections
import contextlib
import sys
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np

from spectratac.device import DeviceTimeoutError, DisconnectedError, Sensor
from spectratac.device.ground_truth import GroundTruth
from spectratac.device.records import Unwrapper
from spectratac.errors import SpectraTacError
from spectratac.protocol import Frame
from spectratac.protocol.generated import messages as m
from spectratac.record.describe import config_summary, info_dict
from spectratac.record.duration_cut import DurationCut
from spectratac.record.errors import RecordingError
from spectratac.record.format import (
    CONFIG,
    END,
    EPOCH,
    FT_INFO,
    GROUND_TRUTH_RECORD,
    INFO,
    LABELS,
    STATS,
    TIME_SYNC,
)
from spectratac.record.guided import GuidedProtocol
from spectratac.record.labels import LabelQueue
from spectratac.record.stop import StopFlag
from spectratac.record.writer import RecordingWriter

StopReason = Literal["duration", "samples", "scene_end", "guided", "interrupt", "error"]


@dataclass
class RecordOptions:
    """What to record and how. Stops at whichever of duration_s, samples, the guided
    protocol's end or a stop request comes first (none given: only a stop request).
    duration_s is on the sensor's clock (what "60 s of data" means: 1200 samples at 50 ms,
    whether a simulated device runs at speed=1 or speed=10)."""

    duration_s: float | None = None
    samples: int | None = None
    integration_ms: int = 50
    gain: float = 1.0
    digital_gain: int = 1
    sensitivity: Literal["high", "low"] = "high"
    leds: Sequence[Sequence[Sequence[int]]] | None = None  # steps x 3 LEDs x RGB permille
    settle_us: int = 1000
    #: keep the device's own estimates (ESTIMATE frames beside the samples; a device that
    #: decodes on board: `spectratac model upload`) on /spectratac/estimates
    estimates: bool = False
    sync_every_s: float = 5.0
    sync_exchanges: int = 8
    flush_s: float = 1.0
    poll_s: float = 0.02

    def validate(self) -> None:
        if self.duration_s is not None and not self.duration_s > 0:
            raise RecordingError(f"duration {self.duration_s!r} s: give a positive number")
        if self.samples is not None and self.samples < 1:
            raise RecordingError(f"samples {self.samples!r}: give at least 1")
        if self.sync_every_s <= 0 or self.flush_s <= 0 or self.poll_s <= 0:
            raise RecordingError("sync, flush and poll intervals must be > 0 s")


@dataclass
class RecordingStatus:
    """Live figures for a progress display. elapsed_s: wall clock; sensor_s: the sensor's
    clock covered by the samples so far (what duration_s counts)."""

    elapsed_s: float
    sensor_s: float
    samples: int
    ft_samples: int
    ft_rate_hz: float
    lost: int  # optical samples missing by sequence number
    crc_errors: int
    ft_lost: int
    labels: int
    file_bytes: int


@dataclass
class RecordingSummary:
    path: Path
    samples: int
    frames: int
    ft_samples: int
    lost: int
    frame_gaps: int
    crc_errors: int
    ft_lost: int
    labels: int
    duration_s: float  # wall clock
    file_bytes: int
    stopped_by: StopReason
    config_id: int
    error: str | None = None
    sensor_stats: dict[str, int] = field(default_factory=dict)
    ft_stats: dict[str, int] | None = None
    sensor_s: float = 0.0  # the sensor's clock covered by the samples (duration_s counts it)
    ft_stalls: int = 0  # the F/T's quiet spells past its stall timeout (the optical went on)
    ft_simulated_loss: float | None = None  # a simulated F/T's deliberate loss probability

    def as_dict(self) -> dict[str, Any]:
        return asdict(self) | {"path": str(self.path)}


class Recorder:
    def __init__(
        self,
        sensor: Sensor,
        path: str | Path,
        options: RecordOptions | None = None,
        *,
        ft: Any = None,
        session: dict[str, Any] | None = None,
        ground_truth: GroundTruth | None = None,
        guided: GuidedProtocol | None = None,
        warn: Callable[[str], None] | None = None,
    ) -> None:
        """`ft`: an open spectratac.ft.FTSensor or None. `session`: extra JSON for the session
        message (URLs, host). `ground_truth`: the link's truth (simulated devices: see
        spectratac.device.ground_truth_of); it is described in the session message
        ("truth"), labels every sample, gives the scene's label events, and ends the session
        when the device clock passes its `duration_s`. `guided`: the guided labelling
        protocol, run on the sensor's clock from the first sample (its labels' spans are
        device times, LABELS.md). `warn` is told once, in a line, that the F/T
        went quiet (default: stderr); the recording goes on without it."""
        self.sensor = sensor
        self.path = Path(path)
        self.options = options or RecordOptions()
        self.options.validate()
        self.ft = ft
        # what the link knows of itself (clock scale...), stored generically: FORMAT.md
        self.session = dict(session or {}) | {"link": sensor.link_info.as_dict(), "truth": None}
        self.ground_truth = ground_truth
        self.labeler: LabelQueue | None = None
        self.scene_end_s: float | None = None
        if ground_truth is not None:
            self.session["truth"] = ground_truth.describe()
            self.labeler = LabelQueue(ground_truth.label_events())
            self.scene_end_s = ground_truth.duration_s  # a scene that ends ends the session
        self.guided = guided
        if guided is not None:
            guided.start_at(0.0)  # the sensor's clock from the first sample's integration
        self.warn = warn or _to_stderr
        self._ft_warned = False
        # frames as they arrive, and (new epoch, host time) where a reconnect began one
        self._frames: collections.deque[tuple[Frame | int, float]] = collections.deque()
        self._unwrap = Unwrapper()  # device µs of the frames written, as the dataset reads them
        # a duration ends on the device clock: samples past it are not written (see DurationCut)
        # a scene's end cuts like a duration: both end on the device (scene) clock; a sample
        # count cuts at exactly that many samples
        ends = [d for d in (self.options.duration_s, self.scene_end_s) if d is not None]
        count = self.options.samples
        self._cut = (
            DurationCut(min(ends) if ends else None, samples=count)
            if ends or count is not None
            else None
        )
        self._samples = 0
        self._ft_rows = 0
        self._labels = 0
        self._scene_now = 0.0  # device clock of the newest sample, s (= scene time in sim)
        # sensor time covered: closed epochs (a reconnect may restart the device clock), and
        # the current epoch's (epoch, first integration start in s)
        self._sensor_done_s = 0.0
        self._segment: tuple[int, float] | None = None
        self._sync_seen = 0
        self._ft_window: collections.deque[tuple[float, int]] = collections.deque()

    # ------------------------------------------------------------------ the session
    def run(
        self,
        stop: StopFlag | None = None,
        progress: Callable[[RecordingStatus], None] | None = None,
    ) -> RecordingSummary:
        """Record until done; the file is finished (indexed) whatever ends the session.
        Raises RecordingError only if the session could not start; a link lost midway ends
        the session with `stopped_by="error"` and the error in the summary."""
        opts = self.options
        stop = stop or threading.Event()
        ft_dtype = None
        if self.ft is not None:
            from spectratac.ft import FT_RECORD  # only sessions with F/T need the drivers

            ft_dtype = FT_RECORD
        session = {
            "url": self.sensor.url,
            "ft_url": getattr(self.ft, "url", None),
            "request": asdict(opts) | {"leds": _listify(opts.leds)},
            # what the dataset's labels come from; a sim session may still be guided
            "labels": "guided" if self.guided else "scene" if self.labeler else "none",
            **self.session,
        }
        writer = RecordingWriter(
            self.path,
            session,
            ft_dtype=ft_dtype,
            ground_truth=self.ground_truth is not None,
            flush_s=opts.flush_s,
        )
        now = time.monotonic()
        writer.json(EPOCH, _epoch_event(self.sensor.epoch, "start", now), now)
        self.sensor.add_epoch_listener(self._on_epoch)
        self.sensor.add_listener(self._on_frame)
        t_begin = time.monotonic()
        stopped_by: StopReason = "error"
        error: str | None = None
        config_id = 0
        started = False
        try:
            config_id = self._start(writer)
            started = True
            t_begin = time.monotonic()
            stopped_by, error = self._loop(writer, stop, progress, t_begin)
        except SpectraTacError as exc:
            stopped_by, error = "error", str(exc)
            if not started:
                self._finish(writer, stopped_by, error)
                raise RecordingError(f"recording {self.path} could not start: {exc}") from exc
        except BaseException:  # KeyboardInterrupt and the like: a finished file, then go on
            self._finish(writer, "interrupt", "interrupted")
            raise
        self._finish(writer, stopped_by, error)
        duration = time.monotonic() - t_begin
        st = self.sensor.stats
        return RecordingSummary(
            path=self.path,
            samples=self._samples,
            frames=writer.frames_written,
            ft_samples=self._ft_rows,
            lost=st.sample_gaps,
            frame_gaps=st.frame_gaps,
            crc_errors=st.crc_errors,
            ft_lost=self.ft.stats.lost if self.ft is not None else 0,
            labels=self._labels,
            duration_s=duration,
            file_bytes=self.path.stat().st_size,
            stopped_by=stopped_by,
            config_id=config_id,
            error=error,
            sensor_stats=st.as_dict(),
            ft_stats=self.ft.stats.as_dict() if self.ft is not None else None,
            sensor_s=self._recorded_sensor_s(),
            ft_simulated_loss=_simulated_loss(self.ft),
            ft_stalls=getattr(self.ft.stats, "stalls", 0) if self.ft is not None else 0,
        )

    def _recorded_sensor_s(self) -> float:
        """Seconds of the sensor's clock the file holds: at most the duration once it was
        reached, or what the counted samples cover (samples that came before the device obeyed
        STOP, many on a loaded host at a high speed, are counted as they arrive but not
        written)."""
        if self._cut is not None and self._cut.reached:
            return min(self.sensor_s, self._cut.limit_us / 1e6, self._cut.kept_s)
        return self.sensor_s

    @property
    def sensor_s(self) -> float:
        """Seconds of the sensor's clock the recorded samples cover."""
        if self._segment is None:
            return self._sensor_done_s
        return self._sensor_done_s + max(self._scene_now - self._segment[1], 0.0)

    def _start(self, writer: RecordingWriter) -> int:
        opts = self.options
        now = time.monotonic()
        writer.json(INFO, info_dict(self.sensor.info), now)
        if self.ft is not None:
            writer.json(FT_INFO, {"url": self.ft.url, **self.ft.info.as_dict()}, now)
        config_id = self.sensor.configure(
            integration_ms=opts.integration_ms,
            gain=opts.gain,
            digital_gain=opts.digital_gain,
            sensitivity=opts.sensitivity,
            leds=None if opts.leds is None else np.asarray(opts.leds),
            settle_us=opts.settle_us,
            estimates="beside" if opts.estimates else "off",
        )
        reply = self.sensor.get_config().to_dict()
        writer.json(
            CONFIG,
            {
                "config_id": config_id,
                "request": {k: v for k, v in asdict(opts).items() if k not in _LOOP_FIELDS}
                | {"leds": _listify(opts.leds)},
                "reply": reply,
                "config": config_summary(reply),
            },
            time.monotonic(),
        )
        self._sync(writer)
        if self.ft is not None:
            self.ft.start()
        self.sensor.start()
        if self.labeler is not None and self.ground_truth is not None:
            # a simulated scene's clock starts with the stream: its label events' host times
            # are known from now on
            self.labeler = LabelQueue(self.ground_truth.label_events())
        writer.flush()
        return config_id

    def _loop(
        self,
        writer: RecordingWriter,
        stop: StopFlag,
        progress: Callable[[RecordingStatus], None] | None,
        t_begin: float,
    ) -> tuple[StopReason, str | None]:
        opts = self.options
        next_sync = t_begin + opts.sync_every_s
        next_progress = t_begin
        while True:
            self._move(writer)
            now = time.monotonic()
            if now >= next_sync:
                try:
                    self._sync(writer)
                except (DisconnectedError, DeviceTimeoutError):
                    if not self.sensor.auto_reconnect:
                        raise
                    # the sensor is reconnecting: the session goes on in a new epoch
                next_sync = now + opts.sync_every_s
            self._label(writer)
            if writer.maybe_flush():
                self._stats(writer)
            if progress is not None and now >= next_progress:
                progress(self.status(now - t_begin, writer))
                next_progress = now + 0.2
            if stop.is_set():
                return "interrupt", None
            if opts.samples is not None and self._samples >= opts.samples:
                return "samples", None
            if opts.duration_s is not None and self.sensor_s >= opts.duration_s:
                return "duration", None
            if self.guided is not None and self.guided.done(self.sensor_s):
                return "guided", None
            if self.scene_end_s is not None and self._scene_now >= self.scene_end_s:
                return "scene_end", None
            stop.wait(self._next_wait())

    def _next_wait(self) -> float:
        """poll_s, or less when the duration ends sooner on the sensor's clock (a fast
        simulated device covers poll_s x speed of sensor time per poll)."""
        opts = self.options
        scale = self.sensor.link_info.clock_scale
        if opts.duration_s is None or not scale:
            return opts.poll_s
        left = (opts.duration_s - self.sensor_s) / scale
        return min(opts.poll_s, max(left, 0.001))

    def _finish(self, writer: RecordingWriter, stopped_by: StopReason, error: str | None) -> None:
        """Stop both streams, keep what is still in flight, write the end summary, close."""
        try:
            for action in (self.sensor.stop, lambda: self._sync(writer), self._stop_ft):
                # a lost link cannot be stopped; what arrived is still written
                with contextlib.suppress(SpectraTacError, OSError):
                    action()
            # each on its own: a lost link on one side must not cost the other its data
            with contextlib.suppress(SpectraTacError):
                self._drain_ft(writer)
            with contextlib.suppress(SpectraTacError):
                self._count_samples()
            self.sensor.remove_listener(self._on_frame)
            self.sensor.remove_epoch_listener(self._on_epoch)
            self._move_frames(writer)
            if self._cut is not None and self._cut.reached:
                self._samples = self._cut.kept  # the samples past the duration are not in it
            if self.labeler is not None:
                self._write_labels(writer, self.labeler.due(self._scene_now))
                self._write_labels(writer, self.labeler.started(self._scene_now))
            now = time.monotonic()
            self._stats(writer)
            writer.json(
                END,
                {
                    "stopped_by": stopped_by,
                    "error": error,
                    "samples": self._samples,
                    "frames": writer.frames_written,
                    "ft_samples": self._ft_rows,
                    "labels": self._labels,
                },
                now,
            )
        finally:
            writer.close()

    # ------------------------------------------------------------------ moving data
    def _on_frame(self, frame: Frame, host_time: float) -> None:
        self._frames.append((frame, host_time))  # reader thread: keep it this small

    def _on_epoch(self, epoch: int, host_time: float) -> None:
        self._frames.append((epoch, host_time))  # in line with the frames around it

    def _move_frames(self, writer: RecordingWriter) -> None:
        q = self._frames
        n = len(q)
        batch: list[tuple[Frame, float]] = []
        for _ in range(n):
            item, host_time = q.popleft()
            if isinstance(item, Frame):
                batch.append((item, host_time))
                continue
            self._write_frames(writer, batch)  # the old connection's, then the break
            batch = []
            writer.json(EPOCH, _epoch_event(item, "reconnect", host_time), host_time)
            self._unwrap = Unwrapper()  # the device clock may have restarted
            if self._cut is not None:
                self._cut.new_epoch()
        self._write_frames(writer, batch)

    def _write_frames(self, writer: RecordingWriter, batch: list[tuple[Frame, float]]) -> None:
        if self._cut is not None and batch:
            kept = {id(f) for f in self._cut.keep([f for f, _ in batch])}
            batch = [(f, t) for f, t in batch if id(f) in kept]
        if batch:
            if self.ground_truth is not None:
                rows = self._truth(self.ground_truth, [f for f, _ in batch])
                writer.ground_truth(rows, batch[0][1])
            writer.frames([(f.raw, t) for f, t in batch])

    def _truth(self, truth: GroundTruth, frames: list[Frame]) -> np.ndarray:
        """GROUND_TRUTH_RECORD rows of the SAMPLE frames among `frames`: each sample's truth
        at the centre of its window, device times unwrapped in arrival order."""
        samples = [f.message for f in frames if isinstance(f.message, m.Sample)]
        rows = np.zeros(len(samples), GROUND_TRUTH_RECORD)
        if not samples:
            return rows
        t_end = np.array([self._unwrap(s.t_end_us) for s in samples], np.int64)
        span = np.array([(s.t_end_us - s.t_start_us) & 0xFFFF_FFFF for s in samples], np.int64)
        rows["sequence"] = [s.sample_seq for s in samples]
        rows["t_end_us"] = t_end
        rows["t_start_us"] = t_end - span
        contact = truth.contact((rows["t_start_us"] + rows["t_end_us"]) / 2e6)
        for name in contact.dtype.names or ():
            rows[name] = contact[name]
        return rows

    def _move(self, writer: RecordingWriter) -> None:
        """Frames and F/T rows that arrived since the last call into the file; then count
        the samples (counting may raise a lost link: everything is written by then)."""
        self._move_frames(writer)
        self._move_ft(writer)
        self._count_samples()

    def _move_ft(self, writer: RecordingWriter) -> None:
        if self.ft is not None:
            # the F/T went quiet: said once, counted in its stats (stalls)
            message = getattr(self.ft, "stall_message", None)
            if message is not None and not self._ft_warned:
                self._ft_warned = True
                self.warn(message)
            rows = self.ft.read_available()
            if len(rows):
                writer.ft(rows)
                self._ft_rows += len(rows)
                self._ft_window.append((time.monotonic(), self._ft_rows))

    def _drain_ft(
        self,
        writer: RecordingWriter,
        quiet_s: float = 0.2,
        limit_s: float = 2.0,
        confirm_s: float = 10.0,
    ) -> None:
        """After the F/T sensor was told to stop: write what is still in flight until the
        sensor confirms the stop (drivers that can, `confirms_stop`: then the file ends where
        the sensor's stream did, however late its data came; at most `confirm_s`), else until
        the link is quiet for `quiet_s` (at most `limit_s`). Its driver counts a gap when the
        rows after it arrive, so rows left unread would be losses the file does not show."""
        if self.ft is None:
            return
        # a stalled sensor will not confirm its stop: wait for quiet only
        stalled = bool(getattr(self.ft, "stalled", False))
        confirms = bool(getattr(self.ft, "confirms_stop", False)) and not stalled
        end = time.monotonic() + (confirm_s if confirms else limit_s)
        quiet_since = time.monotonic()
        while (now := time.monotonic()) < end and (confirms or now - quiet_since < quiet_s):
            if confirms and self.ft.stream_stopped.is_set():
                self._move_ft(writer)  # the rows before the acknowledgement are all queued
                return
            before = self._ft_rows
            self._move_ft(writer)
            if self._ft_rows != before:
                quiet_since = now
            time.sleep(0.02)

    def _count_samples(self) -> None:
        batch = self.sensor.read(1 << 30, timeout=0)  # keeps the sensor's buffer empty
        if len(batch):
            self._samples += len(batch)
            for epoch in np.unique(batch["epoch"]):  # in arrival order: epochs only grow
                rows = batch[batch["epoch"] == epoch]
                if self._segment is None or self._segment[0] != int(epoch):
                    self._sensor_done_s = self.sensor_s
                    self._segment = (int(epoch), float(rows["t_start_us"][0]) / 1e6)
                self._scene_now = float(rows["device_time_us"][-1]) / 1e6

    def _sync(self, writer: RecordingWriter) -> None:
        self.sensor.sync_clock(self.options.sync_exchanges)
        new = self.sensor.time_sync[self._sync_seen :]
        self._sync_seen = len(self.sensor.time_sync)
        if new:
            writer.json(
                TIME_SYNC,
                {"exchanges": [asdict(e) for e in new]},
                new[-1].host_received,
            )

    def _stop_ft(self) -> None:
        if self.ft is not None:
            self.ft.stop()

    def _label(self, writer: RecordingWriter) -> None:
        if self.labeler is not None:
            self._write_labels(writer, self.labeler.due(self._scene_now))
        if self.guided is not None and self._segment is not None:
            epoch, first_s = self._segment
            # the prompts' timeline starts at the first sample's integration; spans go on
            # the device clock of the epoch under way (what the dataset's samples carry)
            to_device = first_s - self._sensor_done_s
            shift = {"clock": "device", "epoch": epoch}
            events = [
                e | shift | {"t_start": e["t_start"] + to_device, "t_end": e["t_end"] + to_device}
                for e in self.guided.poll(self.sensor_s)
            ]
            self._write_labels(writer, events, now=True)

    def _write_labels(
        self, writer: RecordingWriter, events: list[dict[str, Any]], now: bool = False
    ) -> None:
        for event in events:
            t = time.monotonic() if now else event.get("t_end") or time.monotonic()
            writer.json(LABELS, event, t)
            self._labels += 1

    def _stats(self, writer: RecordingWriter) -> None:
        writer.json(
            STATS,
            {
                "sensor": self.sensor.stats.as_dict(),
                "ft": self.ft.stats.as_dict() if self.ft is not None else None,
                "samples": self._samples,
                "ft_samples": self._ft_rows,
            },
            time.monotonic(),
        )

    def status(self, elapsed: float, writer: RecordingWriter) -> RecordingStatus:
        w = self._ft_window
        while len(w) > 2 and w[-1][0] - w[0][0] > 2.0:
            w.popleft()
        rate = (w[-1][1] - w[0][1]) / (w[-1][0] - w[0][0]) if len(w) > 1 else 0.0
        st = self.sensor.stats
        return RecordingStatus(
            elapsed_s=elapsed,
            sensor_s=self.sensor_s,
            samples=self._samples,
            ft_samples=self._ft_rows,
            ft_rate_hz=rate,
            lost=st.sample_gaps,
            crc_errors=st.crc_errors,
            ft_lost=self.ft.stats.lost if self.ft is not None else 0,
            labels=self._labels,
            file_bytes=writer.bytes_written,
        )


_LOOP_FIELDS = ("duration_s", "samples", "sync_every_s", "sync_exchanges", "flush_s", "poll_s")


def _epoch_event(epoch: int, reason: str, host_time: float) -> dict[str, Any]:
    return {"epoch": epoch, "reason": reason, "host_time": host_time}


def _listify(leds: Any) -> Any:
    return None if leds is None else np.asarray(leds).tolist()


def _to_stderr(message: str) -> None:
    print(f"spectratac: warning: {message}", file=sys.stderr, flush=True)


def _simulated_loss(ft: Any) -> float | None:
    """The loss probability a simulated F/T sensor applies on purpose (its driver says so in
    FTInfo.extra["simulated_loss"]); None for a real sensor, whose losses are the link's."""
    if ft is None:
        return None
    loss = ft.info.extra.get("simulated_loss")
    return None if loss is None else float(loss)
