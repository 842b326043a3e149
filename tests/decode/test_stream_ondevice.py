"""`Decoder.stream` uses the device's own estimates when the device runs this very decoder
(protocol 1.1), and decodes on the host otherwise."""

from __future__ import annotations

import itertools
import subprocess
import sys
from collections.abc import Iterator

import numpy as np
import pytest
from spectratac.dataset import SPECTRATAC_INPUTS, Dataset
from spectratac.decode import Decoder, DecoderConfigError, Estimate
from spectratac.decode.export import model_image
from spectratac.decode.networks import SKIP
from spectratac.device import Sensor

pytestmark = pytest.mark.subprocess  # one test checks in a fresh interpreter that torch stays out

WHITE = [[[500, 500, 500]] * 3]
URL = "sim://?scene=tour&seed=5&speed=max"


def tiny_decoder(seed: int = 0) -> Decoder:
    ds = Dataset.generic(
        np.arange(1.0, 37.0).reshape(3, 12) * 100.0,
        np.zeros((3, 1)),
        list(SPECTRATAC_INPUTS),
        ["Fz"],
    )
    return Decoder.untrained(ds, features="paper33", seed=seed)


@pytest.fixture
def sensor() -> Iterator[Sensor]:
    with Sensor.open(URL) as s:
        yield s
        s.clear_model()


def test_device_estimates_of_this_decoder_are_yielded_and_match_host_decoding(
    sensor: Sensor,
) -> None:
    dec = tiny_decoder()
    image = model_image.encode(dec, weights="f32")
    assert dec.model_id() == model_image.model_id(image)
    sensor.upload_model(image, dec.model_id())
    sensor.configure(integration_ms=50, leds=WHITE, estimates="beside")
    sensor.start()
    on_device = list(itertools.islice(dec.stream(sensor, check_config=False), 20))
    samples = list(itertools.islice(sensor, 20))  # the same samples, untouched
    sensor.stop()
    assert all(isinstance(e, Estimate) and e.std is None for e in on_device)
    assert all(np.isnan(e.contact_prob) and e.region == -1 for e in on_device)
    on_host = list(dec.stream(samples, check_config=False))  # a list has no estimates
    device_fz = np.array([e.targets[0] for e in on_device])
    host_fz = np.array([e.targets[0] for e in on_host])
    assert not np.array_equal(device_fz, host_fz)  # float32 on the device, float64 here
    np.testing.assert_allclose(device_fz, host_fz, rtol=1e-4, atol=1e-5)
    assert [e.invalid for e in on_device] == [e.invalid for e in on_host]


def test_estimates_of_another_model_are_ignored_beside_and_refused_instead(
    sensor: Sensor,
) -> None:
    other, dec = tiny_decoder(seed=1), tiny_decoder(seed=0)
    sensor.upload_model(model_image.encode(other), other.model_id())
    assert other.model_id() != dec.model_id()
    sensor.configure(integration_ms=50, leds=WHITE, estimates="beside")
    sensor.start()
    got = list(itertools.islice(dec.stream(sensor, check_config=False), 10))
    sensor.stop()
    theirs = sensor.read_estimates(10, timeout=5)  # left alone: decoded on the host instead
    assert theirs["model_id"].tolist() == [other.model_id()] * 10
    ours = np.array([e.targets[0] for e in got])
    assert np.all(np.abs(ours - theirs["force"][:, 2]) > 1e-3)
    sensor.configure(integration_ms=50, leds=WHITE, estimates="instead")
    with pytest.raises(DecoderConfigError, match="only the estimates of its own model"):
        next(dec.stream(sensor, check_config=False))


def test_a_decoder_no_image_carries_is_decoded_on_the_host_beside_a_device_model(
    sensor: Sensor,
) -> None:
    """A linear skip (a skip.weight array) has no model image: beside a device's own model the
    host decodes it, instead of failing on the image id it cannot have."""
    other, dec = tiny_decoder(seed=1), tiny_decoder(seed=0)
    n_out, n_feat = dec.runtime.weights["head.weight"].shape[0], dec.runtime.features.n_features
    dec.runtime.weights[SKIP] = np.full((n_out, n_feat), 0.01, np.float32)
    with pytest.raises(model_image.ModelImageError, match="linear skip"):
        dec.model_id()
    sensor.upload_model(model_image.encode(other), other.model_id())
    sensor.configure(integration_ms=50, leds=WHITE, estimates="beside")
    sensor.start()
    got = list(itertools.islice(dec.stream(sensor, check_config=False), 5))
    sensor.stop()
    assert len(got) == 5 and all(np.isfinite(e.targets).all() for e in got)


def test_streaming_device_estimates_does_not_import_torch(tmp_path) -> None:
    path = tmp_path / "m.stac"
    tiny_decoder().save(path)
    code = (
        "import itertools, sys\n"
        "from spectratac.decode import Decoder\n"
        "from spectratac.decode.export import model_image\n"
        "from spectratac.device import Sensor\n"
        f"dec = Decoder.load({str(path)!r})\n"
        f"with Sensor.open({URL!r}) as s:\n"
        "    s.upload_model(model_image.encode(dec), dec.model_id())\n"
        "    s.configure(integration_ms=50, leds=[[[500] * 3] * 3], estimates='instead')\n"
        "    s.start()\n"
        "    got = list(itertools.islice(dec.stream(s, check_config=False), 5))\n"
        "    s.stop()\n"
        "print(len(got), 'torch' in sys.modules)\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, timeout=300
    ).stdout
    assert out.split() == ["5", "False"]
