"""`Link`: one connection to a SpectraTac device: its transport, the reader, the request table,
the handshake and reconnects. `Sensor` builds its API on a Link; the model store, clock sync
and conformance checks talk to the device through its public request API.

The link is read in the background: serial ports, ptys and sockets by the process's one
shared I/O thread (spectratac.device.iohub, a selector over every link), other links (sim://,
rfc2217://, wrapped transports) by a thread of their own. Frames are decoded; replies are
matched to the request waiting for them (ACK/NACK by the command's sequence number, other
replies by type), LOG frames are kept, and SAMPLE and ESTIMATE frames go to the owner's
`on_data`. Every public method is thread-safe.
"""

from __future__ import annotations

import collections
import contextlib
import dataclasses
import functools
import itertools
import logging
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TypeVar

from spectratac.device import handshake
from spectratac.device.errors import (
    CommandRejectedError,
    DeviceError,
    DeviceTimeoutError,
    DisconnectedError,
    ProtocolMismatchError,
)
from spectratac.device.iohub import Watch, shared_hub
from spectratac.device.link_info import LinkInfo, link_info_of
from spectratac.device.stats import SensorStats
from spectratac.device.transport import Transport, open_transport
from spectratac.errors import printable
from spectratac.protocol import Frame, StreamDecoder, encode_frame, encode_raw
from spectratac.protocol.generated import messages as m
from spectratac.protocol.schema import Message

log = logging.getLogger("spectratac.device")

R = TypeVar("R", bound=Message)
FrameListener = Callable[[Frame, float], None]  # (accepted frame, host receive time)
EpochListener = Callable[[int, float], None]  # (new epoch, host time of the reconnect)
#: SAMPLE and ESTIMATE messages of one chunk read (split at the replies among them), its host
#: time, the epoch they belong to
DataHandler = Callable[[list[Message], float, int], None]
#: Messages the device sends unasked; every other message is a reply to a request.
DATA_MESSAGES = (m.Sample, m.Estimate)
ACK_NACK = (m.Ack.TYPE_ID, m.Nack.TYPE_ID)


@dataclass
class _Waiter:
    accepts: tuple[int, ...]  # reply type ids this waiter takes
    seqs: set[int] | None  # command seqs (one per attempt) an ACK/NACK may name
    event: threading.Event = field(default_factory=threading.Event)
    reply: Message | None = None
    host_time: float = 0.0
    mismatches: int = 0  # frames of another major seen before it was sent


class Link:
    """The connection to one device over `transport` (owned and closed by the link).

    `on_data(messages, host_time, epoch)` receives the SAMPLE and ESTIMATE messages of each chunk
    read, on the reader thread, each before any reply that followed it on the wire is
    delivered. With `reconnect`, a lost link is reopened from the URL
    until it is back or closed: `on_new_epoch()` runs before the new connection is read,
    `on_resume()` after its handshake (to restore configuration and streaming). Without it,
    `on_lost(error)` tells the owner the link is gone for good.
    """

    def __init__(
        self,
        transport: Transport,
        *,
        stats: SensorStats,
        on_data: DataHandler,
        on_lost: Callable[[DeviceError], None],
        on_new_epoch: Callable[[], None],
        on_resume: Callable[[], None],
        timeout: float = 2.0,
        reconnect: bool = False,
        strict_hash: bool = True,
    ) -> None:
        self.url = transport.url
        self.timeout = timeout
        self.stats = stats
        self.reconnect = reconnect
        self.strict_hash = strict_hash
        #: INFO of the device, text fields made printable (set by handshake())
        self.info: m.Info = m.Info()
        #: connections so far minus one: samples and time syncs carry it (see SAMPLE_RECORD)
        self.epoch = 0
        self.logs: collections.deque[m.Log] = collections.deque(maxlen=256)
        self._on_data = on_data
        self._on_lost = on_lost
        self._on_new_epoch = on_new_epoch
        self._on_resume = on_resume
        self._transport = transport
        self._decoder = StreamDecoder()
        self._seq = 0
        self._waiters: list[_Waiter] = []
        self._lock = threading.Lock()  # the request table and the loss
        self._write_lock = threading.Lock()  # one seq per frame, in order on the wire
        self._mismatches_seen = 0  # frames of another major so far (the decoder counts them)
        self._lost: DeviceError | None = None
        self._closed = False
        self._listeners: list[FrameListener] = []
        self._epoch_listeners: list[EpochListener] = []
        # Reader state; _link_lock orders link changes (reconnect) against close().
        self._link_lock = threading.Lock()
        self._watch: Watch | None = None  # on the shared I/O thread
        self._thread: threading.Thread | None = None  # a reader of its own
        self._reconnector: threading.Thread | None = None
        self._abandoned: Transport | None = None  # dropped after a stall: its reader stops
        self._closing = threading.Event()
        self._start_reader()

    # ------------------------------------------------------------------ requests
    def request(
        self, msg: Message, expect: type[R], *, timeout: float | None = None, attempts: int = 2
    ) -> R:
        """Send `msg` and return its reply, the next `expect` message, within `timeout` s
        (default: the link's); with no reply in time, send it once more (`attempts` = 2).
        Raises DeviceTimeoutError, DisconnectedError or ProtocolMismatchError."""
        return self.request_at(msg, expect, timeout=timeout, attempts=attempts)[0]

    def request_at(
        self, msg: Message, expect: type[R], *, timeout: float | None = None, attempts: int = 2
    ) -> tuple[R, float]:
        """Like request(), with the host time (time.monotonic()) the reply was read at."""
        reply, host_time = self._exchange(msg, (expect.TYPE_ID,), False, timeout, attempts)
        assert isinstance(reply, expect)
        return reply, host_time

    def command(self, msg: Message, *, attempts: int = 2, timeout: float | None = None) -> m.Ack:
        """Send a command and wait for the ACK or NACK naming it (like request()). Raises
        CommandRejectedError with the device's reason on a NACK."""
        reply, _ = self._exchange(msg, ACK_NACK, True, timeout, attempts)
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

    def request_raw(
        self,
        type_id: int,
        payload: bytes,
        accepts: tuple[int, ...] = ACK_NACK,
        version: tuple[int, int] = (m.PROTOCOL_MAJOR, m.PROTOCOL_MINOR),
        timeout: float | None = None,
    ) -> Message:
        """Send a frame with any type, payload and version, unvalidated, and return the reply
        within `timeout` s (default: the link's), for conformance tests and debugging.
        ACK/NACK replies are matched by sequence."""
        with self._write_lock:
            seq = self._next_seq()
            match = m.Ack.TYPE_ID in accepts or m.Nack.TYPE_ID in accepts
            waiter = _Waiter(accepts, {seq} if match else None)
            with self._lock:
                self._waiters.append(waiter)
            self._transport.write(b"\x00" + encode_raw(type_id, payload, seq, version))
        reply = self._await(waiter, f"frame type 0x{type_id:02X}", timeout)
        assert reply is not None  # the only attempt raises instead
        return reply

    def write(self, data: bytes) -> None:
        """Put bytes on the link as they are (e.g. garbage, to test the device's recovery)."""
        if self._lost is not None:
            raise self._lost
        with self._write_lock:
            self._transport.write(data)

    def handshake(self) -> m.Info:
        """Read the device's INFO and check protocol version and definition hash (a hash
        mismatch only warns unless `strict_hash`; spectratac.device.handshake); sets and
        returns `info`."""
        self.info = handshake.read_info(self)
        return self.info

    # ------------------------------------------------------------------ listeners
    def add_listener(self, listener: FrameListener) -> None:
        """Call `listener(frame, host_time)` from the reader for every accepted frame."""
        self._listeners = [*self._listeners, listener]

    def remove_listener(self, listener: FrameListener) -> None:
        self._listeners = [x for x in self._listeners if x is not listener]

    def add_epoch_listener(self, listener: EpochListener) -> None:
        """Call `listener(epoch, host_time)` when a reconnect starts a new epoch."""
        self._epoch_listeners = [*self._epoch_listeners, listener]

    def remove_epoch_listener(self, listener: EpochListener) -> None:
        self._epoch_listeners = [x for x in self._epoch_listeners if x is not listener]

    # ------------------------------------------------------------------ closing
    def close(self) -> None:
        """Stop reading, close the transport, release waiting requests. Idempotent."""
        with self._lock:
            if self._closed:
                return
            self._closed = True
        self._closing.set()
        with self._link_lock:
            watch, self._watch = self._watch, None
            transport = self._transport
            threads = (self._thread, self._reconnector)
        if watch is not None:
            watch.close()  # no callback of it runs after this (unless we are inside one)
        transport.close()
        for thread in threads:
            if thread is not None and thread is not threading.current_thread():
                thread.join(timeout=2.0)
        for waiter in self._take_waiters():
            waiter.event.set()

    @property
    def closed(self) -> bool:
        return self._closed

    @property
    def link_info(self) -> LinkInfo:
        """What the current transport knows about itself: clock scale, a paired F/T URL,
        ground truth (the defaults of hardware when it says nothing)."""
        return link_info_of(self._transport)

    # ------------------------------------------------------------------ the request table
    def _next_seq(self) -> int:
        self._seq = (self._seq + 1) & 0xFFFF
        return self._seq

    def _exchange(
        self,
        msg: Message,
        accepts: tuple[int, ...],
        match_seq: bool,
        timeout: float | None,
        attempts: int,
    ) -> tuple[Message, float]:
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
                return reply, waiter.host_time
        raise AssertionError("unreachable: the last attempt raises or returns")

    def _send_for(self, waiter: _Waiter, msg: Message) -> None:
        with self._write_lock:
            seq = self._next_seq()
            with self._lock:
                if self._lost is not None and not self.reconnect:
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
        return waiter.reply

    def _drop_waiter(self, waiter: _Waiter) -> None:
        with self._lock:
            if waiter in self._waiters:
                self._waiters.remove(waiter)

    def _take_waiters(self) -> list[_Waiter]:
        with self._lock:
            waiters, self._waiters = self._waiters, []
        return waiters

    def _deliver(self, msg: Message, now: float) -> None:
        with self._lock:
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

    # ------------------------------------------------------------------ reading
    def _start_reader(self) -> None:
        """Read the current transport: from the shared I/O thread when it has a descriptor,
        else from a thread of its own. Called at construction and after a reconnect."""
        transport = self._transport
        fileno = getattr(transport, "fileno", None)
        fd = fileno() if callable(fileno) else None
        if fd is not None:
            lost = functools.partial(self._watch_lost, transport)
            self._watch = shared_hub().add(fd, self._dispatch, lost, self.url)
        else:
            self._thread = threading.Thread(
                target=self._reader, args=(transport,), name="spectratac-reader", daemon=True
            )
            self._thread.start()

    def _reader(self, transport: Transport) -> None:
        while not self._closed and transport is not self._abandoned:
            try:
                data = transport.read(0.05)
            except DisconnectedError as exc:
                if not self._closed and transport is not self._abandoned:
                    self._handle_loss(exc, transport)
                return
            if data and transport is not self._abandoned:
                self._dispatch(data, time.monotonic())

    def _watch_lost(self, transport: Transport, exc: OSError) -> None:
        """The I/O thread saw EOF or a read error on our descriptor (it dropped the link)."""
        if not self._closed and transport is not self._abandoned:
            self._handle_loss(DisconnectedError(f"lost the link to {self.url}: {exc}"), transport)

    def _dispatch(self, data: bytes, now: float) -> None:
        frames = self._decoder.feed(data)
        d = self._decoder.stats
        st = self.stats
        st.crc_errors, st.cobs_errors = d.bad_crc, d.bad_cobs
        st.other_frame_errors = d.too_short + d.oversize + d.unknown_type + d.short_payload
        st.frame_gaps = d.seq_gaps
        # counted, not fatal: a request that then gets no reply raises ProtocolMismatchError
        st.version_mismatches = self._mismatches_seen = d.version_mismatch
        for listener in self._listeners:
            try:
                for frame in frames:
                    listener(frame, now)
            except Exception:
                log.exception("%s: frame listener %r failed; removed", self.url, listener)
                self.remove_listener(listener)
        data_messages: list[Message] = []
        for frame in frames:
            st.frames_received += 1
            msg = frame.message
            if isinstance(msg, DATA_MESSAGES):
                data_messages.append(msg)
            elif isinstance(msg, m.Log):
                st.logs += 1
                msg = dataclasses.replace(msg, text=printable(msg.text))
                self.logs.append(msg)
                log.log(10 + 10 * min(msg.level, 3), "%s: %s", self.url, msg.text)
            else:
                # the data sent before a reply reaches the owner before the reply wakes its
                # caller: one woken by STOP's ACK finds every earlier sample already buffered,
                # however late a loaded host ran this thread (wire order, not host timing)
                if data_messages:
                    self._on_data(data_messages, now, self.epoch)
                    data_messages = []
                self._deliver(msg, now)
        if data_messages:
            self._on_data(data_messages, now, self.epoch)

    # ------------------------------------------------------------------ losing and reconnecting
    def stall(self, exc: DisconnectedError) -> None:
        """The device went quiet while it should stream (the owner's stall watch): drop the
        transport as if it were lost, so nothing waits for it any longer; with reconnect it
        is reopened (a new epoch), else the owner gets `exc` (on_lost). Ignored once the
        link is closed or already lost."""
        with self._link_lock:
            if self._closed or self._lost is not None:
                return
            transport, self._abandoned = self._transport, self._transport
            watch, self._watch = self._watch, None
        if watch is not None:
            watch.close()
        if not self.reconnect:  # the reconnect loop closes it itself
            with contextlib.suppress(Exception):
                transport.close()
        self._handle_loss(exc, transport)

    def _handle_loss(self, exc: DisconnectedError, transport: Transport) -> None:
        """Record the loss; with reconnect keep reopening the link from another thread until
        it is back or the link closed, else tell the owner."""
        with self._lock:
            self._lost = exc
        for waiter in self._take_waiters():
            waiter.event.set()
        if not self.reconnect:
            self._on_lost(exc)
            return
        with self._link_lock:
            if self._closed:
                return
            self._watch = None
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
            self._resume(transport)
            return

    def _new_epoch(self) -> None:
        """A new connection: the device may have restarted, so its clock and sequence
        numbers start afresh; the owner forgets the old ones, listeners are told (a recorder
        marks it)."""
        self._decoder.reset()  # keeps its counts: link health adds up over epochs
        self._on_new_epoch()
        self.epoch += 1
        for listener in self._epoch_listeners:
            try:
                listener(self.epoch, time.monotonic())
            except Exception:
                log.exception("%s: epoch listener %r failed; removed", self.url, listener)
                self.remove_epoch_listener(listener)

    def _resume(self, transport: Transport) -> None:
        """After a reconnect: handshake again, then the owner restores its state. A reply
        that does not come (a loaded host, a damaged frame) is asked again while the link
        stays up: given up, the device would never stream again and nothing would say so.
        A loss meanwhile ends it (that loss's reconnect resumes); another failure (a refusal)
        is logged and the link stays as it is."""
        delay = 0.1
        for attempt in itertools.count():
            try:
                self.handshake()
                self._on_resume()
                return
            except DeviceTimeoutError as exc:
                if self._closed or self._lost is not None or self._transport is not transport:
                    return
                if attempt == 0:  # one line, not one per attempt
                    log.warning("%s: resuming after reconnect: %s; asking again", self.url, exc)
            except Exception as exc:
                if not (self._closed or self._lost is not None):
                    log.warning("%s: resuming after reconnect failed: %s", self.url, exc)
                return
            if self._closing.wait(delay):
                return
            delay = min(delay * 2, 2.0)
