"""The hard-case scenes over sim:// (issue 22 item 5): their acquisition settings apply
(saturated under sunlight and full LED duty, dark at 0.2 % duty), and a decoder's every
estimate there is finite and either within its training range or flagged."""

from __future__ import annotations

import numpy as np
import pytest
from spectratac.dataset import Dataset
from spectratac.decode import Decoder
from spectratac.device import Sensor
from spectratac.train import TrainSpec, train

pytestmark = pytest.mark.train

N_SAMPLES = 150  # 50 LED sequences: every state of the first press


@pytest.fixture(scope="module")
def cal() -> Dataset:
    from spectratac.sim.twin_dataset import from_twin_session
    from spectratac.twin import builtin_scenes as scenes
    from spectratac.twin import generate_session

    scene = scenes.calibration_session(seed=3, duration_s=60.0)
    return from_twin_session(generate_session(scene, seed=3), scene)


@pytest.fixture(scope="module")
def decoder(cal: Dataset) -> Decoder:
    spec = TrainSpec.paper(epochs=3, hidden=32, blocks=1, targets=("Fx", "Fy", "Fz"))
    return train(cal, spec, progress=False)


@pytest.fixture(scope="module")
def ridge(cal: Dataset) -> Decoder:
    return train(cal, TrainSpec(model="ridge", targets=("Fx", "Fy", "Fz")), progress=False)


def _samples(scene: str) -> tuple[list, object]:
    with Sensor.open(f"sim://?scene={scene}&speed=max") as sensor:
        config = sensor.get_config()
        sensor.start()
        out = []
        for sample in sensor:
            out.append(sample)
            if len(out) >= N_SAMPLES:
                break
    return out, config


@pytest.mark.parametrize(
    ("scene", "integration_ms", "saturated", "dark"),
    [("saturation_ambient", 400, True, False), ("saturation_led", 400, True, False),
     ("near_dark", 50, False, True)],
)  # fmt: skip
def test_hard_case_settings_apply_over_sim(
    scene: str, integration_ms: int, saturated: bool, dark: bool
) -> None:
    samples, config = _samples(scene)
    assert config.integration_ms == integration_ms
    counts = np.array([s.counts for s in samples], np.float64)[..., :4]
    full = np.mean(np.any(counts >= 65535, axis=(1, 2)))  # samples with a channel at full scale
    said = np.mean([np.any(np.asarray(s.status) & 0x01) for s in samples])  # SENSOR_SATURATED
    assert (full > 0.5) == saturated and (said > 0.5) == saturated, (scene, full, said)
    assert (np.median(counts[..., 3]) < 100) == dark, np.median(counts[..., 3])


class _Replay:
    """A recorded sample list as the stream `Decoder.stream` reads (no config check)."""

    def __init__(self, samples: list) -> None:
        self.samples = samples

    def __iter__(self):  # type: ignore[no-untyped-def]
        return iter(self.samples)


@pytest.mark.parametrize("scene", ["saturation_ambient", "saturation_led", "near_dark"])
def test_every_estimate_is_in_range_or_flagged_never_nan(decoder: Decoder, scene: str) -> None:
    samples, _ = _samples(scene)
    est = list(decoder.stream(_Replay(samples), check_config=False))  # type: ignore[arg-type]
    assert len(est) == len(samples)
    lo, hi = decoder.guard.t_lo, decoder.guard.t_hi
    for e in est:
        assert not e.invalid and np.all(np.isfinite(e.targets)), e
        inside = bool(np.all((e.targets >= lo) & (e.targets <= hi)))
        assert inside or e.ood, e


@pytest.mark.parametrize("which", ["decoder", "ridge"])
def test_absurd_inputs_give_bounded_flagged_estimates(
    which: str, request: pytest.FixtureRequest
) -> None:
    """Inputs of 1e30 gave 1e29 N (a linear model scales with them): bounded and flagged."""
    decoder: Decoder = request.getfixturevalue(which)
    x = np.full((4, len(decoder.layout.channels)), 1e30)
    x[1] = -1e30
    x[2, ::2] = 0.0
    est = decoder.predict_inputs(x)
    assert np.all(np.isfinite(est.targets)) and not est.invalid.any()
    assert est.ood.all()
    span = decoder.guard.t_hi - decoder.guard.t_lo
    assert np.all(np.abs(est.targets) <= np.abs(decoder.guard.t_hi) + 2 * span)
