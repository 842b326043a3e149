"""The on-device decoder on a Cortex-M4F (QEMU netduinoplus2) against the Python decoder,
sample by sample: the interpreter built with the firmware's flags (PlatformIO env
`model_check`), the model image in flash, samples in and estimates out over semihosting."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from spectratac.decode.export import model_image as mi
from spectratac.train import TrainSpec, train

from tests.firmware.conftest import REPO, build_image
from tests.firmware.model_check import model_check_host as harness
from tests.firmware.test_model_native import twin, with_faults

pytestmark = [pytest.mark.qemu, pytest.mark.firmware, pytest.mark.train, pytest.mark.subprocess]

ELF = REPO / "build" / "pio" / "model_check" / "firmware.elf"
REL_TOL = 1e-4


@pytest.fixture(scope="module")
def check_image() -> Path:
    """qemu-system-arm ... -device loader,file=model.bin: the check image, built once."""
    return build_image("model_check", ELF)


@pytest.fixture(scope="module")
def decoders():
    ds = twin(3)
    tiny = {"epochs": 1, "hidden": 16, "threads": 1}
    specs = {"paper": TrainSpec.paper(**tiny, blocks=2), "best": TrainSpec.best(**tiny)}
    session = with_faults(harness.session_of(ds)).head(400)
    return {name: train(ds, spec, progress=False) for name, spec in specs.items()}, session


@pytest.mark.parametrize("weights", mi.WEIGHT_FORMATS)
@pytest.mark.parametrize("name", ["paper", "best"])
def test_cortex_m4_estimates_equal_python(check_image, decoders, tmp_path, name, weights):
    decs, session = decoders
    dec = decs[name]
    result = harness.run_qemu(check_image, mi.encode(dec, weights), session, tmp_path)
    assert result.returncode == 0, result.stderr
    got, trailer = harness.output_of(tmp_path)
    err = harness.errors(dec, got, harness.reference(mi.as_stored(dec, weights), session))
    assert err["estimates_agree"] and err["n_estimates"] > 0.9 * err["n"], err
    assert err["flags_disagree"] == 0 and err["region_disagree"] == 0, err
    for k, v in err["max_abs"].items():
        assert v <= REL_TOL * (1.0 + err["max_abs_ref"][k]), (k, v)
    # SysTick stamped every decode and the two references
    assert (got["ticks"][got["ret"] == 1] > 0).all()
    assert trailer["ticks"] > 0 and trailer["flags"] > 0


def test_a_damaged_image_is_refused_on_the_device(check_image, decoders, tmp_path) -> None:
    decs, session = decoders
    image = bytearray(mi.encode(decs["paper"]))
    image[200] ^= 0x80
    result = harness.run_qemu(check_image, bytes(image), session.head(10), tmp_path)
    assert result.returncode == 2
    assert not (tmp_path / harness.OUT_NAME).read_bytes()


def test_a_perturbed_weight_is_caught_on_the_device(check_image, decoders, tmp_path) -> None:
    from tests.firmware.test_model_native import reseal, weights_offset

    decs, session = decoders
    dec = decs["best"]
    image = bytearray(mi.encode(dec))
    first = weights_offset(image)
    w = np.frombuffer(image, "<f4", count=1, offset=first)[0]
    image[first : first + 4] = np.float32(w - 0.05).tobytes()
    result = harness.run_qemu(check_image, reseal(image), session, tmp_path)
    assert result.returncode == 0, result.stderr
    err = harness.errors(dec, harness.output_of(tmp_path)[0], harness.reference(dec, session))
    assert any(v > REL_TOL * (1.0 + err["max_abs_ref"][k]) for k, v in err["max_abs"].items())
