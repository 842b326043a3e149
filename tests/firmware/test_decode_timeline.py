"""Decoding does not stall acquisition (issue 23 item 2), in the native simulator.

The simulated device is the firmware core on the simulator library, whose clock charges
each decode the time a Cortex-M4F at 96 MHz takes for it (the port's cycle model, from
tools/bench/ondevice.py: ~9.8 / 14.8 / 11.7 ms a sample for the paper's model in float32 /
float16 / int8). Decoding inside the acquisition's pass before the next trigger would add that
to every sample period (19.9 Hz at 50 ms integration falls to ~16.6 / 15.4 / 16.1 Hz); decoding
after the trigger, while the sensors integrate, must leave the rate within 1 % of the rate
without a model. The same timeline under QEMU: test_decode_timeline_qemu.py.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from spectratac.decode import Decoder
from spectratac.decode.export import model_image as mi
from spectratac.device import Sensor
from spectratac.train import TrainSpec, train

pytestmark = [pytest.mark.train, pytest.mark.firmware, pytest.mark.slow]

WHITE = [[[500, 500, 500]] * 3]
SAMPLES = 120  # 6 s of device time at 50 ms: a 1 % change is 1.2 samples' worth
MODELLED_MS = {"f32": 9.8, "f16": 14.8, "i8": 11.7}  # tools/bench/MEASUREMENTS.md, ondevice.py


@pytest.fixture(scope="module")
def paper() -> Decoder:
    """The paper's recipe at full size (ResMLP 128 x 3, 33 features), one epoch on a short
    twin session: the image's size and cost do not depend on the data."""
    from spectratac.sim.twin_dataset import from_twin_session
    from spectratac.twin import builtin_scenes as scenes
    from spectratac.twin import generate_session

    scene = scenes.calibration_session(seed=5, duration_s=60.0)
    ds = from_twin_session(generate_session(scene, seed=5), scene)
    return train(ds, TrainSpec.paper(epochs=1, threads=1), progress=False)


def sample_rate(sensor: Sensor) -> float:
    """Samples per second of device time over SAMPLES consecutive samples."""
    sensor.read(100_000, timeout=0.5)  # what an earlier run sent up to its STOP
    sensor.start()
    try:
        rows = sensor.read(SAMPLES, timeout=60)
    finally:
        sensor.stop()
    assert len(rows) == SAMPLES, f"only {len(rows)} of {SAMPLES} samples arrived"
    assert np.all(np.diff(rows["sequence"].astype(np.int64)) == 1), "samples were lost"
    t = rows["t_start_us"].astype(np.float64)
    return (len(t) - 1) / (t[-1] - t[0]) * 1e6


@pytest.mark.parametrize("weights", ["f32", "f16", "i8"])
def test_paper_model_keeps_the_sample_rate_within_1_percent(
    paper: Decoder, weights: str, tmp_path: Path
) -> None:
    image = mi.encode(paper, weights)
    url = f"sim://?seed=11&speed=max&model_store={tmp_path / 'store.flash'}"
    with Sensor.open(url) as sensor:
        sensor.upload_model(image, 0x5EED)
        sensor.configure(integration_ms=50, leds=WHITE)
        bare = sample_rate(sensor)
        sensor.configure(integration_ms=50, leds=WHITE, estimates="beside")
        sensor.read_estimates(10_000, timeout=0)
        decoding = sample_rate(sensor)
        estimates = sensor.read_estimates(10_000, timeout=2)
    # The simulated MCU really spends the modelled time decoding (else this proves nothing).
    assert len(estimates) >= SAMPLES - 2
    decode_ms = float(np.median(estimates["decode_us"])) / 1e3
    print(f"\n{weights}: {decoding:.3f} samples/s decoding, {bare:.3f} without, "
          f"decode {decode_ms:.2f} ms")  # fmt: skip
    assert decode_ms == pytest.approx(MODELLED_MS[weights], rel=0.05)
    assert bare == pytest.approx(19.9, rel=0.01)
    assert abs(decoding / bare - 1.0) < 0.01, (
        f"{weights}: {decoding:.2f} samples/s decoding vs {bare:.2f} without a model "
        f"(decode {decode_ms:.1f} ms a sample)"
    )
