"""The model store and on-device estimates through the simulator library: uploads in raw
protocol 1.1 frames, the store file surviving a re-boot (a new SimDevice, and a re-opened
sim:// device), flash faults through stac_sim_flash_fault, ESTIMATE after its SAMPLE and
ESTIMATE_ONLY. The C tests (test_store.c) cover the state machine word by word; these check
the native port and the Python side around it."""

from __future__ import annotations

import itertools
from pathlib import Path

import pytest
from spectratac.device import Sensor
from spectratac.device.errors import DeviceError
from spectratac.protocol import decode_frame, encode_frame
from spectratac.protocol.framing import Frame, crc32c
from spectratac.protocol.generated import messages as m
from spectratac.sim.device import SimDevice
from spectratac.sim.generated.native_abi import STORE_CAPACITY
from spectratac.sim.model_store import default_store_path
from spectratac.sim.named_scenes import make_scene

from .model_fixture import C_FIXTURE, fixture_image, render_fixture

pytestmark = [pytest.mark.firmware]

CHUNK = 224
CAPACITY = STORE_CAPACITY - 64  # the store's commit record takes the last 64 bytes


@pytest.fixture(scope="module")
def image() -> bytes:
    return fixture_image()


class Link:
    """A SimDevice driven step by step with raw frames (no threads)."""

    def __init__(self, store: Path | None, seed: int = 1, scene: str = "idle") -> None:
        self.out: list[bytes] = []
        self.dev = SimDevice(
            make_scene(scene), seed=seed, on_tx=lambda d, _t: self.out.append(d), model_store=store
        )
        self.now = 0
        self.seq = 0

    def send(self, msg: m.Message) -> list[Frame]:
        self.out.clear()
        self.seq += 1
        self.dev.feed(b"\x00" + encode_frame(msg, seq=self.seq))
        self.now += 1000
        self.dev.step(self.now)
        return [decode_frame(f[:-1]) for f in self.out]

    def reply(self, msg: m.Message) -> m.Message:
        frames = self.send(msg)
        assert len(frames) == 1, frames
        return frames[0].message

    def error(self, msg: m.Message) -> int:
        """0 for an ACK, else the NACK's error code."""
        reply = self.reply(msg)
        assert isinstance(reply, m.Ack | m.Nack), reply
        return 0 if isinstance(reply, m.Ack) else int(reply.error)

    def info(self) -> m.ModelInfo:
        reply = self.reply(m.GetModel())
        assert isinstance(reply, m.ModelInfo)
        return reply

    def upload(self, image: bytes, model_id: int, step: int = CHUNK) -> int:
        err = self.error(m.ModelBegin(model_id=model_id, size=len(image), crc=crc32c(image)))
        for off in range(0, len(image), step):
            if err:
                return err
            part = image[off : off + step]
            err = self.error(
                m.ModelChunk(offset=off, length=len(part), data=part.ljust(CHUNK, b"\x00"))
            )
        return err or self.error(m.ModelCommit(model_id=model_id))

    def run(self, until_us: int) -> list[Frame]:
        self.out.clear()
        while self.now < until_us:
            self.now = max(self.now + 1, self.dev.next_wake_us())
            self.dev.step(self.now)
        return [decode_frame(f[:-1]) for f in self.out]


def configure(flags: int, steps: int = 1) -> m.Configure:
    table = [[[500] * 3] * 3] * steps + [[[0] * 3] * 3] * (m.MAX_LED_STEPS - steps)
    return m.Configure(
        integration_ms=50,
        gain=0,
        digital_gain=0,
        sensitivity=0,
        flags=flags,
        led_settle_us=1000,
        led_step_count=steps,
        led_duty=tuple(tuple(tuple(led) for led in step) for step in table),
    )


def test_c_fixture_is_the_current_export() -> None:
    """tests/firmware/c/model_fixture.c is what tools/firmware/builtin_model.py makes of the
    fixture decoder today (regenerate: python tests/firmware/model_fixture.py)."""
    assert C_FIXTURE.read_text() == render_fixture()


def test_info_reports_store_and_capabilities(tmp_path: Path) -> None:
    link = Link(tmp_path / "a.flash")
    info = link.info()
    assert (info.present, info.model_id, info.size, info.capacity) == (0, 0, 0, CAPACITY)
    assert info.max_inputs > 0 and info.max_hidden > 0
    dev_info = link.reply(m.GetInfo())
    assert isinstance(dev_info, m.Info)
    caps = m.Capabilities(dev_info.capabilities)
    assert m.Capabilities.CAP_ESTIMATE in caps and m.Capabilities.CAP_MODEL_UPLOAD in caps
    assert (tmp_path / "a.flash").stat().st_size == STORE_CAPACITY


def test_upload_survives_a_new_boot_on_the_same_file(tmp_path: Path, image: bytes) -> None:
    store = tmp_path / "dev.flash"
    link = Link(store)
    assert link.upload(image, 0xC0FFEE, step=100) == 0
    info = link.info()
    assert (info.present, info.model_id, info.size, info.crc) == (
        1,
        0xC0FFEE,
        len(image),
        crc32c(image),
    )
    assert (info.led_steps, info.n_inputs, info.weight_format) == (1, 12, 0)
    again = Link(store)  # power cycle: a new instance boots from the file
    assert again.info().model_id == 0xC0FFEE
    assert Link(None).info().present == 0  # without a file nothing carries over
    assert again.error(m.ModelClear()) == 0
    assert Link(store).info().present == 0


@pytest.mark.parametrize("stop_after", [0, 1, 5, 13])
def test_reset_mid_upload_leaves_no_model(tmp_path: Path, image: bytes, stop_after: int) -> None:
    store = tmp_path / "dev.flash"
    link = Link(store)
    assert link.upload(image, 1) == 0
    assert link.error(m.ModelBegin(model_id=2, size=len(image), crc=crc32c(image))) == 0
    for off in range(0, min(stop_after * CHUNK, len(image)), CHUNK):
        part = image[off : off + CHUNK]
        chunk = m.ModelChunk(offset=off, length=len(part), data=part.ljust(CHUNK, b"\x00"))
        assert link.error(chunk) == 0
    rebooted = Link(store)
    assert rebooted.info().present == 0
    assert rebooted.error(m.ModelCommit(model_id=2)) == m.Error.MODEL_BAD_CHUNK


def test_nacks(tmp_path: Path, image: bytes) -> None:
    link = Link(tmp_path / "dev.flash")
    assert link.error(m.ModelBegin(model_id=1, size=CAPACITY + 1, crc=0)) == (
        m.Error.MODEL_TOO_LARGE
    )
    assert link.error(m.ModelCommit(model_id=1)) == m.Error.MODEL_BAD_CHUNK
    assert link.error(m.ModelChunk(offset=0, length=4)) == m.Error.MODEL_BAD_CHUNK
    assert link.upload(image[:-1], 1) == m.Error.MODEL_INVALID
    damaged = bytearray(image)
    damaged[100] ^= 1
    assert link.upload(bytes(damaged), 1) == m.Error.MODEL_INVALID
    assert link.error(configure(m.ConfigureFlags.CONFIG_ESTIMATE)) == m.Error.NO_MODEL
    assert link.upload(image, 1) == 0
    mismatch = configure(m.ConfigureFlags.CONFIG_ESTIMATE, steps=2)
    assert link.error(mismatch) == m.Error.MODEL_MISMATCH


@pytest.mark.parametrize("countdown", [1, 2, 3, 8])
def test_flash_faults_are_flash_error_and_leave_nothing(
    tmp_path: Path, image: bytes, countdown: int
) -> None:
    store = tmp_path / "dev.flash"
    link = Link(store)
    link.dev.flash_fault(countdown)
    assert link.upload(image, 1) == m.Error.FLASH_ERROR
    assert link.info().present == 0
    assert Link(store).info().present == 0
    link.dev.flash_fault(0)
    assert link.upload(image, 1) == 0


def test_estimates_follow_their_samples(tmp_path: Path, image: bytes) -> None:
    link = Link(tmp_path / "dev.flash")
    assert link.upload(image, 42) == 0
    flags = m.ConfigureFlags.CONFIG_ESTIMATE | m.ConfigureFlags.CONFIG_STREAM
    assert link.error(configure(flags)) == 0
    frames = link.run(link.now + 1_000_000)
    samples = [f.message for f in frames if isinstance(f.message, m.Sample)]
    assert len(samples) > 10
    for prev, frame in itertools.pairwise(frames):
        if isinstance(frame.message, m.Estimate):
            assert isinstance(prev.message, m.Sample)
            est, sample = frame.message, prev.message
            assert est.sample_seq == sample.sample_seq and est.t_end_us == sample.t_end_us
            assert est.config_id == sample.config_id and est.model_id == 42
    estimates = [f.message for f in frames if isinstance(f.message, m.Estimate)]
    assert len(estimates) == len(samples)


def test_estimate_only_sends_no_samples(tmp_path: Path, image: bytes) -> None:
    link = Link(tmp_path / "dev.flash")
    assert link.upload(image, 42) == 0
    flags = (
        m.ConfigureFlags.CONFIG_ESTIMATE
        | m.ConfigureFlags.CONFIG_ESTIMATE_ONLY
        | m.ConfigureFlags.CONFIG_STREAM
    )
    assert link.error(configure(flags)) == 0
    frames = link.run(link.now + 1_000_000)
    assert not [f for f in frames if isinstance(f.message, m.Sample)]
    seqs = [f.message.sample_seq for f in frames if isinstance(f.message, m.Estimate)]
    assert len(seqs) > 10 and seqs == list(range(len(seqs)))


def test_sim_url_store_survives_close_and_reopen(tmp_path: Path, image: bytes) -> None:
    """Over the sim:// transport: a named file, and the per-process default for a seed."""
    for url in (
        f"sim://?seed=71&speed=max&model_store={tmp_path / 'u.flash'}",
        "sim://?seed=72&speed=max",
    ):
        with Sensor.open(url) as sensor:
            assert _raw_upload(sensor, image, 9) == 0
        with Sensor.open(url) as sensor:
            info = sensor.request_raw(m.GetModel.TYPE_ID, b"", accepts=(m.ModelInfo.TYPE_ID,))
            assert isinstance(info, m.ModelInfo)
            assert (info.present, info.model_id) == (1, 9)
            assert _raw(sensor, m.ModelClear()) == 0
    assert default_store_path(72).is_file()


def test_sim_url_refuses_a_foreign_store_file(tmp_path: Path) -> None:
    bad = tmp_path / "not-a-store.bin"
    bad.write_bytes(b"hello")
    with pytest.raises(DeviceError, match="model store"):
        Sensor.open(f"sim://?seed=1&speed=max&model_store={bad}")


def _raw(sensor: Sensor, msg: m.Message) -> int:
    reply = sensor.request_raw(msg.TYPE_ID, msg.pack())
    return 0 if isinstance(reply, m.Ack) else int(reply.error)  # type: ignore[attr-defined]


def _raw_upload(sensor: Sensor, image: bytes, model_id: int) -> int:
    err = _raw(sensor, m.ModelBegin(model_id=model_id, size=len(image), crc=crc32c(image)))
    for off in range(0, len(image), CHUNK):
        part = image[off : off + CHUNK]
        chunk = m.ModelChunk(offset=off, length=len(part), data=part.ljust(CHUNK, b"\x00"))
        err = err or _raw(sensor, chunk)
    return err or _raw(sensor, m.ModelCommit(model_id=model_id))
