"""The paper-size float32 decoder (TrainSpec.paper(): 33 features, ResMLP 128 x 3, about
417 KiB, more than the one 128 KiB sector the store used to be) end to end through the
simulator library: uploaded in raw MODEL_BEGIN/CHUNK/COMMIT frames into a store as large as
the STM32's (flash sectors 4-7), reported by GET_MODEL, still there after a power cycle
(a new device on the same store file) and after a sim:// re-open, and decoding on the
device: each ESTIMATE equals what the Python decoder makes of its SAMPLE, over a few
hundred samples of presses on every region."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from spectratac.decode import Decoder
from spectratac.decode.estimates import FORCE, TORQUE
from spectratac.decode.export import model_image as mi
from spectratac.device import Sensor
from spectratac.protocol.framing import crc32c
from spectratac.protocol.generated import messages as m
from spectratac.sim.generated.native_abi import STORE_CAPACITY
from spectratac.train import TrainSpec, train

from tests.firmware.model_check import model_check_host as harness

from .test_model_store_sim import Link, configure

pytestmark = [pytest.mark.train, pytest.mark.firmware, pytest.mark.slow]

SAMPLES = 300
REL_TOL = 1e-4  # of the output's range: float32 rounding of a differently ordered sum
FLAG_MASK = harness.EST_CONTACT | harness.EST_OOD | harness.EST_INVALID


@pytest.fixture(scope="module")
def paper() -> Decoder:
    """The paper's recipe at full size, trained one epoch on a one-minute twin session (the
    size of the image does not depend on the data)."""
    from spectratac.sim.twin_dataset import from_twin_session
    from spectratac.twin import builtin_scenes as scenes
    from spectratac.twin import generate_session

    scene = scenes.calibration_session(seed=5, duration_s=60.0)
    ds = from_twin_session(generate_session(scene, seed=5), scene)
    return train(ds, TrainSpec.paper(epochs=1, threads=1), progress=False)


def python_estimates(dec: Decoder, samples: list[m.Sample]):
    """The Python decoder over the SAMPLEs (its batch assembly gives what the live path's
    Assembler gives sample by sample)."""
    counts = np.array([s.counts for s in samples], np.float64)[:, :, :4].reshape(-1, 12)
    status = np.array([s.sensor_status for s in samples], np.uint8)
    step = np.array([s.led_step for s in samples], np.int64)
    return dec.predict_inputs(counts, step, status=status)


def test_paper_float32_model_uploads_survives_and_decodes(tmp_path: Path, paper) -> None:
    image = mi.encode(paper, "f32")
    model_id = mi.model_id(image)
    assert paper.runtime.arch == ("resmlp", 128, 3) and paper.runtime.features.n_features == 33
    assert 128 * 1024 < len(image) <= mi.MAX_IMAGE_BYTES == STORE_CAPACITY - 64

    store = tmp_path / "paper.flash"
    link = Link(store)
    assert link.upload(image, model_id) == 0
    info = link.info()
    assert (info.present, info.model_id, info.size, info.crc, info.weight_format) == (
        1, model_id, len(image), crc32c(image), 0,
    )  # fmt: skip
    assert (info.capacity, info.led_steps, info.n_inputs) == (mi.MAX_IMAGE_BYTES, 1, 12)
    assert store.read_bytes()[: len(image)] == image

    # Re-opened over sim:// on the same store file, the model is there.
    with Sensor.open(f"sim://?seed=3&speed=max&model_store={store}") as sensor:
        again = sensor.request_raw(m.GetModel.TYPE_ID, b"", accepts=(m.ModelInfo.TYPE_ID,))
        assert isinstance(again, m.ModelInfo)
        assert (again.present, again.model_id, again.size) == (1, model_id, len(image))

    # Power cycle: a new device boots from the file and decodes with the stored model.
    device = Link(store, seed=4, scene="tour")  # presses on every region in turn
    assert device.info().model_id == model_id
    flags = m.ConfigureFlags.CONFIG_ESTIMATE | m.ConfigureFlags.CONFIG_STREAM
    assert device.error(configure(flags)) == 0
    samples: list[m.Sample] = []
    estimates: dict[int, m.Estimate] = {}
    while len(samples) < SAMPLES:
        for frame in device.run(device.now + 1_000_000):
            if isinstance(frame.message, m.Sample):
                samples.append(frame.message)
            elif isinstance(frame.message, m.Estimate):
                estimates[frame.message.sample_seq] = frame.message
    assert [s.sample_seq for s in samples] == list(range(len(samples)))
    assert sorted(estimates) == [s.sample_seq for s in samples]  # one per sample, one step

    ref = python_estimates(paper, samples)
    got = [estimates[s.sample_seq] for s in samples]
    assert all(e.model_id == model_id for e in got)
    assert [e.flags & FLAG_MASK for e in got] == [
        int(c) * harness.EST_CONTACT + int(o) * harness.EST_OOD + int(i) * harness.EST_INVALID
        for c, o, i in zip(ref.contact, ref.ood, ref.invalid, strict=True)
    ]
    assert [e.region for e in got] == [max(int(r), 0) for r in ref.region]
    for names, field in ((FORCE, "force"), (TORQUE, "torque")):
        device_out = np.array([getattr(e, field) for e in got], np.float64)
        for j, name in enumerate(names):
            want = ref.column(name)
            assert np.array_equal(np.isnan(device_out[:, j]), np.isnan(want)), name
            have = ~np.isnan(want)
            scale = 1.0 + float(np.max(np.abs(want[have]), initial=0.0))
            err = float(np.max(np.abs(device_out[have, j] - want[have]), initial=0.0))
            assert err <= REL_TOL * scale, (name, err, scale)
            assert np.ptp(want[have]) > 0.0, name  # the presses move every output
