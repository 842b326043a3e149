"""The hard-case scenes over sim:// decoded on the device (issue 22: saturated under sunlight
and full LED duty, dark at 0.2 % duty): with each scene's own acquisition settings, every
ESTIMATE is a number (never NaN, never EST_INVALID) and either within the model's training
range or flagged EST_OOD, and the device flags the samples the host's decoder flags
(tests/device/test_hard_cases.py checks the host-decoded side)."""

from __future__ import annotations

import numpy as np
import pytest
from spectratac.dataset import Dataset
from spectratac.decode import Decoder
from spectratac.decode.export import model_image as mi
from spectratac.device import Sensor
from spectratac.protocol.generated import messages as m
from spectratac.train import TrainSpec, train

pytestmark = [pytest.mark.train, pytest.mark.firmware]

N_SAMPLES = 150  # 50 LED sequences: every state of the first press
GAIN = {code: value for value, code in {1.0: 0, 2.0: 1, 4.0: 2, 0.5: 3}.items()}
DIGITAL_GAIN = {0: 1, 1: 2, 2: 4}


@pytest.fixture(scope="module")
def decoder() -> Decoder:
    from spectratac.sim.twin_dataset import from_twin_session
    from spectratac.twin import builtin_scenes as scenes
    from spectratac.twin import generate_session

    scene = scenes.calibration_session(seed=3, duration_s=60.0)
    cal: Dataset = from_twin_session(generate_session(scene, seed=3), scene)
    spec = TrainSpec.paper(epochs=3, hidden=32, blocks=1, targets=("Fx", "Fy", "Fz"), threads=1)
    return train(cal, spec, progress=False)


def on_device(decoder: Decoder, scene: str) -> tuple[np.ndarray, np.ndarray]:
    """(samples, estimates beside them) of `scene` with its own settings (the device's boot
    configuration for the scene), the decoder uploaded."""
    with Sensor.open(f"sim://?scene={scene}&speed=max") as sensor:
        c = sensor.get_config()
        sensor.upload_model(mi.encode(decoder), decoder.model_id())
        steps = np.asarray(c.led_duty)[: c.led_step_count]
        sensor.configure(
            integration_ms=c.integration_ms,
            gain=GAIN[c.gain],
            digital_gain=DIGITAL_GAIN[c.digital_gain],
            sensitivity="high" if c.sensitivity == 0 else "low",
            leds=steps,
            settle_us=c.led_settle_us,
            estimates="beside",
        )
        sensor.start()
        samples = sensor.read(N_SAMPLES, timeout=30.0)
        est = sensor.read_estimates(N_SAMPLES, timeout=30.0)
        sensor.stop()
    assert len(samples) == len(est) == N_SAMPLES
    return samples, est


@pytest.mark.parametrize(
    ("scene", "saturated"),
    [("saturation_ambient", True), ("saturation_led", True), ("near_dark", False)],
)
def test_device_estimates_are_in_range_or_flagged_never_nan(
    decoder: Decoder, scene: str, saturated: bool
) -> None:
    samples, est = on_device(decoder, scene)
    status = samples["status"]
    assert (np.mean(np.any(status & m.SensorStatus.SENSOR_SATURATED, axis=1)) > 0.5) == saturated
    flags = est["flags"]
    assert not np.any(flags & m.EstimateFlags.EST_INVALID)
    force = est["force"].astype(np.float64)
    assert np.all(np.isfinite(force))
    guard = decoder.guard.on_device()
    lo, hi = guard.t_lo[:3], guard.t_hi[:3]
    inside = np.all((force >= lo) & (force <= hi), axis=1)
    ood = (flags & m.EstimateFlags.EST_OOD) > 0
    assert np.all(inside | ood), force[~(inside | ood)]
    # the host's decoder on the same samples flags the same rows (decode/guard.py)
    host = mi.as_stored(decoder).predict_inputs(
        samples["counts"][:, :, :4].reshape(len(samples), -1).astype(np.float64),
        status=samples["status"],
    )
    np.testing.assert_array_equal(ood, host.ood)
