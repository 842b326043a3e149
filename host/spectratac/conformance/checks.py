"""The conformance checks: what any SpectraTac device must do, tested over its real link.

Each check gets a connected Sensor and returns (passed, detail). They assume nothing about the
device beyond the protocol: the same suite runs against the simulated device in-process or over
a pty, the STM32F411 image in QEMU, and a real board. Every check can fail: for each one a
faulty simulated device breaks exactly it (``sim://?fault=…``, spectratac.sim.faults;
tests/conformance).
"""

from __future__ import annotations

import itertools
import random
import struct
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import TypeVar

import numpy as np

from spectratac.device import Sensor
from spectratac.device.clock_sync import TimeSyncExchange
from spectratac.device.errors import DeviceTimeoutError
from spectratac.protocol import Frame
from spectratac.protocol.generated import messages as m
from spectratac.protocol.schema import Message
from spectratac.protocol.versions import expected_definition_hash

WHITE = [[[500, 500, 500]] * 3]
#: bound on every wait for the device's data (s): generous, as a loaded host runs late; a read
#: returns as soon as what it waits for has arrived, so the bound only ends a dead device's wait
WAIT_S = 30.0
RGB_STEPS = [[[(c == k and 1000) or 0 for c in range(3)]] * 3 for k in range(3)]


@dataclass
class Outcome:
    passed: bool
    detail: str


Check = Callable[[Sensor], Outcome]
Target = TypeVar("Target")  # what a check is given: a Sensor, or a model_checks.ModelSession


def _configure_payload(**overrides: int) -> bytes:
    """A CONFIGURE payload packed by hand so that invalid values reach the device."""
    f = {
        "integration_ms": 50,
        "gain": 0,
        "digital_gain": 0,
        "sensitivity": 0,
        "flags": 0,
        "led_settle_us": 1000,
        "led_step_count": 1,
        "duty": 500,
    } | overrides
    head = struct.pack(
        "<HBBBBHB",
        f["integration_ms"],
        f["gain"],
        f["digital_gain"],
        f["sensitivity"],
        f["flags"],
        f["led_settle_us"],
        f["led_step_count"],
    )
    duties = [0] * (m.MAX_LED_STEPS * 9)
    duties[:9] = [f["duty"]] * 9
    return head + struct.pack(f"<{len(duties)}H", *duties)


def handshake(s: Sensor) -> Outcome:
    i = s.info
    expected = expected_definition_hash(i.protocol_minor)
    # the hash of the device's own minor version; a newer minor cannot be checked (SPEC.md)
    ok = i.protocol_major == m.PROTOCOL_MAJOR and expected in (None, i.definition_hash)
    return Outcome(
        ok,
        f"protocol {i.protocol_major}.{i.protocol_minor}, hash "
        f"0x{i.definition_hash:08X}, board {i.board!r}, fw "
        f"{'.'.join(map(str, i.firmware_version))}, build {i.build_id!r}",
    )


def info_limits(s: Sensor) -> Outcome:
    i = s.info
    problems = []
    if i.sensor_count != 3 or i.channels_per_sensor != 5:
        problems.append(f"sensor_count {i.sensor_count}, channels {i.channels_per_sensor}")
    if not 1 <= i.max_led_steps <= m.MAX_LED_STEPS:
        problems.append(f"max_led_steps {i.max_led_steps}")
    if i.duty_full_scale != m.DUTY_FULL_SCALE or i.integration_times_mask & 0x0F != 0x0F:
        problems.append("duty scale or integration times")
    if not 0 < i.max_frame <= m.MAX_FRAME:
        problems.append(f"max_frame {i.max_frame}")
    present = [k for k in range(3) if i.sensor_present >> k & 1]
    return Outcome(not problems, "; ".join(problems) or f"sensors present: {present}")


def configure_ack(s: Sensor) -> Outcome:
    before = s.get_config().config_id
    cid = s.configure(integration_ms=100, gain=2.0, leds=RGB_STEPS)
    cfg = s.get_config()
    ok = (
        cid != before
        and cfg.config_id == cid
        and cfg.integration_ms == 100
        and cfg.led_step_count == 3
        and cfg.gain == m.Gain.GAIN_X2
    )
    s.configure(integration_ms=50, leds=WHITE)
    return Outcome(ok, f"config_id {before} -> {cid}; CONFIG echoes it: {cfg.config_id == cid}")


INVALID = [
    ({"integration_ms": 75}, m.Error.BAD_INTEGRATION_TIME, 0),
    ({"gain": 4}, m.Error.BAD_GAIN, 1),
    ({"digital_gain": 3}, m.Error.BAD_DIGITAL_GAIN, 2),
    ({"sensitivity": 2}, m.Error.BAD_SENSITIVITY, 3),
    ({"flags": 0x80}, m.Error.BAD_FLAGS, 4),
    ({"led_settle_us": 20000}, m.Error.BAD_SETTLE_TIME, 5),
    ({"led_step_count": 0}, m.Error.BAD_STEP_COUNT, 6),
    ({"led_step_count": 9}, m.Error.BAD_STEP_COUNT, 6),
    ({"duty": 1001}, m.Error.DUTY_OUT_OF_RANGE, 7),
]


def configure_nack(s: Sensor) -> Outcome:
    before = s.get_config()
    wrong = []
    for overrides, code, field in INVALID:
        reply = s.link.request_raw(m.Configure.TYPE_ID, _configure_payload(**overrides))
        if not (isinstance(reply, m.Nack) and reply.error == code and reply.field_index == field):
            wrong.append(f"{overrides}: got {reply}")
    after = s.get_config()
    if after != before:
        wrong.append("a refused CONFIGURE changed the configuration")
    return Outcome(
        not wrong,
        "; ".join(wrong)
        or f"{len(INVALID)} invalid configurations "
        "refused with the specific code and field; configuration unchanged",
    )


def bad_messages(s: Sensor) -> Outcome:
    cases = [
        (0x7E, b"", (1, 0), m.Error.UNKNOWN_TYPE),
        (m.Sample.TYPE_ID, bytes(48), (1, 0), m.Error.WRONG_DIRECTION),
        (m.GetInfo.TYPE_ID, b"", (2, 0), m.Error.VERSION_MISMATCH),
    ]
    wrong = []
    for type_id, payload, version, code in cases:
        reply = s.link.request_raw(type_id, payload, version=version)
        if not (isinstance(reply, m.Nack) and reply.error == code):
            wrong.append(f"type 0x{type_id:02X} v{version}: got {reply}")
    return Outcome(
        not wrong,
        "; ".join(wrong)
        or "unknown type, wrong direction and "
        "another major version each answered with their NACK code",
    )


def _stream(s: Sensor, n: int, integration_ms: int, leds: list) -> np.ndarray:
    s.configure(integration_ms=integration_ms, leds=leds)
    s.read(10_000, timeout=0)  # discard anything older
    s.start()
    try:
        batch = s.read(n, timeout=WAIT_S)
    finally:
        s.stop()
    return batch


def sample_rate(s: Sensor) -> Outcome:
    details, ok = [], True
    for leds, name in ((WHITE, "1 step"), (RGB_STEPS, "3 steps")):
        batch = _stream(s, 24, 50, leds)
        if len(batch) < 24:
            return Outcome(False, f"{name}: only {len(batch)} of 24 samples arrived")
        period = np.diff(batch["device_time_us"].astype(np.int64)).mean() / 1000
        steps = batch["step"].tolist()
        per_step = 1000 / (period * len(leds))
        cycle_ok = all(b == (a + 1) % len(leds) for a, b in itertools.pairwise(steps))
        ok &= abs(period - 50) <= 2.5 and cycle_ok
        details.append(
            f"{name}: {1000 / period:.2f} samples/s, {per_step:.2f}/s per step, "
            f"steps cycle {'ok' if cycle_ok else steps[:6]}"
        )
    return Outcome(ok, "; ".join(details))


def continuity_and_time(s: Sensor) -> Outcome:
    gaps_before = s.stats.sample_gaps
    batch = _stream(s, 40, 50, WHITE)
    seq = batch["sequence"].astype(np.int64)
    t_end = batch["device_time_us"].astype(np.int64)
    width = (t_end - batch["t_start_us"].astype(np.int64)) / 1000
    problems = []
    if len(batch) < 40:
        problems.append(f"only {len(batch)} samples")
    if len(seq) and (seq[0] != 0 or np.any(np.diff(seq) != 1)):
        problems.append(f"sequence not 0,1,2,…: {seq[:5].tolist()}")
    if np.any(np.diff(t_end) <= 0):
        problems.append("device timestamps not increasing")
    if len(width) and not np.all((width >= 49) & (width <= 60)):
        problems.append(f"integration windows {width.min():.1f}..{width.max():.1f} ms, not ~50")
    if s.stats.sample_gaps != gaps_before:
        problems.append("sample gaps")
    return Outcome(
        not problems,
        "; ".join(problems)
        or f"{len(batch)} samples, seq 0..{seq[-1]}, windows {width.mean():.2f} ms",
    )


#: a TIME_SYNC exchange at most this long (s) is judged: a longer one waited on the host (a
#: loaded scheduler), and its wide error bar would hide a device's stamps that are off
SYNC_FAST_S = 0.02
SYNC_JUDGED = 8  # fast exchanges judged
SYNC_MAX_EXCHANGES = 400  # bound on the exchanges run to find them


def time_sync(s: Sensor) -> Outcome:
    """Every TIME_SYNC reply's device stamps must fit one device clock: the offsets that the
    fast exchanges give agree within their round trips. Exchanges the host delayed are left
    out (run more instead, within a bound), so the verdict does not depend on the host's load."""
    fast: list[TimeSyncExchange] = []
    ran = 0
    while len(fast) < SYNC_JUDGED and ran < SYNC_MAX_EXCHANGES:
        exchanges = s.sync_clock(exchanges=SYNC_JUDGED).exchanges
        ran += len(exchanges)
        fast += [e for e in exchanges if e.round_trip <= SYNC_FAST_S]
    if len(fast) < SYNC_JUDGED:
        return Outcome(
            False,
            f"only {len(fast)} of {ran} TIME_SYNC round trips took {SYNC_FAST_S * 1e3:.0f} ms "
            f"or less (need {SYNC_JUDGED}): the device answers slowly, or the host is too busy",
        )
    fast = fast[:SYNC_JUDGED]
    offsets = [e.offset for e in fast]
    ordered = all(e.device_tx_us >= e.device_rx_us for e in fast)
    spread = max(offsets) - min(offsets)
    best = min(e.round_trip for e in fast)
    ok = ordered and spread <= max(e.round_trip for e in fast) + 0.01
    return Outcome(
        ok,
        f"best round trip {best * 1e3:.2f} ms, offset spread {spread * 1e3:.2f} ms over "
        f"{SYNC_JUDGED} exchanges of at most {SYNC_FAST_S * 1e3:.0f} ms ({ran} run)",
    )


def garbage_recovery(s: Sensor) -> Outcome:
    rx_errors = s.status().rx_errors
    s.configure(integration_ms=50, leds=WHITE)
    # an earlier stream's samples (left unread before its STOP) would break the sequence
    s.read(10_000, timeout=0)
    s.start()
    try:
        s.read(3, timeout=WAIT_S)
        rng = random.Random(3)
        junk = bytes(rng.randrange(256) for _ in range(600))
        s.link.write(junk + b"\x00")
        info_ok = s.get_config().integration_ms == 50
        after = s.read(10, timeout=WAIT_S)
    finally:
        s.stop()
    seq = after["sequence"].astype(np.int64)
    continuous = len(seq) == 10 and bool(np.all(np.diff(seq) == 1))
    counted = s.status().rx_errors > rx_errors
    ok = info_ok and continuous and counted
    return Outcome(
        ok,
        f"answers after 600 garbage bytes: {info_ok}; streaming continued: "
        f"{continuous}; device counted rx errors: {counted}",
    )


#: how long the device's own clock must run on after STOP's ACK for "stop really stops"
STOP_WATCH_US = 10 * 50_000  # ten integration times


def stop_stops(s: Sensor) -> Outcome:
    """SPEC section 7.4: after the ACK of STOP no SAMPLE follows. Judged on the order of the
    frames on the link and on the device's clock, never on host time: every SAMPLE between
    the ACK and a TIME_SYNC_REPLY stamped ten integration times after the last sample before
    the ACK is late, however slowly a loaded host read them."""
    wire: list[Message] = []

    def keep(frame: Frame, _host_time: float) -> None:
        wire.append(frame.message)  # on the reader thread, in the order frames arrived

    s.configure(integration_ms=50, leds=WHITE)
    s.read(10_000, timeout=0)  # discard an earlier stream's samples
    s.link.add_listener(keep)
    try:
        s.start()
        s.read(3, timeout=WAIT_S)
        s.stop()
        ack = max(i for i, msg in enumerate(wire) if _acks(msg, m.Stop.TYPE_ID))
        before = [msg for msg in wire[:ack] if isinstance(msg, m.Sample)]
        if not before:
            return Outcome(False, "no SAMPLE arrived before STOP was acknowledged")
        reply = _await_device_time(s, before[-1].t_end_us + STOP_WATCH_US)
    finally:
        s.link.remove_listener(keep)
    end = next(i for i, msg in enumerate(wire) if msg is reply)
    late = [msg for msg in wire[ack:end] if isinstance(msg, m.Sample)]
    return Outcome(
        not late,
        f"{len(late)} samples after STOP was acknowledged (watched "
        f"{STOP_WATCH_US // 1000} ms of device time)",
    )


def _acks(msg: Message, type_id: int) -> bool:
    return isinstance(msg, m.Ack) and msg.acked_type == type_id


def _await_device_time(s: Sensor, until_us: int) -> m.TimeSyncReply:
    """The first TIME_SYNC_REPLY stamped at or after device time `until_us` (u32, wrapping);
    every frame the device sent before it has arrived when it does (the link keeps order)."""
    started = time.monotonic()
    for exchange in itertools.count():
        reply = s.link.request(
            m.TimeSyncRequest(exchange_id=exchange, host_time_ns=0),
            m.TimeSyncReply,
            timeout=WAIT_S,
            attempts=1,
        )
        if (reply.device_tx_us - until_us) & 0xFFFF_FFFF < 1 << 31:  # at or past it
            return reply
        waited = time.monotonic() - started
        if waited > WAIT_S:
            raise DeviceTimeoutError(
                f"the device clock did not reach {until_us} µs within {waited:.0f} s of host "
                f"time (TIME_SYNC_REPLY at {reply.device_tx_us} µs): is the device's clock "
                "running?"
            )
        time.sleep(0.02)  # pacing only: the verdict waits for the device's clock
    raise AssertionError("unreachable: itertools.count() never ends")


def sensor_status(s: Sensor) -> Outcome:
    batch = _stream(s, 5, 50, WHITE)
    if not len(batch):
        return Outcome(False, "no samples")
    present = s.info.sensor_present
    problems = []
    for k in range(3):
        flags = batch["status"][:, k]
        if present >> k & 1:
            if np.any(flags & (m.SensorStatus.SENSOR_ABSENT | m.SensorStatus.SENSOR_BUS_FAULT)):
                problems.append(f"sensor {k} present but flagged faulty")
        elif not np.all(flags & (m.SensorStatus.SENSOR_ABSENT | m.SensorStatus.SENSOR_BUS_FAULT)):
            problems.append(f"sensor {k} absent but not flagged")
    status = s.status()
    return Outcome(
        not problems,
        "; ".join(problems)
        or f"status flags match presence {present:03b}; bus errors "
        f"{list(status.bus_errors)}, frames sent {status.frames_sent}",
    )


CHECKS: list[tuple[str, Check]] = [
    ("handshake, version and definition hash", handshake),
    ("info limits", info_limits),
    ("configure accepted (ACK, CONFIG echo)", configure_ack),
    ("invalid configurations refused (NACK codes)", configure_nack),
    ("unknown type / direction / version refused", bad_messages),
    ("sample rate matches integration and steps", sample_rate),
    ("sequence continuity and monotonic time", continuity_and_time),
    ("time-sync round trip", time_sync),
    ("recovery after garbage bytes", garbage_recovery),
    ("stop really stops", stop_stops),
    ("sensor status flags", sensor_status),
]


def run_check(target: Target, check: Callable[[Target], Outcome]) -> Outcome:
    started = time.monotonic()
    try:
        outcome = check(target)
    except Exception as exc:  # a failing device must give a failed row, not a traceback
        outcome = Outcome(False, f"{type(exc).__name__}: {exc}")
    outcome.detail += f" [{time.monotonic() - started:.1f} s]"
    return outcome
