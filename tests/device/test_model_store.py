"""Sensor's on-device decoding API (protocol 1.1) against the simulated device: model info,
upload (chunks, retry, typed refusals), clear, estimates beside or instead of samples."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import numpy as np
import pytest
from spectratac.conformance import TestModel
from spectratac.device import (
    ESTIMATE_RECORD,
    MissingCapabilityError,
    ModelUploadError,
    Sensor,
)
from spectratac.device.transport import open_transport
from spectratac.protocol import Frame, crc32c, encode_raw
from spectratac.protocol.generated import messages as m
from spectratac.protocol.versions import RELEASED_DEFINITION_HASHES

from .faults import RewritingTransport

WHITE = [[[500, 500, 500]] * 3]
MODEL = TestModel.packaged()
URL = "sim://?scene=tour&speed=max"


def _wire(msg: m.Message, frame: Frame) -> bytes:
    return encode_raw(msg.TYPE_ID, msg.pack(), frame.seq, frame.version)


def _rewriting(rewrite: Callable[[Frame], bytes], **options: object) -> Sensor:
    return Sensor.attach(RewritingTransport(open_transport(URL), rewrite), **options)


@pytest.fixture
def sensor() -> Sensor:
    with Sensor.open(URL) as s:
        s.clear_model()
        yield s


def test_upload_reports_progress_and_the_device_confirms_the_model(sensor: Sensor) -> None:
    assert sensor.model_info().present == "none"
    done: list[tuple[int, int]] = []
    info = sensor.upload_model(MODEL.image, MODEL.model_id, progress=lambda *p: done.append(p))
    assert (info.present, info.model_id, info.size) == (
        "uploaded",
        MODEL.model_id,
        len(MODEL.image),
    )
    assert info.crc == crc32c(MODEL.image) and info.weight_format == "f32" and info.led_steps == 1
    assert info.image_crc == int.from_bytes(MODEL.image[-4:], "little")  # the image's own CRC
    chunks = -(-len(MODEL.image) // 224)
    assert [n for n, _ in done] == [
        0,
        *[min(224 * (k + 1), len(MODEL.image)) for k in range(chunks)],
    ]
    assert sensor.stats.model_upload_retries == 0
    sensor.clear_model()
    assert sensor.model_info() == dataclasses.replace(
        info,
        present="none",
        model_id=0,
        size=0,
        crc=0,
        weight_format="",
        led_steps=0,
        n_inputs=0,
        image_crc=None,
    )


def test_an_image_larger_than_the_store_is_refused_before_anything_is_sent(sensor: Sensor) -> None:
    capacity = sensor.model_info().capacity
    with pytest.raises(ModelUploadError, match=r"model store holds \d+ B") as info:
        sensor.upload_model(bytes(capacity + 1), 7)
    assert info.value.name == "MODEL_TOO_LARGE" and "smaller model" in info.value.action
    assert sensor.model_info().present == "none" and sensor.stats.model_upload_retries == 0


def test_a_damaged_image_is_refused_at_once_with_the_device_s_reason(sensor: Sensor) -> None:
    damaged = bytearray(MODEL.image)
    damaged[len(damaged) // 2] ^= 0xFF
    with pytest.raises(ModelUploadError, match="MODEL_INVALID") as info:
        sensor.upload_model(bytes(damaged), MODEL.model_id)
    assert info.value.name == "MODEL_INVALID" and info.value.action
    assert sensor.stats.model_upload_retries == 0  # a second try cannot cure the image
    assert sensor.model_info().present == "none"


def test_a_lost_chunk_ack_restarts_the_upload_from_model_begin_once() -> None:
    lost = []

    def drop_first_chunk_ack(frame: Frame) -> bytes:
        msg = frame.message
        if isinstance(msg, m.Ack) and msg.acked_type == m.ModelChunk.TYPE_ID and not lost:
            lost.append(frame.seq)
            return b""
        return _wire(msg, frame)

    with _rewriting(drop_first_chunk_ack, timeout=0.5) as s:
        info = s.upload_model(MODEL.image, MODEL.model_id)
        assert lost and s.stats.model_upload_retries == 1
        assert (info.present, info.model_id) == ("uploaded", MODEL.model_id)
        s.clear_model()


def test_an_upload_that_fails_twice_names_the_error_and_what_to_do() -> None:
    def refuse_commit(frame: Frame) -> bytes:
        msg = frame.message
        if isinstance(msg, m.Ack) and msg.acked_type == m.ModelCommit.TYPE_ID:
            msg = m.Nack(msg.acked_type, msg.acked_seq, m.Error.MODEL_BAD_CRC, 255)
        return _wire(msg, frame)

    with _rewriting(refuse_commit) as s:
        with pytest.raises(ModelUploadError, match="MODEL_COMMIT: MODEL_BAD_CRC") as info:
            s.upload_model(MODEL.image, MODEL.model_id)
        assert info.value.name == "MODEL_BAD_CRC"
        assert info.value.action == m.ERROR_TEXT[m.Error.MODEL_BAD_CRC][1]
        assert s.stats.model_upload_retries == 1
        s.clear_model()


def test_estimates_beside_samples_pair_by_sample_seq(sensor: Sensor) -> None:
    sensor.upload_model(MODEL.image, MODEL.model_id)
    cid = sensor.configure(integration_ms=50, leds=WHITE, estimates="beside")
    assert sensor.estimates == "beside"
    sensor.start()
    samples = sensor.read(30, timeout=30)
    rows = sensor.read_estimates(30, timeout=30)
    sensor.stop()
    assert rows.dtype == ESTIMATE_RECORD and len(rows) == len(samples) == 30
    assert samples["sequence"].tolist() == rows["sequence"].tolist() == list(range(30))
    assert np.array_equal(samples["device_time_us"], rows["device_time_us"])
    assert set(rows["config_id"].tolist()) == {cid} and set(rows["model_id"]) == {MODEL.model_id}
    assert np.isnan(rows["torque"]).all()  # a force-only (Fz) model: torque does not exist
    assert np.isnan(rows["force"][:, :2]).all() and np.isfinite(rows["force"][:, 2]).all()
    assert rows["region"].tolist() == [0] * 30 and np.isnan(rows["region_prob"]).all()
    stats = sensor.stats
    assert stats.estimates_received >= 30 and stats.estimate_gaps == 0 == stats.sample_gaps


def test_estimates_instead_of_samples(sensor: Sensor) -> None:
    sensor.upload_model(MODEL.image, MODEL.model_id)
    sensor.configure(integration_ms=50, leds=WHITE, estimates="instead")
    sensor.start()
    rows = sensor.read_estimates(20, timeout=30)
    sensor.stop()
    assert rows["sequence"].tolist() == list(range(20))
    assert len(sensor.read(10_000, timeout=0.3)) == 0
    sensor.configure(integration_ms=50, leds=WHITE)  # estimates off again: samples only
    sensor.start()
    assert len(sensor.read(5, timeout=30)) == 5
    sensor.stop()
    assert sensor.estimates == "off"


def test_lost_estimates_are_counted() -> None:
    def drop_every_fifth_estimate(frame: Frame) -> bytes:
        msg = frame.message
        if isinstance(msg, m.Estimate) and msg.sample_seq % 5 == 4:
            return b""
        return _wire(msg, frame)

    with _rewriting(drop_every_fifth_estimate) as s:
        s.upload_model(MODEL.image, MODEL.model_id)
        s.configure(integration_ms=50, leds=WHITE, estimates="beside")
        s.start()
        s.read(50, timeout=30)
        rows = s.read_estimates(40, timeout=30)
        s.stop()
        last = int(np.concatenate([rows, s.read_estimates(10_000, timeout=0.5)])["sequence"][-1])
        assert 4 not in rows["sequence"].tolist()
        assert s.stats.estimate_gaps == sum(1 for q in range(last) if q % 5 == 4) > 0
        s.clear_model()


def test_estimates_without_a_model_are_refused_by_the_device(sensor: Sensor) -> None:
    from spectratac.device import CommandRejectedError

    with pytest.raises(CommandRejectedError, match="NO_MODEL"):
        sensor.configure(integration_ms=50, leds=WHITE, estimates="beside")
    assert sensor.estimates == "off"


def test_bad_estimates_argument_names_the_choices(sensor: Sensor) -> None:
    with pytest.raises(ValueError, match="'off', 'beside' or 'instead'"):
        sensor.configure(estimates="both")  # type: ignore[arg-type]


def _as_1_0_device(frame: Frame) -> bytes:
    """A protocol 1.0 firmware: INFO of 1.0 with its hash and no 1.1 capabilities."""
    msg = frame.message
    if isinstance(msg, m.Info):
        caps = msg.capabilities & ~(m.Capabilities.CAP_ESTIMATE | m.Capabilities.CAP_MODEL_UPLOAD)
        msg = dataclasses.replace(
            msg,
            protocol_minor=0,
            definition_hash=RELEASED_DEFINITION_HASHES[0],
            capabilities=caps,
        )
    return _wire(msg, frame)


def test_a_1_0_device_is_accepted_and_estimates_get_a_typed_error() -> None:
    with _rewriting(_as_1_0_device, strict_hash=True) as s:
        assert s.info.protocol_minor == 0  # its 1.0 hash is the right one for 1.0
        for ask in (
            lambda: s.configure(leds=WHITE, estimates="beside"),
            s.model_info,
            lambda: s.upload_model(MODEL.image, MODEL.model_id),
            s.clear_model,
        ):
            with pytest.raises(MissingCapabilityError, match="does not report CAP_") as info:
                ask()
            assert info.value.capability in ("CAP_ESTIMATE", "CAP_MODEL_UPLOAD")
        s.configure(leds=WHITE)  # plain sampling still works
        s.start()
        assert len(s.read(3, timeout=30)) == 3
        s.stop()
