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

The link is read in the background: serial ports, ptys and sockets by the process's one
shared I/O thread (spectratac.device.iohub, a selector over every link), other links (sim://,
rfc2217://, wrapped transports) by a thread of their own. Frames are decoded and samples put
into a bounded buffer; replies to commands are matched by the command's sequence number.
Every public method is thread-safe.
"""

from __future__ import annotations

import collections
import contextlib
import dataclasses
import functools
import logging
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np

from spectratac.device import model_store
from spectratac.device.errors import (
    BufferOverflowError,
    CommandRejectedError,
    DeviceError,
    DeviceTimeoutError,
    DisconnectedError,
    ProtocolMismatchError,
)
from spectratac.device.estimate_records import EstimateGaps, EstimateRow, to_estimate_array
from spectratac.device.iohub import Link, shared_hub
from spectratac.device.link_info import LinkInfo, link_info_of
from spectratac.device.model_store import ModelInfo, Progress
from spectratac.device.records import (
    SAMPLE_TIME_INVERTED,
    SAMPLE_WINDOW_CLIPPED,
    Sample,
    Unwrapper,
    to_array,
)
from spectratac.device.transport import Transport, open_transport
from spectratac.errors import printable
from spectratac.hardware.veml3328 import INTEGRATION_MS as INTEGRATION_TIMES
from spectratac.protocol import Frame, StreamDecoder, encode_frame, encode_raw
from spectratac.protocol import messages as m
from spectratac.protocol.schema import Message
from spectratac.protocol.versions import expected_definition_hash

log = logging.getLogger("spectratac.device")

OverflowPolicy = Literal["drop_oldest", "drop_newest", "error"]
EstimatesMode = Literal["off", "beside", "instead"]
_ESTIMATE_FLAGS: dict[str, int] = {
    "off": 0,
    "beside": m.ConfigureFlags.CONFIG_ESTIMATE,
    "instead": m.ConfigureFlags.CONFIG_ESTIMATE | m.ConfigureFlags.CONFIG_ESTIMATE_ONLY,
}
FrameListener = Callable[[Frame, float], None]  # (accepted frame, host receive time)
EpochListener = Callable[[int, float], None]  # (new epoch, host time of the reconnect)
_GAINS = {1.0: m.Gain.GAIN_X1, 2.0: m.Gain.GAIN_X2, 4.0: m.Gain.GAIN_X4, 0.5: m.Gain.GAIN_X0_5}
_DG = {1: m.DigitalGain.DG_X1, 2: m.DigitalGain.DG_X2, 4: m.DigitalGain.DG_X4}


@dataclass
class SensorStats:
    """Link health as seen by the host."""

    frames_received: int = 0
    samples_received: int = 0
    crc_errors: int = 0
    cobs_errors: int = 0
    other_frame_errors: int = 0  # too short, oversize, unknown type, short payload
    frame_gaps: int = 0  # frames missing by the device's frame sequence numbers
    sample_gaps: int = 0  # samples missing by SAMPLE.sample_seq
    buffer_overflows: int = 0  # samples discarded by the overflow policy
    reconnects: int = 0
    logs: int = 0
    sample_time_errors: int = 0  # samples flagged SAMPLE_TIME_INVERTED or _WINDOW_CLIPPED
    version_mismatches: int = 0  # frames of another protocol major version, dropped
    command_retries: int = 0  # commands sent a second time after no reply
    estimates_received: int = 0  # ESTIMATE frames (protocol 1.1)
    estimate_gaps: int = 0  # estimates missing by ESTIMATE.sample_seq
    estimate_overflows: int = 0  # estimates discarded by the overflow policy
    model_upload_retries: int = 0  # model uploads restarted from MODEL_BEGIN

    def as_dict(self) -> dict[str, int]:
        return dict(self.__dict__)


@dataclass(frozen=True)
class TimeSyncExchange:
    """One TIME_SYNC round trip: host clock (s, monotonic) and device clock (µs, unwrapped)."""

    host_sent: float
    device_rx_us: int
    device_tx_us: int
    host_received: float
    epoch: int = 0  # the sensor's connection epoch the device times belong to

    @property
    def round_trip(self) -> float:
        return self.host_received - self.host_sent

    @property
    def offset(self) -> float:
        """device time − host time in seconds, assuming a symmetric link (NTP)."""
        device_mid = (self.device_rx_us + self.device_tx_us) / 2e6
        return device_mid - (self.host_sent + self.host_received) / 2


@dataclass(frozen=True)
class ClockSync:
    offset: float  # device − host seconds, from the exchange with the shortest round trip
    round_trip: float
    exchanges: tuple[TimeSyncExchange, ...] = field(repr=False)


@dataclass
class _Waiter:
    accepts: tuple[int, ...]  # reply type ids this waiter takes
    seqs: set[int] | None  # command seqs (one per attempt) an ACK/NACK may name
    event: threading.Event = field(default_factory=threading.Event)
    reply: Message | None = None
    host_time: float = 0.0
    mismatches: int = 0  # frames of another major seen before it was sent


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
    ) -> None:
        if overflow not in ("drop_oldest", "drop_newest", "error"):
            raise ValueError(
                f"overflow={overflow!r}: choose 'drop_oldest', 'drop_newest' or 'error'"
            )
        if buffer_size < 1:
            raise ValueError(f"buffer_size={buffer_size}: must be at least 1")
        self.url = transport.url
        self.timeout = timeout
        self.stats = SensorStats()
        self.logs: collections.deque[m.Log] = collections.deque(maxlen=256)
        self.time_sync: list[TimeSyncExchange] = []
        self._transport = transport
        self._reconnect = reconnect
        self._strict_hash = strict_hash
        self._overflow = overflow
        self._buffer: collections.deque[Sample] = collections.deque()
        self._estimates: collections.deque[EstimateRow] = collections.deque()
        self._estimate_gaps = EstimateGaps()
        self._estimates_overflowed = False
        #: what the configuration in force asks of the device: "off", "beside" or "instead"
        self.estimates: EstimatesMode = "off"
        self._buffer_size = buffer_size
        self._overflowed = False
        self._cond = threading.Condition()
        self._write_lock = threading.Lock()
        self._decoder = StreamDecoder()
        self._seq = 0
        self._waiters: list[_Waiter] = []
        self._unwrap = Unwrapper()
        self._last_sample_seq: int | None = None
        #: connections so far minus one: samples and time syncs carry it (see SAMPLE_RECORD)
        self.epoch = 0
        self._mismatches_seen = 0  # frames of another major so far (the decoder counts them)
        self._closed = False
        self._lost: DeviceError | None = None
        self._streaming = False
        self._configure_msg: m.Configure | None = None
        self.info: m.Info = m.Info()
        self.config_id = 0
        self._listeners: list[FrameListener] = []
        self._epoch_listeners: list[EpochListener] = []
        # Reader state; _link_lock orders link changes (reconnect) against close().
        self._link_lock = threading.Lock()
        self._link: Link | None = None  # on the shared I/O thread
        self._thread: threading.Thread | None = None  # a reader of its own
        self._reconnector: threading.Thread | None = None
        self._closing = threading.Event()
        self._start_reader()

    # ------------------------------------------------------------------ opening and closing
    @classmethod
    def open(cls, url: str, **options: Any) -> Sensor:
        """Connect to `url` (serial path, socket://host:port, rfc2217://…, sim://…), read its
        INFO and check protocol version and definition hash. Options: buffer_size, overflow
        ('drop_oldest' | 'drop_newest' | 'error'), timeout (s), reconnect, strict_hash,
        baudrate."""
        baudrate = options.pop("baudrate", 921_600)
        return cls.attach(open_transport(url, baudrate), **options)

    @classmethod
    def attach(cls, transport: Transport, **options: Any) -> Sensor:
        """Like open(), over a transport you opened yourself (a custom link, or one wrapped
        for fault injection). The sensor owns it from now on and closes it."""
        sensor = cls(transport, **options)
        try:
            sensor._handshake()
        except BaseException:
            sensor.close()
            raise
        return sensor

    def _handshake(self) -> None:
        self._write(b"\x00")  # ends any partial frame the device holds from earlier garbage
        # Ask again every 0.5 s within the timeout: a board that is still booting (or reset
        # by opening its port) loses what it receives before its UART is up.
        deadline = time.monotonic() + self.timeout
        while True:
            remaining = deadline - time.monotonic()
            try:
                info = self._request(
                    m.GetInfo(), (m.Info.TYPE_ID,), timeout=min(0.5, remaining), attempts=1
                )
                break
            except DeviceTimeoutError:
                if deadline - time.monotonic() <= 0:
                    raise DeviceTimeoutError(
                        f"no reply to GET_INFO from {self.url} within {self.timeout:.1f} s: is "
                        f"the device powered, running SpectraTac firmware, and on this "
                        f"port/baud rate?"
                    ) from None
        assert isinstance(info, m.Info)
        host = (m.PROTOCOL_MAJOR, m.PROTOCOL_MINOR)
        device = (info.protocol_major, info.protocol_minor)
        if info.protocol_major != m.PROTOCOL_MAJOR:
            raise ProtocolMismatchError(
                f"{self.url} speaks protocol {device[0]}.{device[1]}, this host library "
                f"{host[0]}.{host[1]}: update the library or reflash the firmware",
                device,
                host,
            )
        # compare with the hash of the device's own minor version; a newer one is a superset
        expected = expected_definition_hash(info.protocol_minor)
        if expected is not None and info.definition_hash != expected:
            text = (
                f"{self.url} was built from other protocol definitions (hash "
                f"0x{info.definition_hash:08X}, protocol {device[0]}.{device[1]} has "
                f"0x{expected:08X}): rebuild firmware and host from one checkout"
            )
            if self._strict_hash:
                raise ProtocolMismatchError(text, device, host)
            log.warning(text)
        self.info = _printable_info(info)

    def close(self) -> None:
        """Stop reading and close the link. Safe to call more than once."""
        with self._cond:
            if self._closed:
                return
            self._closed = True
            self._cond.notify_all()
        self._closing.set()
        with self._link_lock:
            link, self._link = self._link, None
            transport = self._transport
            threads = (self._thread, self._reconnector)
        if link is not None:
            link.close()  # no callback of it runs after this (unless we are inside one)
        transport.close()
        for thread in threads:
            if thread is not None and thread is not threading.current_thread():
                thread.join(timeout=2.0)
        for waiter in self._take_waiters():
            waiter.event.set()

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
        self._listeners = [*self._listeners, listener]

    def remove_listener(self, listener: FrameListener) -> None:
        self._listeners = [x for x in self._listeners if x is not listener]

    def add_epoch_listener(self, listener: EpochListener) -> None:
        """Call `listener(epoch, host_time)` when a reconnect starts a new epoch, before
        any frame of the new connection reaches the frame listeners."""
        self._epoch_listeners = [*self._epoch_listeners, listener]

    def remove_epoch_listener(self, listener: EpochListener) -> None:
        self._epoch_listeners = [x for x in self._epoch_listeners if x is not listener]

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
            model_store.require(self, m.Capabilities.CAP_ESTIMATE, "send estimates")
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
        ack = self._command(msg)
        self._configure_msg = msg
        self.config_id = ack.config_id
        self.estimates = estimates
        with self._cond:
            self._estimate_gaps.restart(stride)
        if stream:
            self._streaming = True
        return ack.config_id

    def start(self) -> None:
        """Start streaming; samples then arrive in the buffer."""
        if not self._streaming:
            # a new stream counts from sample_seq 0 (SPEC): a lost first sample is a gap too
            with self._cond:
                self._last_sample_seq = -1
                self._estimate_gaps.restart()
        self._command(m.Start())
        self._streaming = True

    def stop(self) -> None:
        """Stop streaming; no sample is produced after the device's acknowledgement.
        Idempotent: it always asks the device (a device may stream although the host
        thinks it stopped), and a reconnect never restarts a stream stopped here."""
        self._streaming = False
        self._command(m.Stop())

    def status(self) -> m.Status:
        reply = self._request(m.GetStatus(), (m.Status.TYPE_ID,))
        assert isinstance(reply, m.Status)
        return reply

    def get_config(self) -> m.Config:
        reply = self._request(m.GetConfig(), (m.Config.TYPE_ID,))
        assert isinstance(reply, m.Config)
        return reply

    def reset_stats(self) -> None:
        self._command(m.ResetStats())

    def sync_clock(self, exchanges: int = 8) -> ClockSync:
        """Run TIME_SYNC exchanges; keep the one with the shortest round trip (least queuing)."""
        done: list[TimeSyncExchange] = []
        for i in range(exchanges):
            sent = time.monotonic()
            reply = self._request(  # not resent: a resend would void the timestamps
                m.TimeSyncRequest(exchange_id=i, host_time_ns=int(sent * 1e9)),
                (m.TimeSyncReply.TYPE_ID,),
                attempts=1,
            )
            assert isinstance(reply, m.TimeSyncReply)
            received = self._last_reply_time
            rx = self._unwrap_like(reply.device_rx_us)
            done.append(
                TimeSyncExchange(
                    sent,
                    rx,
                    rx + ((reply.device_tx_us - reply.device_rx_us) & 0xFFFF_FFFF),
                    received,
                    self.epoch,
                )
            )
        self.time_sync.extend(done)
        best = min(done, key=lambda e: e.round_trip)
        return ClockSync(best.offset, best.round_trip, tuple(done))

    # ------------------------------------------------------------------ model store (1.1)
    def model_info(self) -> ModelInfo:
        """The model the device decodes with and its limits (GET_MODEL). Raises
        MissingCapabilityError for a device without CAP_ESTIMATE."""
        return model_store.read_info(self)

    def upload_model(
        self, image: bytes, model_id: int, progress: Progress | None = None
    ) -> ModelInfo:
        """Upload a model image (`spectratac.decode.export.model_image.encode(decoder)`) as
        `model_id` into the device's flash, in acknowledged chunks of 224 B; `progress(done,
        total)` is called after each. On a NACK or a timeout the upload is restarted from
        MODEL_BEGIN once. Returns the device's MODEL_INFO afterwards. Raises
        MissingCapabilityError (no CAP_MODEL_UPLOAD) or ModelUploadError carrying the NACK's
        error name and what to do."""
        model_store.upload(self, image, model_id, progress)
        return self.model_info()

    def clear_model(self) -> None:
        """Erase the uploaded model; a built-in one, if the firmware has one, takes over."""
        model_store.clear(self)

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
        ACK/NACK replies are matched by sequence."""
        with self._write_lock:
            seq = self._next_seq()
            match = m.Ack.TYPE_ID in accepts or m.Nack.TYPE_ID in accepts
            waiter = _Waiter(accepts, {seq} if match else None)
            with self._cond:
                self._waiters.append(waiter)
            self._transport.write(b"\x00" + encode_raw(type_id, payload, seq, version))
        return self._await(waiter, f"frame type 0x{type_id:02X}", timeout)

    def write_raw(self, data: bytes) -> None:
        """Put arbitrary bytes on the link (e.g. garbage, to test the device's recovery)."""
        self._write(data)

    # ------------------------------------------------------------------ samples
    def _take(
        self, queue: collections.deque, n: int, timeout: float | None, flag: str, what: str
    ) -> list[Any]:
        """Up to `n` rows popped from `queue` (the caller holds self._cond), waiting up to
        `timeout` s for all n. `flag` names the attribute that says rows of this queue were
        discarded; with overflow="error" that raises BufferOverflowError if nothing was read.
        Raises the loss only once every row received before it has been read."""
        deadline = time.monotonic() + (self.timeout if timeout is None else timeout)
        out: list[Any] = []
        while True:
            while queue and len(out) < n:
                out.append(queue.popleft())
            if len(out) >= n:
                break
            if getattr(self, flag) and self._overflow == "error":
                setattr(self, flag, False)
                if not out:
                    count = (
                        self.stats.buffer_overflows
                        if what == "samples"
                        else (self.stats.estimate_overflows)
                    )
                    raise BufferOverflowError(
                        f"{count} {what} were discarded: read more often or open with a "
                        f"larger buffer_size"
                    )
                break
            if self._lost is not None and not self._reconnect:
                if out:
                    break
                raise self._lost
            if self._closed:
                break
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                break
            self._cond.wait(remaining)
        return out

    def read(self, n: int, timeout: float | None = None) -> np.ndarray:
        """Up to `n` samples as a SAMPLE_RECORD array, waiting up to `timeout` s (default:
        the sensor's timeout) for all n. Returns fewer on timeout. Raises DisconnectedError
        only once every sample received before the loss has been read."""
        with self._cond:
            out = self._take(self._buffer, n, timeout, "_overflowed", "samples")
            try:
                return to_array(out)
            except (OverflowError, ValueError):
                self._buffer.extendleft(reversed(out))  # nothing received is lost
                raise

    def read_estimates(self, n: int, timeout: float | None = None) -> np.ndarray:
        """Up to `n` on-device estimates as ESTIMATE_RECORD rows, waiting up to `timeout` s
        (default: the sensor's timeout) for all n; fewer on timeout. Like read(), it raises
        DisconnectedError only once every estimate received before a loss has been read."""
        with self._cond:
            out = self._take(self._estimates, n, timeout, "_estimates_overflowed", "estimates")
        return to_estimate_array(out)

    def iter_estimates(self) -> Iterator[EstimateRow]:
        """On-device estimates one by one until the link is lost or the sensor closed."""
        while True:
            with self._cond:
                while not self._estimates:
                    if self._lost is not None and not self._reconnect:
                        return
                    if self._closed:
                        return
                    self._cond.wait(0.5)
                row = self._estimates.popleft()
            yield row

    @property
    def buffered_estimates(self) -> int:
        with self._cond:
            return len(self._estimates)

    def __iter__(self) -> Iterator[Sample]:
        """Samples one by one until the link is lost or the sensor closed."""
        while True:
            with self._cond:
                while not self._buffer:
                    if self._lost is not None and not self._reconnect:
                        return
                    if self._closed:
                        return
                    self._cond.wait(0.5)
                sample = self._buffer.popleft()
            yield sample

    @property
    def link_info(self) -> LinkInfo:
        """What the link knows about itself: clock scale, a paired F/T URL, ground truth."""
        return link_info_of(self._transport)

    @property
    def auto_reconnect(self) -> bool:
        """True if opened with reconnect=True: a lost link is reopened (a new epoch)."""
        return self._reconnect

    @property
    def buffered(self) -> int:
        with self._cond:
            return len(self._buffer)

    # ------------------------------------------------------------------ internals
    def _next_seq(self) -> int:
        self._seq = (self._seq + 1) & 0xFFFF
        return self._seq

    def _write(self, data: bytes) -> None:
        if self._lost is not None:
            raise self._lost
        with self._write_lock:
            self._transport.write(data)

    def _command(self, msg: Message, attempts: int = 2, timeout: float | None = None) -> m.Ack:
        reply = self._request(
            msg, (m.Ack.TYPE_ID, m.Nack.TYPE_ID), True, timeout=timeout, attempts=attempts
        )
        if isinstance(reply, m.Nack):
            code = m.Error(reply.error) if reply.error in m.Error._value2member_map_ else None
            meaning, action = (
                m.ERROR_TEXT.get(code, ("unknown error code", ""))
                if code
                else ("unknown error code", "Update the host library.")
            )
            raise CommandRejectedError(
                msg.NAME, reply.error, code.name if code else "?", meaning, action
            )
        assert isinstance(reply, m.Ack)
        return reply

    def _request(
        self,
        msg: Message,
        accepts: tuple[int, ...],
        match_seq: bool = False,
        timeout: float | None = None,
        attempts: int = 2,
    ) -> Message:
        """Send `msg` and wait for its reply; with no reply within `timeout`, send it once
        more (`attempts` = 2) with a new seq. Every frame starts with 0x00 so that stray
        bytes on the line end there instead of swallowing the command. A reply to either
        attempt counts (the first one may only have been late)."""
        msg.validate()
        waiter = _Waiter(accepts, set() if match_seq else None, mismatches=self._mismatches_seen)
        for attempt in range(attempts):
            self._send_for(waiter, msg)
            if attempt:
                self.stats.command_retries += 1
            reply = self._await(waiter, msg.NAME, timeout, last=attempt == attempts - 1)
            if reply is not None:
                return reply
        raise AssertionError("unreachable: the last attempt raises or returns")

    def _send_for(self, waiter: _Waiter, msg: Message) -> None:
        with self._write_lock:  # one seq per frame, in order on the wire
            seq = self._next_seq()
            with self._cond:
                if self._lost is not None and not self._reconnect:
                    raise self._lost
                if waiter.seqs is not None:
                    waiter.seqs.add(seq)
                if waiter not in self._waiters:
                    self._waiters.append(waiter)
            try:
                self._transport.write(b"\x00" + encode_frame(msg, seq, validate=False))
            except DisconnectedError:
                self._drop_waiter(waiter)
                raise

    def _await(
        self, waiter: _Waiter, what: str, timeout: float | None = None, last: bool = True
    ) -> Message | None:
        """The reply; None if none came in time and this was not the `last` attempt."""
        timeout = self.timeout if timeout is None else timeout
        if not waiter.event.wait(timeout):
            if self._lost is not None:
                self._drop_waiter(waiter)
                raise self._lost
            remote = self._decoder.stats.remote_version
            if self._mismatches_seen > waiter.mismatches and remote is not None:
                self._drop_waiter(waiter)  # the reply may have come in another major version
                host = (m.PROTOCOL_MAJOR, m.PROTOCOL_MINOR)
                raise ProtocolMismatchError(
                    f"{self.url} speaks protocol {remote[0]}.{remote[1]}, this host library "
                    f"{host[0]}.{host[1]}: update the library or reflash the firmware",
                    remote,
                    host,
                )
            if not last:
                return None
            self._drop_waiter(waiter)
            tries = "" if waiter.seqs is None or len(waiter.seqs) < 2 else " (sent twice)"
            raise DeviceTimeoutError(
                f"no reply to {what}{tries} from {self.url} within {timeout:.1f} s: is the "
                f"device powered, running SpectraTac firmware, and on this port/baud rate?"
            )
        if waiter.reply is None:
            raise self._lost or DisconnectedError(f"{self.url} was closed")
        self._last_reply_time = waiter.host_time
        return waiter.reply

    def _drop_waiter(self, waiter: _Waiter) -> None:
        with self._cond:
            if waiter in self._waiters:
                self._waiters.remove(waiter)

    def _take_waiters(self) -> list[_Waiter]:
        with self._cond:
            waiters, self._waiters = self._waiters, []
        return waiters

    def _unwrap_like(self, t32: int) -> int:
        return self._unwrap(t32)

    def _start_reader(self) -> None:
        """Read the current transport: from the shared I/O thread when it has a descriptor,
        else from a thread of its own. Called at construction and after a reconnect."""
        transport = self._transport
        fileno = getattr(transport, "fileno", None)
        fd = fileno() if callable(fileno) else None
        if fd is not None:
            lost = functools.partial(self._link_lost, transport)
            self._link = shared_hub().add(fd, self._dispatch, lost, self.url)
        else:
            self._thread = threading.Thread(
                target=self._reader, args=(transport,), name="spectratac-reader", daemon=True
            )
            self._thread.start()

    def _reader(self, transport: Transport) -> None:
        while not self._closed:
            try:
                data = transport.read(0.05)
            except DisconnectedError as exc:
                if not self._closed:
                    self._handle_loss(exc, transport)
                return
            if data:
                self._dispatch(data, time.monotonic())

    def _link_lost(self, transport: Transport, exc: OSError) -> None:
        """The I/O thread saw EOF or a read error on our descriptor (it dropped the link)."""
        if not self._closed:
            self._handle_loss(DisconnectedError(f"lost the link to {self.url}: {exc}"), transport)

    def _dispatch(self, data: bytes, now: float) -> None:
        frames = self._decoder.feed(data)
        d = self._decoder.stats
        st = self.stats
        st.crc_errors, st.cobs_errors = d.bad_crc, d.bad_cobs
        st.other_frame_errors = d.too_short + d.oversize + d.unknown_type + d.short_payload
        st.frame_gaps = d.seq_gaps
        # counted, not fatal: a command that then gets no reply raises ProtocolMismatchError
        st.version_mismatches = self._mismatches_seen = d.version_mismatch
        samples: list[Sample] = []
        estimates: list[EstimateRow] = []
        for listener in self._listeners:
            try:
                for frame in frames:
                    listener(frame, now)
            except Exception:
                log.exception("%s: frame listener %r failed; removed", self.url, listener)
                self.remove_listener(listener)
        for frame in frames:
            st.frames_received += 1
            msg = frame.message
            if isinstance(msg, m.Sample):
                samples.append(self._to_sample(msg, now))
            elif isinstance(msg, m.Estimate):
                estimates.append(self._to_estimate(msg, now))
            elif isinstance(msg, m.Log):
                st.logs += 1
                msg = dataclasses.replace(msg, text=printable(msg.text))
                self.logs.append(msg)
                log.log(10 + 10 * min(msg.level, 3), "%s: %s", self.url, msg.text)
            else:
                self._deliver(msg, now)
        if samples:
            self._enqueue(samples)
        if estimates:
            self._enqueue_estimates(estimates)

    def _to_sample(self, msg: m.Sample, now: float) -> Sample:
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
            self.epoch,
            flags,
        )

    def _to_estimate(self, msg: m.Estimate, now: float) -> EstimateRow:
        self.stats.estimates_received += 1
        with self._cond:
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
            self.epoch,
        )

    def _enqueue_estimates(self, rows: list[EstimateRow]) -> None:
        with self._cond:
            buf = self._estimates
            for row in rows:
                if len(buf) >= self._buffer_size:
                    self.stats.estimate_overflows += 1
                    self._estimates_overflowed = True
                    if self._overflow == "drop_oldest":
                        buf.popleft()
                    else:
                        continue
                buf.append(row)
            self._cond.notify_all()

    def _enqueue(self, samples: list[Sample]) -> None:
        with self._cond:
            buf = self._buffer
            for sample in samples:
                if len(buf) >= self._buffer_size:
                    self.stats.buffer_overflows += 1
                    self._overflowed = True
                    if self._overflow == "drop_oldest":
                        buf.popleft()
                    else:
                        continue  # drop_newest and error keep what is already buffered
                buf.append(sample)
            self._cond.notify_all()

    def _deliver(self, msg: Message, now: float) -> None:
        with self._cond:
            for waiter in self._waiters:
                if msg.TYPE_ID not in waiter.accepts:
                    continue
                if waiter.seqs is not None:
                    named = (
                        msg.acked_seq
                        if isinstance(msg, m.Ack)
                        else getattr(msg, "rejected_seq", None)
                    )
                    if named not in waiter.seqs:
                        continue
                waiter.reply, waiter.host_time = msg, now
                self._waiters.remove(waiter)
                waiter.event.set()
                return
        if isinstance(msg, m.Nack):
            log.warning("%s: unsolicited NACK %s", self.url, msg)

    def _handle_loss(self, exc: DisconnectedError, transport: Transport) -> None:
        """Record the loss (readers see it once the buffer is drained); with reconnect=True
        keep reopening the link from another thread until it is back or the sensor closed."""
        with self._cond:
            self._lost = exc
            self._cond.notify_all()
        for waiter in self._take_waiters():
            waiter.event.set()
        if not self._reconnect:
            return
        with self._link_lock:
            if self._closed:
                return
            self._link = None
            self._reconnector = threading.Thread(
                target=self._reconnect_loop, args=(transport,), name="spectratac-reconnect"
            )
            self._reconnector.daemon = True
            self._reconnector.start()

    def _reconnect_loop(self, lost: Transport) -> None:
        with contextlib.suppress(Exception):
            lost.close()  # release the dead link's descriptor
        delay = 0.05
        while not self._closing.wait(delay):
            delay = min(delay * 2, 1.0)
            try:
                transport = open_transport(self.url)
            except Exception:  # the device is still away: keep trying until close()
                continue
            with self._link_lock:
                if self._closed:
                    transport.close()
                    return
                self._transport = transport
                self._new_epoch()
                self._lost = None
                self.stats.reconnects += 1
                self._start_reader()
            self._resume()
            return

    def _new_epoch(self) -> None:
        """A new connection: the device may have restarted, so its clock and sequence
        numbers start afresh; forget the old ones and tell listeners (a recorder marks it)."""
        self._decoder.reset()  # keeps its counts: link health adds up over epochs
        with self._cond:
            self._unwrap = Unwrapper()
            self._last_sample_seq = None
            self._estimate_gaps.restart()
            self.epoch += 1
        for listener in self._epoch_listeners:
            try:
                listener(self.epoch, time.monotonic())
            except Exception:
                log.exception("%s: epoch listener %r failed; removed", self.url, listener)
                self.remove_epoch_listener(listener)

    def _resume(self) -> None:
        """After a reconnect: handshake again and restore configuration and streaming."""
        try:
            self._handshake()
            if self._configure_msg is not None:
                self.config_id = self._command(self._configure_msg).config_id
            if self._streaming:
                self._command(m.Start())
        except Exception as exc:  # the reader reports the next loss; log why resuming failed
            log.warning("%s: resuming after reconnect failed: %s", self.url, exc)


def _printable_info(info: m.Info) -> m.Info:
    """INFO with its text fields made safe to print (a device names itself)."""
    text = {f.name: printable(getattr(info, f.name)) for f in info.FIELDS if f.type == "char"}
    return dataclasses.replace(info, **text)
