"""`Sensor`: open a SpectraTac device, configure it, stream samples.

    >>> from spectratac.device import Sensor
    >>> with Sensor.open("sim://?scene=tour&speed=max") as sensor:
    ...     config_id = sensor.configure(integration_ms=50, leds=[[[500] * 3] * 3])
    ...     sensor.start()
    ...     batch = sensor.read(20, timeout=10.0)
    ...     sensor.stop()
    >>> batch["counts"].shape, batch["sequence"][:3].tolist()
    ((20, 3, 5), [0, 1, 2])
    >>> bool((batch["config_id"] == config_id).all())
    True

On-device decoding (protocol 1.1): `configure(..., estimates="beside")` asks the device for an
ESTIMATE after every SAMPLE (samples keep flowing unchanged), `estimates="instead"` for
estimates only; `read_estimates` returns them as ESTIMATE_RECORD rows. `model_info`,
`upload_model` and `clear_model` manage the model the device decodes with.

Every wait ends: while the sensor streams, a stall watch drops a device that sends nothing for
`stall_timeout` s (default: `default_stall_timeout`, ten sequence periods of the configuration,
at least STALL_FLOOR_S) with DeviceStalledError, or reopens it with reconnect=True.

A Sensor is a façade: its `link` (spectratac.device.link) reads the device in the background,
matches replies to commands and reconnects; samples and estimates wait in two RecordQueues
(spectratac.device.record_queue) until read. Every public method is thread-safe.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Iterator, Sequence
from typing import Literal, TypedDict, Unpack

import numpy as np

from spectratac.device import maintenance, model_store
from spectratac.device.boot_report import BootReport
from spectratac.device.clock_sync import ClockSync, TimeSyncExchange, sync_clock
from spectratac.device.errors import DeviceError, DeviceStalledError
from spectratac.device.estimate_records import EstimateGaps, EstimateRow, to_estimate_array
from spectratac.device.link import EpochListener, FrameListener, Link
from spectratac.device.link_info import LinkInfo
from spectratac.device.model_store import ModelInfo, Progress
from spectratac.device.record_queue import OverflowPolicy, RecordQueue
from spectratac.device.records import (
    SAMPLE_TIME_INVERTED,
    SAMPLE_WINDOW_CLIPPED,
    Sample,
    Unwrapper,
    to_array,
)
from spectratac.device.stats import SensorStats
from spectratac.device.transport import DEFAULT_BAUD, Transport, open_transport
from spectratac.hardware.generated.veml3328 import INTEGRATION_MS as INTEGRATION_TIMES
from spectratac.protocol.generated import messages as m
from spectratac.protocol.schema import Message

EstimatesMode = Literal["off", "beside", "instead"]
_ESTIMATE_FLAGS: dict[str, int] = {
    "off": 0,
    "beside": m.ConfigureFlags.CONFIG_ESTIMATE,
    "instead": m.ConfigureFlags.CONFIG_ESTIMATE | m.ConfigureFlags.CONFIG_ESTIMATE_ONLY,
}
_GAINS = {1.0: m.Gain.GAIN_X1, 2.0: m.Gain.GAIN_X2, 4.0: m.Gain.GAIN_X4, 0.5: m.Gain.GAIN_X0_5}
_DG = {1: m.DigitalGain.DG_X1, 2: m.DigitalGain.DG_X2, 4: m.DigitalGain.DG_X4}


class SensorOptions(TypedDict, total=False):
    """Keyword options of Sensor.attach (and Sensor.open, which also takes `baudrate`)."""

    buffer_size: int  # samples (and estimates) held until read
    overflow: OverflowPolicy  # what a full buffer drops
    timeout: float  # s, for replies and for reads without their own
    reconnect: bool  # reopen a lost link (a new epoch)
    strict_hash: bool  # refuse a device built from other protocol definitions
    stall_timeout: float | None  # s without data while streaming; None: default_stall_timeout


#: The shortest default stall timeout, s: a loaded host may hold a healthy link's reader for
#: a second or two; a device quiet this long while it should stream is stalled.
STALL_FLOOR_S = 5.0
#: The default stall timeout is this many periods of the configured LED sequence.
STALL_PERIODS = 10


def default_stall_timeout(config: m.Configure | None, clock_scale: float | None) -> float:
    """Seconds without data after which a streaming device counts as stalled: STALL_PERIODS
    periods of one LED sequence (integration plus LED settling, per step: an estimate comes
    once per sequence), in host time (a simulated device at speed 0.1 is ten times slower),
    at least STALL_FLOOR_S.

    >>> cfg = m.Configure(integration_ms=400, led_settle_us=1000, led_step_count=8)
    >>> default_stall_timeout(cfg, None), default_stall_timeout(None, 0.1)
    (32.08, 5.0)
    """
    if config is None:
        return STALL_FLOOR_S
    step_s = config.integration_ms / 1000 + config.led_settle_us / 1e6
    period_s = step_s * max(config.led_step_count, 1) / (clock_scale or 1.0)
    return max(STALL_FLOOR_S, round(STALL_PERIODS * period_s, 6))


class Sensor:
    """A connection to one SpectraTac device. Use Sensor.open(url)."""

    def __init__(
        self,
        transport: Transport,
        *,
        buffer_size: int = 65536,
        overflow: OverflowPolicy = "drop_oldest",
        timeout: float = 2.0,
        reconnect: bool = False,
        strict_hash: bool = True,
        stall_timeout: float | None = None,
    ) -> None:
        if stall_timeout is not None and not (
            math.isfinite(stall_timeout) and 0 < stall_timeout <= 1e7
        ):
            raise ValueError(f"stall_timeout={stall_timeout}: give seconds in (0, 1e7] or None")
        if not (math.isfinite(timeout) and 0 < timeout <= 1e7):  # inf overflows a wait
            raise ValueError(f"timeout={timeout}: give seconds in (0, 1e7]")
        self.stats = SensorStats()
        self.time_sync: list[TimeSyncExchange] = []
        self._samples: RecordQueue[Sample] = RecordQueue(
            buffer_size, _samples_array, overflow=overflow, what="samples"
        )
        self._estimates: RecordQueue[EstimateRow] = RecordQueue(
            buffer_size, _estimates_array, overflow=overflow, what="estimates"
        )
        self._estimate_gaps = EstimateGaps()
        #: what the configuration in force asks of the device: "off", "beside" or "instead"
        self.estimates: EstimatesMode = "off"
        self._lock = threading.Lock()  # sequence tracking: the reader against commands
        self._unwrap = Unwrapper()
        self._last_sample_seq: int | None = None
        self._streaming = False
        # start/stop against a reconnect's resume: a STOP never lands between the resume's
        # check of `_streaming` and its START (which would restart a stream stopped here)
        self._stream_lock = threading.RLock()
        self._configure_msg: m.Configure | None = None
        self.config_id = 0
        self._link = Link(
            transport,
            stats=self.stats,
            on_data=self._on_data,
            on_lost=self._on_lost,
            on_new_epoch=self._on_new_epoch,
            on_resume=self._on_resume,
            timeout=timeout,
            reconnect=reconnect,
            strict_hash=strict_hash,
        )
        self.url = self._link.url
        #: LOG messages of the device, newest last (at most 256)
        self.logs = self._link.logs
        self._stall_timeout = stall_timeout
        self._last_data = time.monotonic()  # host time data last came (or streaming began)
        self._stall_error: DeviceStalledError | None = None
        self._closing = threading.Event()
        self._watchdog: threading.Thread | None = None

    # ------------------------------------------------------------------ opening and closing
    @classmethod
    def open(
        cls, url: str, *, baudrate: int = DEFAULT_BAUD, **options: Unpack[SensorOptions]
    ) -> Sensor:
        """Connect to `url` (serial path, socket://host:port, rfc2217://…, sim://…), read its
        INFO and check protocol version and definition hash. Options: buffer_size, overflow
        ('drop_oldest' | 'drop_newest' | 'error'), timeout (s), reconnect, strict_hash,
        stall_timeout (s; None: default_stall_timeout), baudrate."""
        return cls.attach(open_transport(url, baudrate), **options)

    @classmethod
    def attach(cls, transport: Transport, **options: Unpack[SensorOptions]) -> Sensor:
        """Like open(), over a transport you opened yourself (a custom link, or one wrapped
        for fault injection). The sensor owns it from now on and closes it."""
        try:
            sensor = cls(transport, **options)
        except BaseException:  # a bad option: the transport opened for it is closed
            transport.close()
            raise
        try:
            sensor._link.handshake()
        except BaseException:
            sensor.close()
            raise
        return sensor

    def close(self) -> None:
        """Stop reading and close the link. Safe to call more than once."""
        self._closing.set()
        watchdog = self._watchdog
        if watchdog is not None and watchdog is not threading.current_thread():
            watchdog.join(timeout=2.0)
        self._samples.close()
        self._estimates.close()
        self._link.close()

    def __enter__(self) -> Sensor:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def add_listener(self, listener: FrameListener) -> None:
        """Call `listener(frame, host_time)` from the reader for every accepted frame, before
        it is parsed into samples or replies (a recorder stores `frame.raw` verbatim).
        Keep it fast: it runs on the thread that reads the link (for serial ports and sockets
        the I/O thread all sensors of the process share). Exceptions it raises are logged and
        the listener is removed, so a broken recorder never stops the stream."""
        self._link.add_listener(listener)

    def remove_listener(self, listener: FrameListener) -> None:
        self._link.remove_listener(listener)

    def add_epoch_listener(self, listener: EpochListener) -> None:
        """Call `listener(epoch, host_time)` when a reconnect starts a new epoch, before
        any frame of the new connection reaches the frame listeners."""
        self._link.add_epoch_listener(listener)

    def remove_epoch_listener(self, listener: EpochListener) -> None:
        self._link.remove_epoch_listener(listener)

    # ------------------------------------------------------------------ properties
    @property
    def link(self) -> Link:
        """The connection: its public request API serves the model store, clock sync and
        conformance checks."""
        return self._link

    @property
    def info(self) -> m.Info:
        """The device's INFO (identity, versions, limits), read at the handshake."""
        return self._link.info

    @property
    def timeout(self) -> float:
        """Seconds to wait for a reply, and for reads given no timeout of their own."""
        return self._link.timeout

    @timeout.setter
    def timeout(self, value: float) -> None:
        self._link.timeout = value

    @property
    def stall_timeout(self) -> float:
        """Seconds without data after which a streaming device counts as stalled: the
        stall_timeout given at open, else default_stall_timeout of the configuration."""
        if self._stall_timeout is not None:
            return self._stall_timeout
        return default_stall_timeout(self._configure_msg, self.link_info.clock_scale)

    @stall_timeout.setter
    def stall_timeout(self, value: float | None) -> None:
        self._stall_timeout = value

    @property
    def epoch(self) -> int:
        """Connections so far minus one: samples and time syncs carry it (SAMPLE_RECORD)."""
        return self._link.epoch

    @property
    def link_info(self) -> LinkInfo:
        """What the link knows about itself: clock scale, a paired F/T URL, ground truth."""
        return self._link.link_info

    @property
    def auto_reconnect(self) -> bool:
        """True if opened with reconnect=True: a lost link is reopened (a new epoch)."""
        return self._link.reconnect

    @property
    def streaming(self) -> bool:
        """True from start() (or configure(stream=True)) until stop(): the host asked the
        device to stream (a reconnect resumes it)."""
        return self._streaming

    @property
    def buffered(self) -> int:
        return self._samples.buffered

    @property
    def buffered_estimates(self) -> int:
        return self._estimates.buffered

    # ------------------------------------------------------------------ commands
    def configure(
        self,
        integration_ms: int = 50,
        gain: float = 1.0,
        digital_gain: int = 1,
        sensitivity: Literal["high", "low"] = "high",
        leds: Sequence[Sequence[Sequence[int]]] | np.ndarray | None = None,
        settle_us: int = 1000,
        stream: bool = False,
        estimates: EstimatesMode = "off",
    ) -> int:
        """Validate locally, send CONFIGURE, wait for ACK; return the new configuration id.

        `leds` is a list of 1..8 steps, each 3 LEDs x (R, G, B) duties in permille (0..1000);
        default: one white step at 500 ‰. `estimates` asks a device with CAP_ESTIMATE to
        decode on board: "beside" sends an ESTIMATE after every SAMPLE, "instead" estimates
        only (read them with read_estimates). Raises ValueError naming the bad argument,
        MissingCapabilityError for estimates from a device without CAP_ESTIMATE, or
        CommandRejectedError with the device's reason (e.g. NO_MODEL, MODEL_MISMATCH).
        """
        if estimates not in _ESTIMATE_FLAGS:
            raise ValueError(f"estimates={estimates!r}: allowed 'off', 'beside' or 'instead'")
        stride = 1
        if estimates != "off":
            model_store.require(self._link, m.Capabilities.CAP_ESTIMATE, "send estimates")
            stride = self.model_info().led_steps
        if integration_ms not in INTEGRATION_TIMES:
            raise ValueError(f"integration_ms={integration_ms}: allowed {INTEGRATION_TIMES}")
        if gain not in _GAINS:
            raise ValueError(f"gain={gain}: allowed {sorted(_GAINS)}")
        if digital_gain not in _DG:
            raise ValueError(f"digital_gain={digital_gain}: allowed {sorted(_DG)}")
        if sensitivity not in ("high", "low"):
            raise ValueError(f"sensitivity={sensitivity!r}: allowed 'high' or 'low'")
        duties = np.full((1, 3, 3), 500) if leds is None else np.asarray(leds)
        if duties.ndim != 3 or duties.shape[1:] != (3, 3) or not 1 <= len(duties) <= 8:
            raise ValueError(
                f"leds has shape {duties.shape}: give 1..8 steps of 3 LEDs x (R, G, B) duties"
            )
        if not np.issubdtype(duties.dtype, np.integer) or duties.min() < 0 or duties.max() > 1000:
            raise ValueError("leds: duties must be integers in permille, 0..1000")
        table = np.zeros((m.MAX_LED_STEPS, 3, 3), dtype=int)
        table[: len(duties)] = duties
        msg = m.Configure(
            integration_ms=integration_ms,
            gain=int(_GAINS[gain]),
            digital_gain=int(_DG[digital_gain]),
            sensitivity=0 if sensitivity == "high" else 1,
            flags=(m.ConfigureFlags.CONFIG_STREAM if stream else 0) | _ESTIMATE_FLAGS[estimates],
            led_settle_us=settle_us,
            led_step_count=len(duties),
            led_duty=tuple(tuple(tuple(int(v) for v in led) for led in step) for step in table),
        )
        ack = self._link.command(msg)
        self._configure_msg = msg
        self.config_id = ack.config_id
        self.estimates = estimates
        with self._lock:
            self._estimate_gaps.restart(stride)
        if stream:
            self._streaming = True
            self._watch_stalls()
        return ack.config_id

    def start(self) -> None:
        """Start streaming; samples then arrive in the buffer."""
        with self._stream_lock:
            if not self._streaming:
                # a new stream counts from sample_seq 0 (SPEC): a lost first sample is a gap
                with self._lock:
                    self._last_sample_seq = -1
                    self._estimate_gaps.restart()
            self._link.command(m.Start())
            self._streaming = True
            self._watch_stalls()

    def stop(self) -> None:
        """Stop streaming; no sample is produced after the device's acknowledgement.
        Idempotent: it always asks the device (a device may stream although the host
        thinks it stopped), and a reconnect never restarts a stream stopped here (a resume
        under way finishes first)."""
        with self._stream_lock:
            self._streaming = False
            self._link.command(m.Stop())

    def status(self) -> m.Status:
        """The device's STATUS: its counters, state and health."""
        return self._link.request(m.GetStatus(), m.Status)

    def get_config(self) -> m.Config:
        """The configuration in force on the device (CONFIG)."""
        return self._link.request(m.GetConfig(), m.Config)

    def reset_stats(self) -> None:
        """Zero the device's STATUS counters."""
        self._link.command(m.ResetStats())

    def sync_clock(self, exchanges: int = 8) -> ClockSync:
        """Run TIME_SYNC exchanges; keep the one with the shortest round trip (least queuing).
        Every exchange is also appended to `time_sync`."""
        sync = sync_clock(self._link, self._unwrap_device_time, exchanges)
        self.time_sync.extend(sync.exchanges)
        return sync

    # ------------------------------------------------------------------ model store (1.1)
    def model_info(self) -> ModelInfo:
        """The model the device decodes with and its limits (GET_MODEL). Raises
        MissingCapabilityError for a device without CAP_ESTIMATE."""
        return model_store.read_info(self._link)

    def upload_model(
        self, image: bytes, model_id: int, progress: Progress | None = None
    ) -> ModelInfo:
        """Upload a model image (`spectratac.decode.export.model_image.encode(decoder)`) as
        `model_id` into the device's flash, in acknowledged chunks of 224 B; `progress(done,
        total)` is called after each. On a NACK or a timeout the upload is restarted from
        MODEL_BEGIN once. Returns the device's MODEL_INFO afterwards. Raises
        MissingCapabilityError (no CAP_MODEL_UPLOAD) or ModelUploadError carrying the NACK's
        error name and what to do."""
        model_store.upload(self._link, image, model_id, progress)
        return self.model_info()

    def tare(self) -> None:
        """Zero the on-device model's drift baseline on its next sample (TARE, protocol 1.3):
        call it while nothing touches the skin. MissingCapabilityError for an older device."""
        model_store.tare(self._link)

    def clear_model(self) -> None:
        """Erase the uploaded model; a built-in one, if the firmware has one, takes over."""
        model_store.clear(self._link)

    # ------------------------------------------------------------------ service (1.4)
    def enter_bootloader(self) -> None:
        """Restart the device in its ROM DFU bootloader (ENTER_BOOTLOADER, protocol 1.4), for
        flashing a new firmware without BOOT0; the device leaves the link: close the sensor
        afterwards. MissingCapabilityError for a device without CAP_BOOTLOADER."""
        maintenance.enter_bootloader(self._link)

    def debug_fault(self, kind: m.FaultKind) -> None:
        """Make a test image fault or hang (DEBUG_FAULT, protocol 1.4); after its reset STATUS
        reports the cause (boot_report). MissingCapabilityError for a release image."""
        maintenance.debug_fault(self._link, kind)

    def boot_report(self) -> BootReport:
        """How the device came up: reset cause, fault record, safe mode, brown-out level,
        measured erase and TRIG times (STATUS, protocol 1.4)."""
        return BootReport.from_status(self.status(), self.info.protocol_minor)

    def request_raw(
        self,
        type_id: int,
        payload: bytes,
        accepts: tuple[int, ...] = (m.Ack.TYPE_ID, m.Nack.TYPE_ID),
        version: tuple[int, int] = (m.PROTOCOL_MAJOR, m.PROTOCOL_MINOR),
        timeout: float | None = None,
    ) -> Message:
        """Send a frame with any type, payload and version, unvalidated, and return the reply
        within `timeout` s (default: the sensor's), for conformance tests and debugging.
        ACK/NACK replies are matched by sequence (Link.request_raw)."""
        return self._link.request_raw(type_id, payload, accepts, version, timeout)

    def write_raw(self, data: bytes) -> None:
        """Put arbitrary bytes on the link (e.g. garbage, to test the device's recovery)."""
        self._link.write(data)

    # ------------------------------------------------------------------ samples and estimates
    def read(self, n: int, timeout: float | None = None) -> np.ndarray:
        """Up to `n` samples as a SAMPLE_RECORD array, waiting up to `timeout` s (default:
        the sensor's timeout) for all n. Returns fewer on timeout. Raises DisconnectedError
        (DeviceStalledError after a stall) only once every sample received before the loss
        has been read."""
        return self._samples.read(n, self.timeout if timeout is None else timeout)

    def read_estimates(self, n: int, timeout: float | None = None) -> np.ndarray:
        """Up to `n` on-device estimates as ESTIMATE_RECORD rows, waiting up to `timeout` s
        (default: the sensor's timeout) for all n; fewer on timeout. Like read(), it raises
        DisconnectedError only once every estimate received before a loss has been read."""
        return self._estimates.read(n, self.timeout if timeout is None else timeout)

    def iter_estimates(self) -> Iterator[EstimateRow]:
        """On-device estimates one by one until the link is lost or the sensor closed; after
        a stall, every estimate received before it, then DeviceStalledError."""
        yield from self._estimates
        if self._stall_error is not None and not self._closing.is_set():
            raise self._stall_error

    def __iter__(self) -> Iterator[Sample]:
        """Samples one by one until the link is lost or the sensor closed; after a stall,
        every sample received before it, then DeviceStalledError (a wait that ends)."""
        yield from self._samples
        if self._stall_error is not None and not self._closing.is_set():
            raise self._stall_error

    # ------------------------------------------------------------------ the stall watch
    def _watch_stalls(self) -> None:
        """Start the stall watch (once): from now on `_last_data` is the stream's last sign."""
        self._last_data = time.monotonic()
        if self._watchdog is None:
            self._watchdog = threading.Thread(
                target=self._stall_watch, name="spectratac-stall-watch", daemon=True
            )
            self._watchdog.start()

    def _stall_watch(self) -> None:
        strikes = 0
        while True:
            limit = self.stall_timeout
            if self._closing.wait(min(1.0, max(0.05, limit / 10))):
                return
            quiet = time.monotonic() - self._last_data
            if not self._streaming or self._link.closed or quiet <= limit:
                strikes = 0
                continue
            strikes += 1
            if strikes < 2:  # seen twice: a starved host lets the reader catch up first
                continue
            strikes = 0
            self._last_data = time.monotonic()  # one stall at a time; a reopened link anew
            self.stats.stalls += 1
            option = "--stall-timeout S (Python: stall_timeout=S)"
            error = DeviceStalledError(
                f"{self.url} sent no data for {quiet:.1f} s while streaming (stall timeout "
                f"{limit:g} s): the device or its link stalled; what came before is kept. Check "
                f"the device and cable, or allow a longer quiet with {option}"
            )
            if not self._link.reconnect:
                self._stall_error = error
            self._link.stall(error)

    # ------------------------------------------------------------------ the link's callbacks
    def _unwrap_device_time(self, t32: int) -> int:
        return self._unwrap(t32)

    def _on_data(self, messages: list[Message], now: float, epoch: int) -> None:
        """SAMPLE and ESTIMATE messages of one chunk read (on the reader thread)."""
        self._last_data = now
        samples: list[Sample] = []
        estimates: list[EstimateRow] = []
        for msg in messages:
            if isinstance(msg, m.Sample):
                samples.append(self._to_sample(msg, now, epoch))
            elif isinstance(msg, m.Estimate):
                estimates.append(self._to_estimate(msg, now, epoch))
        if samples:
            self.stats.buffer_overflows += self._samples.put(samples)
        if estimates:
            self.stats.estimate_overflows += self._estimates.put(estimates)

    def _to_sample(self, msg: m.Sample, now: float, epoch: int) -> Sample:
        st = self.stats
        st.samples_received += 1
        last = self._last_sample_seq
        if last is not None and msg.sample_seq > last + 1:
            st.sample_gaps += msg.sample_seq - last - 1
        self._last_sample_seq = msg.sample_seq
        end = self._unwrap(msg.t_end_us)
        span = (msg.t_end_us - msg.t_start_us) & 0xFFFF_FFFF
        flags = 0
        if span >= 0x8000_0000:  # start after end: no real integration is half a wrap long
            flags, span = SAMPLE_TIME_INVERTED, 0
        elif span > end:
            flags, span = SAMPLE_WINDOW_CLIPPED, end
        if flags:
            st.sample_time_errors += 1
        start = end - span
        return Sample(
            end,
            start,
            now,
            msg.sample_seq,
            msg.led_step,
            msg.config_id,
            msg.counts,
            msg.sensor_status,
            epoch,
            flags,
        )

    def _to_estimate(self, msg: m.Estimate, now: float, epoch: int) -> EstimateRow:
        self.stats.estimates_received += 1
        with self._lock:
            self._estimate_gaps.see(msg.sample_seq)
            self.stats.estimate_gaps = self._estimate_gaps.lost
        return EstimateRow(
            self._unwrap(msg.t_end_us),
            now,
            msg.sample_seq,
            msg.config_id,
            msg.model_id,
            msg.flags,
            msg.force,
            msg.torque,
            msg.region,
            msg.region_prob,
            msg.decode_us,
            epoch,
        )

    def _on_lost(self, error: DeviceError) -> None:
        """The link is gone for good: readers get `error` once the queues are drained."""
        self._samples.fail(error)
        self._estimates.fail(error)

    def _on_new_epoch(self) -> None:
        """A new connection: the device may have restarted, so its clock and sequence
        numbers start afresh."""
        with self._lock:
            self._unwrap = Unwrapper()
            self._last_sample_seq = None
            self._estimate_gaps.restart()
        self._last_data = time.monotonic()  # a new link has its own stall timeout

    def _on_resume(self) -> None:
        """After a reconnect's handshake: restore configuration and streaming. A device that
        is not streaming (it restarted) counts its resumed stream from sample_seq 0, so a lost
        first sample is a gap, as after start(); one that streamed on continues its count."""
        with self._stream_lock:
            if self._streaming and not self._link.request(m.GetStatus(), m.Status).streaming:
                with self._lock:
                    self._last_sample_seq = -1
            if self._configure_msg is not None:
                self.config_id = self._link.command(self._configure_msg).config_id
            if self._streaming:
                self._link.command(m.Start())
                self._last_data = time.monotonic()


def _samples_array(batches: list[Sequence[Sample]]) -> np.ndarray:
    return to_array([sample for batch in batches for sample in batch])


def _estimates_array(batches: list[Sequence[EstimateRow]]) -> np.ndarray:
    return to_estimate_array([row for batch in batches for row in batch])
