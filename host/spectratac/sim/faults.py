"""Faulty simulated devices: a layer between the firmware core and its host link that makes
the device misbehave in one chosen way, selected with ``fault=`` in a sim:// URL.

    spectratac conformance "sim://?fault=late_stop"        # "stop really stops" fails
    Sensor.open("sim://?seed=3&speed=max&fault=corrupt&fault_rate=1e-4")

Each conformance fault breaks exactly one conformance check (tests/conformance); the link
faults (``corrupt``, ``stall``) damage the link the way a bad cable or a busy USB hub does.
Several faults combine with commas: ``fault=corrupt,stall``. Every layer counts what the
device really sent in `ledger(url)`, summed over every device booted behind that URL in this
process (a replug boots a new one), so a test can check that nothing vanished unaccounted.

>>> from spectratac.device import Sensor
>>> with Sensor.open("sim://?fault=bad_info") as s:
...     s.info.max_frame > m.MAX_FRAME
True
>>> ledger("sim://?fault=bad_info").frames_sent > 0
True
"""

from __future__ import annotations

import dataclasses
import random
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass

from cobs import cobs

from spectratac.protocol import encode_raw
from spectratac.protocol.framing import FrameError, decode_frame
from spectratac.protocol.generated import messages as m

#: conformance faults: name -> what the device does wrong (and the check that notices)
CONFORMANCE_FAULTS = {
    "wrong_hash": "INFO names another definition hash (handshake)",
    "bad_info": "INFO claims frames longer than the protocol allows (info limits)",
    "stale_config": "CONFIG echoes another config_id than the CONFIGURE ACK (configure ack)",
    "wrong_nack_field": "NACKs name the wrong field (invalid configurations refused)",
    "silent_unknown": "unknown message types get no NACK (unknown type refused)",
    "fast_clock": "the device clock runs 10 % fast (sample rate)",
    "short_window": "SAMPLE integration windows are 40 % too short (continuity and time)",
    "sync_jitter": "every other TIME_SYNC reply is stamped 50 ms early (time-sync round trip)",
    "no_rx_errors": "STATUS never counts receive errors (recovery after garbage)",
    "late_stop": "STOP is acknowledged at once but streaming goes on for 0.4 s of device time "
    "(stop really stops)",
    "flag_fault": "sensor 0 is flagged as a bus fault although present (sensor status)",
    # on-device decoding (protocol 1.1; spectratac.conformance.model_checks)
    "bad_model_info": "MODEL_INFO reports max_hidden 0 (model info)",
    "accept_large_model": "MODEL_TOO_LARGE refusals arrive as ACK (model larger than the store)",
    "accept_bad_chunk": "MODEL_BAD_CHUNK refusals arrive as ACK (model chunk out of order)",
    "accept_bad_crc": "MODEL_BAD_CRC refusals arrive as ACK (model with a bad CRC)",
    "accept_bad_model": "MODEL_INVALID refusals arrive as ACK (damaged model)",
    "wrong_model_crc": "MODEL_INFO names another CRC than the stored model's (upload round trip)",
    "estimate_skew": "ESTIMATE names the next sample's sample_seq (estimates beside samples)",
    "ignore_estimate_only": "CONFIG_ESTIMATE_ONLY is ignored: samples keep coming (estimates "
    "instead of samples)",
    "volatile_model": "a model uploaded before a reset is gone after it (model survives a reset)",
    "sticky_model": "MODEL_CLEAR is acknowledged but not carried out (model clear)",
    "begin_erases": "every MODEL_BEGIN erases the installed model first, even one it refuses "
    "(refused MODEL_BEGIN changes nothing)",
}
#: bring-up faults: a board built wrongly, which `spectratac bringup` must catch
BRINGUP_FAULTS = {
    "swapped_led": "LED 0's red and blue PWM pins are crossed: its red duty drives blue and its "
    "blue duty red (bring-up's LED channels)",
    "hsi_clock": "STATUS reports a 16 MHz core clock, the HSI fallback (bring-up's clock)",
    "hsi_pll_clock": "the crystal failed and the PLL runs from the internal RC: STATUS reports "
    "96 MHz and the boot LOG names the fallback (bring-up's clock)",
    "bor_off": "STATUS reports brown-out level 0, the option byte's default (bring-up's "
    "brown-out level)",
    "lost_fault_record": "STATUS never reports a fault record, as if .noinit RAM were cleared "
    "at boot (bring-up's fault record)",
}
#: the bring-up faults that rewrite STATUS
STATUS_FAULTS = frozenset({"hsi_clock", "hsi_pll_clock", "bor_off", "lost_fault_record"})
#: the boot LOG line of firmware whose crystal failed (clock_note in ports/stm32f411/clock.c)
HSI_PLL_NOTE = "clock HSI+PLL 96MHz (crystal failed): no USB, UART +0.16%"
#: the 1.1 faults that turn a NACK of the device into an ACK: fault -> the error it hides
ACCEPTS = {
    "accept_large_model": m.Error.MODEL_TOO_LARGE,
    "accept_bad_chunk": m.Error.MODEL_BAD_CHUNK,
    "accept_bad_crc": m.Error.MODEL_BAD_CRC,
    "accept_bad_model": m.Error.MODEL_INVALID,
}
MODEL_INFO_FAULTS = frozenset({"bad_model_info", "wrong_model_crc", "volatile_model"})
#: faults that change what the host sends before the device sees it
HOST_SIDE = frozenset(
    {
        "late_stop",
        "ignore_estimate_only",
        "volatile_model",
        "sticky_model",
        "begin_erases",
        "swapped_led",
    }
)
#: header seq of the MODEL_CLEAR a begin_erases device runs on its own (its ACK is not sent)
HIDDEN_CLEAR_SEQ = 0xFFFF
#: link faults: damage on the wire, not a protocol violation
LINK_FAULTS = {
    "none": "no fault; only count what the device sends",
    "corrupt": "flip random bits in bytes sent to the host (fault_rate per byte, 1e-4)",
    "stall": "hold the device's output for fault_stall s (0.2) every fault_every s (2) of "
    "host time, from its first sample (a device that stalls streams first)",
    "unplug": "unplug the device after a random time (mean fault_unplug s, 20, of device "
    "time); the next open boots a fresh one",
}
FAULTS = CONFORMANCE_FAULTS | BRINGUP_FAULTS | LINK_FAULTS
SYNC_JITTER_US = 50_000  # how far a sync_jitter device's odd replies are off
#: how long a late_stop device streams on after acknowledging STOP, on its own clock (host
#: time would make the fault, and so the check that catches it, depend on the host's load)
LATE_STOP_US = 400_000


@dataclass
class Ledger:
    """What devices behind one URL really sent (before any damage), and the damage done."""

    frames_sent: int = 0
    samples_sent: int = 0
    bytes_corrupted: int = 0
    frames_corrupted: int = 0
    stalls: int = 0
    unplugs: int = 0
    boots: int = 0
    #: samples corrupted after the last intact one when the device was unplugged: no later
    #: sample tells the host they existed, so no host can count them
    samples_lost_at_unplug: int = 0
    paused: bool = False  # the test bench stopped injecting faults (to end cleanly)

    def as_dict(self) -> dict[str, int | bool]:
        return dataclasses.asdict(self)


_LEDGERS: dict[str, Ledger] = {}
_LEDGERS_LOCK = threading.Lock()


def ledger(url: str) -> Ledger:
    """The running totals of every faulty device opened with exactly `url` in this process."""
    with _LEDGERS_LOCK:
        return _LEDGERS.setdefault(url, Ledger())


def parse_faults(value: str) -> tuple[str, ...]:
    """``corrupt,stall`` -> ('corrupt', 'stall'); raises ValueError naming the known faults."""
    names = tuple(n for n in value.split(",") if n)
    unknown = [n for n in names if n not in FAULTS]
    if unknown:
        raise ValueError(f"unknown fault {', '.join(unknown)}; choose from {', '.join(FAULTS)}")
    return names


HostSink = Callable[[bytes, int], bool]
DeviceSink = Callable[[bytes], None]


class FaultLayer:
    """Sits on the device's UART: `from_device` replaces its transmit sink, `from_host` the
    host's writes. `to_host`/`to_device` are the healthy paths behind it."""

    def __init__(
        self,
        url: str,
        faults: tuple[str, ...],
        params: dict[str, str],
        seed: int,
        to_host: HostSink,
        to_device: DeviceSink,
        unplug: Callable[[], None] = lambda: None,
    ) -> None:
        self.faults = frozenset(faults)
        self.ledger = ledger(url)
        self.ledger.boots += 1
        self.rate = float(params.get("fault_rate", "1e-4"))
        self.stall_s = float(params.get("fault_stall", "0.2"))
        self.stall_every = float(params.get("fault_every", "2"))
        self._to_host = to_host
        self._to_device = to_device
        self._unplug = unplug
        self._rng = random.Random(seed * 7919 + self.ledger.boots)  # each boot its own faults
        mean_unplug_us = float(params.get("fault_unplug", "20")) * 1e6
        self._unplug_after_us = int(self._rng.expovariate(1 / mean_unplug_us))
        self._unplug_at_us: int | None = None  # counted from the boot's first frame
        self._unplugged = False
        self._tail_corrupted = 0  # sample frames lost on the wire since the last intact one
        # the last frame's closing 0x00 was flipped: the host reads the next frame as part of
        # it, so that one is lost too however intact its own bytes
        self._merges_next = False
        self._pending = b""  # device bytes of a frame not yet complete
        self._rewrites = bool(self.faults & (CONFORMANCE_FAULTS.keys() | STATUS_FAULTS))
        self._next_stall: float | None = None  # set by the first sample
        self._closed = threading.Event()
        # late_stop: the STOP and every host byte after it, held until device time _stop_due_us
        self._held_stop: bytearray | None = None
        self._stop_due_us: int | None = None
        self._stop_lock = threading.Lock()
        self._streaming = False  # late_stop: a START reached the device after the last STOP
        self._uploading = False  # volatile_model: the host began an upload in this boot
        self._boot_logged = False  # hsi_pll_clock: the boot LOG went out before the first reply

    # --- device -> host ----------------------------------------------------------------------
    def from_device(self, data: bytes, t: int) -> bool:
        active = not self.ledger.paused
        if self._unplugged:
            return False
        if self._unplug_at_us is None:
            self._unplug_at_us = t + self._unplug_after_us  # device clocks of a shared world
        if active and "unplug" in self.faults and t >= self._unplug_at_us:
            self._unplugged = True
            self.ledger.unplugs += 1
            self.ledger.samples_lost_at_unplug += self._tail_corrupted
            self._unplug()
            return False  # the cable is out: nothing more reaches the host
        *frames, self._pending = (self._pending + data).split(b"\x00")
        if "late_stop" in self.faults:
            self._release_stop_at(t)
        out = bytearray()
        for encoded in frames:
            is_sample = self._count(encoded)
            if is_sample and self._next_stall is None:
                self._next_stall = time.monotonic() + self.stall_every
            wire = self._rewrite(encoded) if self._rewrites else encoded + b"\x00"
            if wire is None:
                continue
            merged, self._merges_next = self._merges_next, False
            hit = False
            if active and "corrupt" in self.faults:
                damaged = self._corrupt(wire)
                hit, wire = damaged != wire, damaged
                self._merges_next = not wire.endswith(b"\x00")
            if is_sample:
                self._tail_corrupted = self._tail_corrupted + 1 if hit or merged else 0
            out += wire
        if not out:
            return True
        due = self._next_stall is not None and time.monotonic() >= self._next_stall
        if active and "stall" in self.faults and due:
            self.ledger.stalls += 1
            self._closed.wait(self.stall_s)  # the link holds everything; the device waits
            self._next_stall = time.monotonic() + self.stall_every
        return self._to_host(bytes(out), t)

    def _count(self, encoded: bytes) -> bool:
        """Count a frame the device sent; True if it carries a sample."""
        self.ledger.frames_sent += 1
        try:
            raw = cobs.decode(encoded)
        except cobs.DecodeError:
            return False
        if len(raw) > 2 and raw[2] == m.Sample.TYPE_ID:
            self.ledger.samples_sent += 1
            return True
        return False

    def _corrupt(self, wire: bytes) -> bytes:
        """Flip bits at `rate` per byte (the gaps between flips are geometric: one draw per
        flip, not one per byte)."""
        rng, out, hits = self._rng, bytearray(wire), 0
        i = int(rng.expovariate(self.rate)) if self.rate > 0 else len(out)
        while i < len(out):
            out[i] ^= 1 << rng.randrange(8)
            hits += 1
            i += 1 + int(rng.expovariate(self.rate))
        if hits:
            self.ledger.bytes_corrupted += hits
            self.ledger.frames_corrupted += 1
        return bytes(out)

    def _rewrite(self, encoded: bytes) -> bytes | None:
        """The frame as the faulty device sends it, or None if it sends nothing; the boot
        LOG of an hsi_pll_clock device goes before its first frame, as the firmware's does."""
        wire = self._rewrite_one(encoded)
        if "hsi_pll_clock" not in self.faults or self._boot_logged:
            return wire
        self._boot_logged = True
        try:
            frame = decode_frame(encoded)
        except FrameError:
            return wire
        log = m.Log(level=m.LogLevel.LOG_WARN, text=HSI_PLL_NOTE)
        # the seq before the first frame's: the host counts no frame missing
        first = encode_raw(log.TYPE_ID, log.pack(), (frame.seq - 1) & 0xFFFF, frame.version)
        return first + (wire or b"")

    def _rewrite_one(self, encoded: bytes) -> bytes | None:
        try:
            frame = decode_frame(encoded)
        except FrameError:
            return encoded + b"\x00"
        msg, f = frame.message, self.faults
        if isinstance(msg, m.Info) and "wrong_hash" in f:
            msg = dataclasses.replace(msg, definition_hash=msg.definition_hash ^ 0x1)
        elif isinstance(msg, m.Info) and "bad_info" in f:
            msg = dataclasses.replace(msg, max_frame=m.MAX_FRAME + 1)
        elif isinstance(msg, m.Config) and "stale_config" in f:
            msg = dataclasses.replace(msg, config_id=(msg.config_id + 1) & 0xFFFF)
        elif isinstance(msg, m.Nack) and "wrong_nack_field" in f:
            msg = dataclasses.replace(msg, field_index=(msg.field_index + 1) & 0xFF)
        elif isinstance(msg, m.Nack) and "silent_unknown" in f:
            if msg.error == m.Error.UNKNOWN_TYPE:
                return None
        elif isinstance(msg, m.Sample) and "fast_clock" in f:
            msg = dataclasses.replace(
                msg,
                t_start_us=msg.t_start_us * 11 // 10 & 0xFFFF_FFFF,
                t_end_us=msg.t_end_us * 11 // 10 & 0xFFFF_FFFF,
            )
        elif isinstance(msg, m.Estimate) and "fast_clock" in f:  # the same clock as SAMPLE's
            msg = dataclasses.replace(msg, t_end_us=msg.t_end_us * 11 // 10 & 0xFFFF_FFFF)
        elif isinstance(msg, m.Sample) and "short_window" in f:
            width = (msg.t_end_us - msg.t_start_us) & 0xFFFF_FFFF
            msg = dataclasses.replace(
                msg, t_start_us=(msg.t_end_us - width * 6 // 10) & 0xFFFF_FFFF
            )
        elif isinstance(msg, m.Sample) and "flag_fault" in f:
            status = (msg.sensor_status[0] | m.SensorStatus.SENSOR_BUS_FAULT,)
            msg = dataclasses.replace(msg, sensor_status=status + msg.sensor_status[1:])
        elif isinstance(msg, m.TimeSyncReply) and "sync_jitter" in f:
            early = SYNC_JITTER_US * (msg.exchange_id & 1)
            msg = dataclasses.replace(
                msg,
                device_rx_us=(msg.device_rx_us - early) & 0xFFFF_FFFF,
                device_tx_us=(msg.device_tx_us - early) & 0xFFFF_FFFF,
            )
        elif isinstance(msg, m.Status) and "no_rx_errors" in f:
            msg = dataclasses.replace(msg, rx_errors=0)
        elif isinstance(msg, m.Status) and f & STATUS_FAULTS:
            msg = _status_fault(msg, f)
        elif isinstance(msg, m.Ack) and "begin_erases" in f and msg.acked_seq == HIDDEN_CLEAR_SEQ:
            return None
        elif isinstance(msg, m.Nack) and any(ACCEPTS[a] == msg.error for a in f & ACCEPTS.keys()):
            msg = m.Ack(acked_type=msg.rejected_type, acked_seq=msg.rejected_seq)
        elif isinstance(msg, m.ModelInfo) and f & MODEL_INFO_FAULTS:
            msg = _model_info_fault(msg, f, self._uploading)
        elif isinstance(msg, m.Estimate) and "estimate_skew" in f:
            msg = dataclasses.replace(msg, sample_seq=(msg.sample_seq + 1) & 0xFFFF_FFFF)
        else:
            return encoded + b"\x00"
        return encode_raw(msg.TYPE_ID, msg.pack(), frame.seq, frame.version)

    # --- host -> device ----------------------------------------------------------------------
    def from_host(self, data: bytes) -> None:
        if not self.faults & HOST_SIDE:
            self._to_device(data)
            return
        with self._stop_lock:
            if self._held_stop is not None:  # the device reads nothing newer before the STOP
                self._held_stop += data
                return
        out = bytearray()
        *frames, tail = data.split(b"\x00")
        for i, encoded in enumerate(frames):
            stop = self._stop_to_hold(encoded) if "late_stop" in self.faults else None
            if stop is None:
                out += self._host_frame(encoded)
                continue
            self._to_device(bytes(out))
            self._hold_stop(stop, b"\x00".join(frames[i:]) + b"\x00" + tail)
            return
        self._to_device(bytes(out) + tail)

    def _host_frame(self, encoded: bytes) -> bytes:
        """A host frame as the faulty device takes it (with its 0x00), or b"" if it drops it."""
        try:
            frame = decode_frame(encoded)
        except FrameError:
            return encoded + b"\x00"
        msg = frame.message
        if isinstance(msg, m.ModelBegin):
            self._uploading = True
            if "begin_erases" in self.faults:  # as firmware that invalidates before checking
                clear = encode_raw(m.ModelClear.TYPE_ID, b"", HIDDEN_CLEAR_SEQ, frame.version)
                return clear + encoded + b"\x00"
        if isinstance(msg, m.ModelClear) and "sticky_model" in self.faults:
            self._ack(msg.TYPE_ID, frame.seq)
            return b""
        if isinstance(msg, m.Configure) and "swapped_led" in self.faults:
            return _crossed(msg, frame.seq, frame.version)
        only = m.ConfigureFlags.CONFIG_ESTIMATE_ONLY
        if (
            isinstance(msg, m.Configure)
            and "ignore_estimate_only" in self.faults
            and msg.flags & only
        ):
            msg = dataclasses.replace(msg, flags=msg.flags & ~only)
            return encode_raw(msg.TYPE_ID, msg.pack(), frame.seq, frame.version)
        return encoded + b"\x00"

    def _ack(self, type_id: int, seq: int) -> None:
        ack = m.Ack(acked_type=type_id, acked_seq=seq, config_id=0)
        self._to_host(
            encode_raw(m.Ack.TYPE_ID, ack.pack(), 0, (m.PROTOCOL_MAJOR, m.PROTOCOL_MINOR)), 0
        )

    def _stop_to_hold(self, encoded: bytes) -> int | None:
        """The seq of a STOP that ends a stream (the late_stop device holds it), else None.
        Whether the device streams is followed on the commands the host sends, in order: a
        STOP held while the device was idle would never see the device's clock move on."""
        try:
            frame = decode_frame(encoded)
        except FrameError:
            return None
        msg = frame.message
        if isinstance(msg, m.Start) or (
            isinstance(msg, m.Configure) and msg.flags & m.ConfigureFlags.CONFIG_STREAM
        ):
            self._streaming = True
        elif isinstance(msg, m.Stop) and self._streaming:
            return frame.seq
        elif isinstance(msg, m.Stop):
            self._streaming = False
        return None

    def _hold_stop(self, seq: int, held: bytes) -> None:
        """Acknowledge STOP at once but hold it, with what the host wrote after it, for
        LATE_STOP_US of device time counted from the device's next output: the device goes on
        streaming, and reads the STOP and anything newer only then."""
        self._ack(m.Stop.TYPE_ID, seq)
        with self._stop_lock:
            self._held_stop = bytearray(held)
            self._stop_due_us = None

    def _release_stop_at(self, t: int) -> None:
        """The device's clock reads `t` µs: pass a held STOP on once it is due."""
        with self._stop_lock:
            if self._held_stop is None:
                return
            if self._stop_due_us is None:
                self._stop_due_us = t + LATE_STOP_US
            if t < self._stop_due_us:
                return
            held, self._held_stop = bytes(self._held_stop), None
            self._streaming = False
            self._to_device(held)  # under the lock: no newer host write overtakes it

    def close(self) -> None:
        self._closed.set()  # a stall in progress ends: the device is being closed
        with self._stop_lock:
            self._held_stop = None


def _status_fault(msg: m.Status, faults: frozenset[str]) -> m.Status:
    if "hsi_clock" in faults:
        msg = dataclasses.replace(msg, cycle_hz=16_000_000)
    if "hsi_pll_clock" in faults:
        msg = dataclasses.replace(msg, cycle_hz=96_000_000)
    if "bor_off" in faults:
        msg = dataclasses.replace(msg, bor_level=0)
    if "lost_fault_record" in faults:
        cleared = {f"fault_{k}": 0 for k in ("pc", "lr", "xpsr", "cfsr", "hfsr", "mmfar", "bfar")}
        cause = msg.reset_cause & ~m.ResetCause.RESET_FAULT
        msg = dataclasses.replace(msg, reset_cause=cause, **cleared)
    return msg


def _crossed(msg: m.Configure, seq: int, version: tuple[int, int]) -> bytes:
    """CONFIGURE as a board with LED 0's red and blue pins crossed carries it out."""
    duty = tuple((step[0][::-1], *step[1:]) for step in msg.led_duty)
    crossed = dataclasses.replace(msg, led_duty=duty)
    return encode_raw(crossed.TYPE_ID, crossed.pack(), seq, version)


def _model_info_fault(msg: m.ModelInfo, faults: frozenset[str], uploading: bool) -> m.ModelInfo:
    if "bad_model_info" in faults:
        msg = dataclasses.replace(msg, max_hidden=0)
    if "wrong_model_crc" in faults and msg.present:
        msg = dataclasses.replace(msg, crc=msg.crc ^ 1, image_crc=msg.image_crc ^ 1)
    if "volatile_model" in faults and not uploading:
        msg = m.ModelInfo(
            capacity=msg.capacity, max_inputs=msg.max_inputs, max_hidden=msg.max_hidden
        )
    return msg
