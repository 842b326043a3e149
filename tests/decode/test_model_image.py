"""Model images (decode/export/model_image.py): layout, ids, refusals, damage detection."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from spectratac.dataset import SPECTRATAC_INPUTS, Dataset
from spectratac.decode import Decoder
from spectratac.decode.estimates import FORCE, TORQUE
from spectratac.decode.export import model_image as mi
from spectratac.decode.generated.model_image_layout import TARGETS

REPO = Path(__file__).resolve().parents[2]


def dataset(n: int = 50, seed: int = 1) -> Dataset:
    rng = np.random.default_rng(seed)
    raw = rng.integers(500, 30000, (n, 12)).astype(np.float64)
    return Dataset.generic(raw, rng.normal(size=(n, 2)), list(SPECTRATAC_INPUTS), ["Fx", "Fz"])


@pytest.fixture(scope="module")
def dec() -> Decoder:
    return Decoder.untrained(
        dataset(), features="paper33", targets=("Fx", "Fz", "region"), arch=("resmlp", 16, 2)
    )


def test_limits_equal_the_interpreters() -> None:
    header = REPO / "firmware" / "core" / "generated" / "stac_model_image.h"
    text = header.read_text(encoding="utf-8")
    defined = {k: int(v) for k, v in re.findall(r"#define STAC_MODEL_(\w+) (\d+)u", text)}
    assert {k: defined.get(k) for k in mi.LIMITS} == mi.LIMITS
    assert '#include "generated/stac_model_image.h"' in (
        REPO / "firmware" / "core" / "stac_model.h"
    ).read_text(encoding="utf-8")


def test_target_map_order_is_the_estimates() -> None:
    """The device reports force and torque in the layout's TARGETS order."""
    assert (*FORCE, *TORQUE) == TARGETS


@pytest.mark.parametrize("weights", mi.WEIGHT_FORMATS)
def test_layout_and_description(dec, weights) -> None:
    image = mi.encode(dec, weights)
    d = mi.describe(image)
    assert image[:4] == b"STMI" and len(image) % 4 == 0
    assert d["size"] == len(image) and d["weight_format"] == weights
    assert (d["arch"], d["hidden"], d["blocks"]) == ("resmlp", 16, 2)
    assert (d["n_inputs"], d["n_features"], d["n_outputs"]) == (12, 33, 2 + 9)
    n_weights = 33 * 16 + 4 * 16 * 16 + 16 * 11
    assert d["sections"]["weights"] == n_weights * {"f32": 4, "f16": 2, "i8": 1}[weights]
    assert d["sections"]["w_scale"] == (4 * (16 * 5 + 11) if weights == "i8" else 0)
    # the paper's feature rows are sparse: one or two non-zeros each
    assert d["sections"]["lin_idx"] == 2 * (12 + 2 * 12)
    offsets = [
        mi.ENTRY.unpack_from(image, mi.HEADER_SIZE + mi.ENTRY.size * i)[0]
        for i in range(mi.N_SECTIONS)
    ]
    assert all(o % 4 == 0 for o in offsets) and offsets == sorted(offsets)


def test_ids_follow_content_and_format(dec) -> None:
    a, b = mi.encode(dec), mi.encode(dec)
    assert a == b and mi.model_id(a) == mi.decoder_model_id(dec) != 0
    assert len({mi.model_id(mi.encode(dec, w)) for w in mi.WEIGHT_FORMATS}) == 3
    other = Decoder.untrained(dataset(), features="paper33", targets=("Fx", "Fz", "region"),
                              arch=("resmlp", 16, 2), seed=1)  # fmt: skip
    assert mi.model_id(mi.encode(other)) != mi.model_id(a)


def test_stored_weights_are_the_rounded_ones(dec) -> None:
    w = dec.runtime.weights["blocks.0.fc1.weight"]
    f16 = mi.as_stored(dec, "f16").runtime.weights["blocks.0.fc1.weight"]
    i8 = mi.as_stored(dec, "i8").runtime.weights["blocks.0.fc1.weight"]
    np.testing.assert_array_equal(f16, w.astype(np.float16).astype(np.float32))
    step = np.abs(w).max(axis=1, keepdims=True) / 127
    assert np.all(np.abs(i8 - w) <= step / 2 + 1e-7) and not np.array_equal(i8, w)
    assert mi.as_stored(dec, "f32").runtime.weights["blocks.0.fc1.weight"] is not None


def test_damage_is_detected(dec) -> None:
    image = bytearray(mi.encode(dec))
    image[400] ^= 0x01
    with pytest.raises(mi.ModelImageError, match="CRC"):
        mi.describe(bytes(image))
    with pytest.raises(mi.ModelImageError, match="truncated"):
        mi.model_id(mi.encode(dec)[:-8])
    with pytest.raises(mi.ModelImageError, match="STMI"):
        mi.model_id(b"\0" * 400)


def test_guard_bounds_decide_like_float64() -> None:
    lo, hi = mi._count_bounds(np.array([-np.inf, 10.5, 3.0]), np.array([7.2, np.inf, 1e9]))
    assert np.frombuffer(lo, "<f4").tolist() == [-1.0, 11.0, 3.0]
    assert np.frombuffer(hi, "<f4").tolist() == [7.0, 65536.0, 65536.0]
    t_lo, t_hi = mi._target_bounds(np.array([0.1]), np.array([0.1]))
    lo32, hi32 = np.frombuffer(t_lo, "<f4")[0], np.frombuffer(t_hi, "<f4")[0]
    assert np.float64(lo32) >= 0.1 >= np.float64(hi32)
    assert (
        np.float64(np.nextafter(lo32, np.float32(0)))
        < 0.1
        < np.float64(np.nextafter(hi32, np.float32(1)))
    )


def test_what_the_firmware_cannot_run_is_refused(dec) -> None:
    generic = Dataset.generic(np.ones((4, 2)), np.zeros((4, 1)), ["a", "b"], ["Fz"])
    with pytest.raises(mi.ModelImageError, match="12 SpectraTac inputs"):
        mi.encode(Decoder.untrained(generic))
    wide = Decoder.untrained(dataset(), features="paper33", arch=("resmlp", 300, 1))
    with pytest.raises(mi.ModelImageError, match="300 hidden units; the firmware runs at most 256"):
        mi.encode(wide)
    with pytest.raises(mi.ModelImageError, match="model store holds"):
        mi.encode(dec, limit=1000)
    with pytest.raises(mi.ModelImageError, match="f32, f16, i8"):
        mi.encode(dec, "bf16")
    big = Decoder.untrained(dataset(), features="paper33", arch=("resmlp", 256, 1))
    assert len(mi.encode(big, "f16")) < mi.MAX_IMAGE_BYTES
    with pytest.raises(mi.ModelImageError, match="weights='f16' or 'i8'"):
        mi.encode(big, "f32")
    assert len(mi.encode(big, "f32", limit=None)) > mi.MAX_IMAGE_BYTES


@pytest.mark.train
def test_polynomial_ridge_is_refused_not_miscomputed() -> None:
    from spectratac.train import TrainSpec, train

    ridge = train(dataset(200), TrainSpec(model="ridge", degree=2, targets=("Fz",)), progress=False)
    assert ridge.runtime.features.M.shape[0] > 0
    with pytest.raises(mi.ModelImageError, match="polynomial"):
        mi.encode(ridge)
    linear = train(
        dataset(200), TrainSpec(model="ridge", degree=1, targets=("Fz",)), progress=False
    )
    assert mi.describe(mi.encode(linear))["n_inputs"] == 12


def test_the_paper_size_float32_decoder_fits_the_store() -> None:
    """The paper's network (33 features, ResMLP 128 x 3) in float32 fits the STM32 model
    store (flash sectors 4-7 less the commit record) with room to spare."""
    assert mi.MAX_IMAGE_BYTES == 448 * 1024 - 64
    paper = Decoder.untrained(dataset(), features="paper33", arch=("resmlp", 128, 3))
    assert 400_000 < len(mi.encode(paper, "f32")) <= mi.MAX_IMAGE_BYTES


@pytest.mark.parametrize(
    ("broken", "old", "new", "message"),
    [
        ("model_image.toml", 'name = "reserved0"\ntype = "u32"', 'name = "reserved0"\ntype = "u16"',
         "base_tau at offset 62 is not aligned"),
        ("model_image.toml", 'name = "n_sections"\ntype = "u16"',
         'name = "n_sections"\ntype = "u32"', "n_sections at offset 50 is not aligned"),
        ("model_image.toml", "header_size = 96", "header_size = 100", "take 96 bytes; .* says 100"),
        ("vocabulary.toml", '"Ty", "Tz"]', '"Ty"]', "target_map holds 6 entries; .* names 5"),
    ],
)  # fmt: skip
def test_the_layout_definition_refuses_padding_and_wrong_sizes(
    tmp_path: Path, broken: str, old: str, new: str, message: str
) -> None:
    """Offsets come from the definition's field order: a field that would need padding, or
    fields that do not fill the declared header, are refused when generating; so is a
    target_map that does not hold every F/T axis of the vocabulary beside it."""
    from tools.codegen import model_image_backend as backend
    definitions = REPO / "hardware" / "definitions"
    layout = backend.load(definitions / "model_image.toml")
    assert layout.offset("n_sections") == 50 and layout.struct_format() == mi.HEADER.format
    for name in ("model_image.toml", "vocabulary.toml"):
        text = (definitions / name).read_text(encoding="utf-8")
        if name == broken:
            assert text.count(old) == 1
            text = text.replace(old, new)
        (tmp_path / name).write_text(text, encoding="utf-8")
    with pytest.raises(backend.ModelImageDefinitionError, match=message):
        backend.load(tmp_path / "model_image.toml")


@pytest.mark.train
def test_a_linear_skip_is_refused_not_dropped() -> None:
    """The image has no section for the skip: encoding it would run the network without it
    on the device (other forces than the host's), so the export refuses and says why."""
    from spectratac.train import TrainSpec, train

    small = {"epochs": 1, "hidden": 8, "blocks": 1, "threads": 1, "targets": ("Fx", "Fz")}
    skipped = train(dataset(200), TrainSpec.paper(skip=True, **small), progress=False)
    with pytest.raises(mi.ModelImageError, match=r"linear skip .* model image"):
        mi.encode(skipped)
    plain = train(dataset(200), TrainSpec.paper(**small), progress=False)
    assert mi.describe(mi.encode(plain))["n_inputs"] == 12
