"""Conformance checks of on-device decoding (protocol 1.1, SPEC.md sections 13 and 14).

They run only on a device that reports CAP_MODEL_UPLOAD or CAP_ESTIMATE. The model they upload
is `TestModel.packaged()`: a tiny model image committed beside this module (the suite sits
below the decoder in the package, so it takes bytes, not a decoder). Uploading replaces the
device's model, and the last check erases it again (MODEL_CLEAR): a user's uploaded model has
to be uploaded again after a conformance run.

Like every check, each one here can fail: a faulty simulated device breaks exactly it
(spectratac.sim.faults, tests/conformance).
"""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import dataclass, field
from importlib import resources

import numpy as np

from spectratac.conformance.checks import WAIT_S, WHITE, Outcome
from spectratac.device import ModelInfo, Sensor
from spectratac.device.flash_timing import erase_ack_timeout_s
from spectratac.hardware.generated import vocabulary as vocab
from spectratac.protocol import crc32c
from spectratac.protocol.generated import messages as m
from spectratac.protocol.schema import Message

CHUNK = 224
FLASH_TIMEOUT = erase_ack_timeout_s()  # erase/program block the device (device.flash_timing)
_EST_MASK = sum(int(f) for f in m.EstimateFlags)


@dataclass(frozen=True)
class TestModel:
    """A model image to upload, with the id the host gives it."""

    __test__ = False  # not a pytest test class, despite the name

    image: bytes
    model_id: int
    led_steps: int

    @classmethod
    def packaged(cls) -> TestModel:
        """The committed conformance model (tools/vectors/make_conformance_model.py).

        >>> model = TestModel.packaged()
        >>> model.led_steps, len(model.image) > 0
        (1, True)
        """
        text = resources.files(__package__).joinpath("conformance_model.json").read_text("utf-8")
        raw = json.loads(text)
        return cls(bytes.fromhex(raw["image_hex"]), raw["model_id"], raw["led_steps"])


@dataclass
class ModelSession:
    """What a model check works with: the current sensor, the model, and a way to reopen the
    link (a new connection boots a simulated device afresh)."""

    sensor: Sensor
    model: TestModel
    reopen: Callable[[], Sensor]
    uploaded: bool = field(default=False)  # the round trip put `model` on the device


ModelCheck = Callable[[ModelSession], Outcome]


def _raw(s: Sensor, msg: Message, timeout: float | None = None) -> Message:
    """Send `msg` unvalidated (as a faulty host could) and return the device's ACK or NACK."""
    return s.link.request_raw(msg.TYPE_ID, msg.pack(), timeout=timeout)


def _is_nack(reply: Message, error: m.Error) -> bool:
    return isinstance(reply, m.Nack) and reply.error == error


def _name(reply: Message) -> str:
    if isinstance(reply, m.Nack):
        known = reply.error in m.Error._value2member_map_
        return f"NACK {m.Error(reply.error).name if known else reply.error}"
    return reply.NAME


def _chunks(image: bytes) -> list[m.ModelChunk]:
    return [
        m.ModelChunk(
            offset=i,
            length=len(image[i : i + CHUNK]),
            data=image[i : i + CHUNK].ljust(CHUNK, b"\x00"),
        )
        for i in range(0, len(image), CHUNK)
    ]


def _send_image(s: Sensor, image: bytes, model_id: int, crc: int) -> list[str]:
    """MODEL_BEGIN and every chunk; the replies that were not ACKs."""
    wrong = []
    begin = _raw(s, m.ModelBegin(model_id=model_id, size=len(image), crc=crc), FLASH_TIMEOUT)
    if not isinstance(begin, m.Ack):
        wrong.append(f"MODEL_BEGIN: {_name(begin)}")
    for chunk in _chunks(image):
        reply = _raw(s, chunk)
        if not isinstance(reply, m.Ack):
            wrong.append(f"MODEL_CHUNK at {chunk.offset}: {_name(reply)}")
            break
    return wrong


def model_info(session: ModelSession) -> Outcome:
    info = session.sensor.model_info()
    problems = []
    if info.present not in ("none", "uploaded", "builtin"):
        problems.append(f"present {info.present}")
    if info.present == "none" and (info.model_id or info.size):
        problems.append(f"no model but model_id {info.model_id}, size {info.size}")
    if info.capacity < len(session.model.image):
        problems.append(
            f"capacity {info.capacity} B cannot hold a {len(session.model.image)} B model"
        )
    if not (info.max_inputs and info.max_hidden):
        problems.append(f"limits max_inputs {info.max_inputs}, max_hidden {info.max_hidden}")
    return Outcome(
        not problems,
        "; ".join(problems)
        or f"{info.present} model 0x{info.model_id:08X}; store {info.capacity} B, limits "
        f"{info.max_inputs} inputs, {info.max_hidden} hidden",
    )


def model_too_large(session: ModelSession) -> Outcome:
    s = session.sensor
    capacity = s.model_info().capacity
    reply = _raw(s, m.ModelBegin(model_id=1, size=capacity + 1, crc=0), FLASH_TIMEOUT)
    return Outcome(
        _is_nack(reply, m.Error.MODEL_TOO_LARGE),
        f"MODEL_BEGIN of {capacity + 1} B (store {capacity} B): {_name(reply)}",
    )


def chunk_order(session: ModelSession) -> Outcome:
    s, image = session.sensor, session.model.image
    wrong = []
    begin = _raw(s, m.ModelBegin(model_id=1, size=len(image), crc=crc32c(image)), FLASH_TIMEOUT)
    if not isinstance(begin, m.Ack):
        wrong.append(f"MODEL_BEGIN: {_name(begin)}")
    first, second = _chunks(image)[:2]
    skipped = _raw(s, second)  # offset 224 before offset 0
    if not _is_nack(skipped, m.Error.MODEL_BAD_CHUNK):
        wrong.append(f"chunk at offset {second.offset} first: {_name(skipped)}")
    _raw(s, m.ModelBegin(model_id=1, size=first.length, crc=0), FLASH_TIMEOUT)
    past = m.ModelChunk(offset=0, length=CHUNK, data=first.data)  # more than announced
    too_long = _raw(s, past) if first.length < CHUNK else None
    if too_long is not None and not _is_nack(too_long, m.Error.MODEL_BAD_CHUNK):
        wrong.append(f"a chunk past the announced size: {_name(too_long)}")
    return Outcome(
        not wrong,
        "; ".join(wrong)
        or "a chunk out of order and a chunk past the announced size: NACK MODEL_BAD_CHUNK",
    )


def bad_crc(session: ModelSession) -> Outcome:
    s, model = session.sensor, session.model
    wrong = _send_image(s, model.image, model.model_id, crc32c(model.image) ^ 1)
    commit = _raw(s, m.ModelCommit(model_id=model.model_id), FLASH_TIMEOUT)
    if not _is_nack(commit, m.Error.MODEL_BAD_CRC):
        wrong.append(f"MODEL_COMMIT: {_name(commit)}")
    info = s.model_info()
    if info.present == "uploaded":
        wrong.append(f"the refused model is in use (model 0x{info.model_id:08X})")
    return Outcome(
        not wrong,
        "; ".join(wrong)
        or "an image that does not match MODEL_BEGIN's CRC: NACK MODEL_BAD_CRC, no model in use",
    )


def damaged_model(session: ModelSession) -> Outcome:
    s, model = session.sensor, session.model
    damaged = bytearray(model.image)
    damaged[len(damaged) // 2] ^= 0xFF  # the transfer is intact (CRC matches), the image not
    wrong = _send_image(s, bytes(damaged), model.model_id, crc32c(bytes(damaged)))
    commit = _raw(s, m.ModelCommit(model_id=model.model_id), FLASH_TIMEOUT)
    if not _is_nack(commit, m.Error.MODEL_INVALID):
        wrong.append(f"MODEL_COMMIT: {_name(commit)}")
    if s.model_info().present == "uploaded":
        wrong.append("the damaged model is in use")
    return Outcome(
        not wrong,
        "; ".join(wrong)
        or "an image damaged before upload (transfer CRC good): "
        "NACK MODEL_INVALID, no model in use",
    )


def _own_crc(image: bytes) -> int:
    """An image's own CRC-32C: its trailing u32 (SPEC section 13, MODEL_INFO.image_crc)."""
    return int.from_bytes(image[-4:], "little")


def _image_crc_expected(s: Sensor, image: bytes) -> int | None:
    """What a device must report as image_crc: the image's own CRC from 1.2 on, else None."""
    return _own_crc(image) if s.info.protocol_minor >= 2 else None


def upload_round_trip(session: ModelSession) -> Outcome:
    s, model = session.sensor, session.model
    done: list[int] = []
    info = s.upload_model(model.image, model.model_id, progress=lambda n, _: done.append(n))
    expected = (
        model.model_id,
        len(model.image),
        crc32c(model.image),
        _image_crc_expected(s, model.image),
        "uploaded",
    )
    got = (info.model_id, info.size, info.crc, info.image_crc, info.present)
    session.uploaded = got == expected
    image_crc = "none" if info.image_crc is None else f"0x{info.image_crc:08X}"
    return Outcome(
        session.uploaded and done[-1] == len(model.image),
        f"{len(model.image)} B in {len(done) - 1} chunks; MODEL_INFO {info.present} model "
        f"0x{info.model_id:08X}, {info.size} B, CRC 0x{info.crc:08X}, image CRC {image_crc} "
        f"({'as uploaded' if session.uploaded else f'expected {expected}'})",
    )


def refused_begin_keeps_model(session: ModelSession) -> Outcome:
    """SPEC section 7: a NACKed command changes nothing. With a model installed, a MODEL_BEGIN
    too large for the store is refused and the installed model stays in use."""
    s, model = session.sensor, session.model
    before = s.model_info()
    if (before.present, before.model_id) != ("uploaded", model.model_id):
        before = s.upload_model(model.image, model.model_id)
    oversize = m.ModelBegin(model_id=model.model_id ^ 0x5A5A, size=before.capacity + 1, crc=0)
    reply = _raw(s, oversize, FLASH_TIMEOUT)
    after = s.model_info()
    problems = []  # the refusal itself is "model larger than the store refused"'s to check
    if after != before:
        problems.append(
            f"MODEL_INFO changed: {before.present} model 0x{before.model_id:08X} before, "
            f"{after.present} model 0x{after.model_id:08X} after"
        )
    return Outcome(
        not problems,
        "; ".join(problems)
        or f"MODEL_BEGIN of {oversize.size} B ({_name(reply)}); model 0x{after.model_id:08X} "
        "still installed",
    )


def _expected_model(session: ModelSession) -> ModelInfo | None:
    info = session.sensor.model_info()
    return info if info.has_model else None


def _configure_estimates(s: Sensor, mode: str, steps: int) -> None:
    s.configure(integration_ms=50, leds=WHITE * max(1, steps), estimates=mode)  # type: ignore[arg-type]
    s.read(10_000, timeout=0)  # discard anything older
    s.read_estimates(10_000, timeout=0)


def _estimate_problems(rows: np.ndarray, model_id: int) -> list[str]:
    problems = []
    if np.any(rows["model_id"] != model_id):
        problems.append(f"model_id {sorted(set(rows['model_id'].tolist()))} != 0x{model_id:08X}")
    if np.any(rows["flags"] & (0xFF ^ _EST_MASK)):
        problems.append("reserved EST_* bits set")
    invalid = (rows["flags"] & m.EstimateFlags.EST_INVALID) != 0
    if np.any(~np.isnan(rows["force"][invalid])):
        problems.append("EST_INVALID estimates with a finite force")
    if np.any(rows["region"] > vocab.N_REGIONS):
        problems.append(f"region {rows['region'].max()} outside 0..{vocab.N_REGIONS}")
    return problems


def estimates_beside(session: ModelSession) -> Outcome:
    s = session.sensor
    model = _expected_model(session)
    if model is None:
        return _refused_without_model(s)
    _configure_estimates(s, "beside", model.led_steps)
    s.start()
    try:
        samples = s.read(24, timeout=WAIT_S)
        rows = s.read_estimates(24 // max(1, model.led_steps), timeout=WAIT_S)
    finally:
        s.stop()
        s.configure(integration_ms=50, leds=WHITE)
    problems = _estimate_problems(rows, model.model_id)
    by_seq = {
        int(q): (int(t), int(c)) for q, t, c in samples[["sequence", "device_time_us", "config_id"]]
    }
    unpaired = [
        int(q)
        for q, t, c in rows[["sequence", "device_time_us", "config_id"]]
        if by_seq.get(int(q)) != (int(t), int(c)) and int(q) <= max(by_seq, default=-1)
    ]
    if unpaired:
        problems.append(
            f"estimates of sample_seq {unpaired[:4]} match no SAMPLE (seq, time, config)"
        )
    seq = samples["sequence"].astype(np.int64)
    if len(samples) < 24 or np.any(np.diff(seq) != 1):
        problems.append(f"samples did not keep flowing: {len(samples)} of 24")
    if len(rows) < 24 // max(1, model.led_steps) - 1:
        problems.append(f"only {len(rows)} estimates")
    return Outcome(
        not problems,
        "; ".join(problems)
        or f"{len(samples)} samples and {len(rows)} estimates, each paired with its SAMPLE by "
        f"sample_seq, model 0x{model.model_id:08X}, decode "
        f"{np.median(rows['decode_us']):.0f} µs (median)",
    )


def estimates_instead(session: ModelSession) -> Outcome:
    s = session.sensor
    model = _expected_model(session)
    if model is None:
        return _refused_without_model(s)
    want = 12
    _configure_estimates(s, "instead", model.led_steps)
    s.start()
    try:
        rows = s.read_estimates(want, timeout=WAIT_S)
    finally:
        s.stop()
    samples = s.read(10_000, timeout=0.2)
    s.configure(integration_ms=50, leds=WHITE)
    problems = _estimate_problems(rows, model.model_id)
    seq = rows["sequence"].astype(np.int64)
    if len(rows) < want:
        problems.append(f"only {len(rows)} of {want} estimates")
    elif np.any(np.diff(seq) <= 0):
        problems.append(f"sample_seq not increasing: {seq[:5].tolist()}")
    if len(samples):
        problems.append(f"{len(samples)} SAMPLEs sent although CONFIG_ESTIMATE_ONLY was set")
    return Outcome(
        not problems,
        "; ".join(problems)
        or f"{len(rows)} estimates and no SAMPLE, sample_seq {seq[0]}..{seq[-1]}",
    )


def _refused_without_model(s: Sensor) -> Outcome:
    """A device that decodes but holds no model must refuse estimates with NO_MODEL."""
    flags = m.ConfigureFlags.CONFIG_ESTIMATE
    msg = m.Configure(integration_ms=50, flags=flags, led_step_count=1)
    reply = _raw(s, msg)
    return Outcome(
        _is_nack(reply, m.Error.NO_MODEL),
        f"no model on the device: CONFIGURE with CONFIG_ESTIMATE got {_name(reply)}",
    )


def survives_reset(session: ModelSession) -> Outcome:
    before = session.sensor.model_info()
    uptime = session.sensor.status().uptime_ms
    session.sensor = session.reopen()
    after = session.sensor.model_info()
    rebooted = session.sensor.status().uptime_ms < uptime
    same = (after.present, after.model_id, after.size, after.crc) == (
        before.present,
        before.model_id,
        before.size,
        before.crc,
    )
    return Outcome(
        same,
        f"{'device restarted' if rebooted else 'link reopened (the device kept running)'}; "
        f"model before {before.present} 0x{before.model_id:08X}, after {after.present} "
        f"0x{after.model_id:08X}",
    )


def clear(session: ModelSession) -> Outcome:
    s = session.sensor
    s.clear_model()
    info = s.model_info()
    problems = []
    if info.present == "uploaded":
        problems.append(f"MODEL_INFO still reports uploaded model 0x{info.model_id:08X}")
    if info.present == "none" and s.info.capabilities & m.Capabilities.CAP_ESTIMATE:
        refused = _refused_without_model(s)
        if not refused.passed:
            problems.append(refused.detail)
    return Outcome(
        not problems,
        "; ".join(problems)
        or f"erased; the device now runs {info.present} model 0x{info.model_id:08X}",
    )


#: (name, check, capability the device must report for it to run)
MODEL_CHECKS: list[tuple[str, ModelCheck, m.Capabilities]] = [
    ("model info (GET_MODEL)", model_info, m.Capabilities.CAP_ESTIMATE),
    ("model larger than the store refused", model_too_large, m.Capabilities.CAP_MODEL_UPLOAD),
    ("model chunk out of order refused", chunk_order, m.Capabilities.CAP_MODEL_UPLOAD),
    ("model with a bad CRC refused", bad_crc, m.Capabilities.CAP_MODEL_UPLOAD),
    ("damaged model refused", damaged_model, m.Capabilities.CAP_MODEL_UPLOAD),
    ("model upload round trip", upload_round_trip, m.Capabilities.CAP_MODEL_UPLOAD),
    (
        "refused MODEL_BEGIN changes nothing",
        refused_begin_keeps_model,
        m.Capabilities.CAP_MODEL_UPLOAD,
    ),
    ("estimates beside samples", estimates_beside, m.Capabilities.CAP_ESTIMATE),
    ("estimates instead of samples", estimates_instead, m.Capabilities.CAP_ESTIMATE),
    ("model survives a reset", survives_reset, m.Capabilities.CAP_MODEL_UPLOAD),
    ("model clear", clear, m.Capabilities.CAP_MODEL_UPLOAD),
]


def applicable(capabilities: int) -> list[tuple[str, ModelCheck]]:
    """The model checks a device with these INFO.capabilities must pass, in order."""
    return [(name, check) for name, check, cap in MODEL_CHECKS if capabilities & cap]
