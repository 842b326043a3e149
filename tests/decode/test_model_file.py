"""A damaged model file never loads as a working decoder: shapes and finiteness are checked at
load, every kind of damage is a DecoderFileError saying so, and a non-finite output is marked
invalid rather than passed on as a force."""

from __future__ import annotations

import io
import json
import zipfile
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from spectratac.decode.decoder import Decoder
from spectratac.decode.errors import DecoderFileError
from spectratac.decode.feature_matrices import build_features
from spectratac.decode.guard import Guard
from spectratac.decode.heads import Heads
from spectratac.decode.layout import Layout
from spectratac.decode.networks import init_weights
from spectratac.decode.runtime import Runtime

X = np.random.default_rng(0).uniform(0, 1, (40, 2))


def tiny_decoder() -> Decoder:
    """An untrained two-channel decoder (random weights): enough to write and read files."""
    layout = Layout(("a", "b"))
    features = build_features("generic", layout)
    heads = Heads(("Fz",), n_classes=2)
    arch = ("resmlp", 8, 1)
    weights = init_weights(arch, features.n_features, heads.n_out, np.random.default_rng(1))
    runtime = Runtime.create(features, arch, weights, heads, X)
    return Decoder(runtime, layout, Guard.fit(X, X[:, :1]), {"unit_id": "tiny"})


@pytest.fixture(scope="module")
def model_parts(tmp_path_factory) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    path = tiny_decoder().save(tmp_path_factory.mktemp("m") / "m.stac")
    with zipfile.ZipFile(path) as z:
        meta = json.loads(z.read("meta.json"))
        with np.load(io.BytesIO(z.read("arrays.npz"))) as npz:
            arrays = {k: npz[k] for k in npz.files}
    return meta, arrays


def write(path: Path, meta: Any, arrays: dict[str, np.ndarray]) -> Path:
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    with zipfile.ZipFile(path, "w", compression=zipfile.ZIP_DEFLATED) as z:
        z.writestr("meta.json", json.dumps(meta))
        z.writestr("arrays.npz", buf.getvalue())
    return path


def test_a_sound_file_round_trips(model_parts, tmp_path: Path) -> None:
    meta, arrays = model_parts
    est = Decoder.load(write(tmp_path / "m.stac", meta, arrays)).predict_inputs(X[:5])
    assert np.isfinite(est.targets).all() and not est.invalid.any()


@pytest.mark.parametrize("value", [np.nan, np.inf])
def test_a_non_finite_weight_is_refused_at_load(model_parts, tmp_path: Path, value) -> None:
    meta, arrays = model_parts
    bad = dict(arrays)
    bad["w/head.weight"] = arrays["w/head.weight"].copy()
    bad["w/head.weight"][0, 0] = value
    with pytest.raises(DecoderFileError, match=r"'w/head.weight' holds NaN or inf.*retrain"):
        Decoder.load(write(tmp_path / "nan.stac", meta, bad))


@pytest.mark.parametrize("key", ["w/stem.weight", "w/head.bias", "f_std", "center", "feat/L"])
def test_a_wrong_shaped_array_is_refused_at_load(model_parts, tmp_path: Path, key: str) -> None:
    meta, arrays = model_parts
    bad = dict(arrays)
    bad[key] = arrays[key][..., :-1]
    with pytest.raises(DecoderFileError, match=r"array '[^']+' has shape .*expected .*damaged"):
        Decoder.load(write(tmp_path / "shape.stac", meta, bad))


def test_a_missing_array_and_a_bad_guard_are_refused(model_parts, tmp_path: Path) -> None:
    meta, arrays = model_parts
    with pytest.raises(DecoderFileError, match=r"damaged .*w/norm\.bias"):
        Decoder.load(write(tmp_path / "a.stac", meta, {k: v for k, v in arrays.items()
                                                       if k != "w/norm.bias"}))  # fmt: skip
    bad = dict(arrays, **{"guard/in_lo": np.array([np.nan, 0.0])})
    with pytest.raises(DecoderFileError, match="guard range in_lo"):
        Decoder.load(write(tmp_path / "g.stac", meta, bad))


@pytest.mark.parametrize(
    "damage",
    [
        lambda m: [m],
        lambda m: {**m, "runtime": "resmlp"},
        lambda m: {**m, "runtime": {**m["runtime"], "arch": ["resmlp", "eight", 1]}},
        lambda m: {**m, "runtime": {**m["runtime"], "arch": ["transformer", 8, 1]}},
        lambda m: {**m, "runtime": {**m["runtime"], "heads": None}},
        lambda m: {**m, "layout": {"channels": 3}},
        lambda m: {**m, "guard": []},
        lambda m: {**m, "decoder": 7},
        lambda m: {k: v for k, v in m.items() if k != "layout"},
    ],
)
def test_malformed_meta_json_is_a_decoder_file_error(model_parts, tmp_path: Path, damage) -> None:
    meta, arrays = model_parts
    with pytest.raises(DecoderFileError):
        Decoder.load(write(tmp_path / "meta.stac", damage(meta), arrays))


def test_a_non_finite_output_is_invalid_not_a_force(model_parts, tmp_path: Path) -> None:
    dec = Decoder.load(write(tmp_path / "m.stac", *model_parts))
    dec.runtime.weights["head.bias"][0] = np.inf  # damaged after loading (or an overflow)
    est = dec.predict_inputs(X[:4])
    assert est.invalid.all() and np.isnan(est.targets).all() and (est.region == -1).all()


@settings(
    max_examples=120,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
@given(data=st.data())
def test_any_corrupted_byte_gives_a_decoder_file_error_or_a_sound_decoder(
    model_parts, tmp_path: Path, data
) -> None:
    raw = bytearray(write(tmp_path / "m.stac", *model_parts).read_bytes())
    for _ in range(data.draw(st.integers(1, 4))):
        at = data.draw(st.integers(0, len(raw) - 1))
        raw[at] ^= data.draw(st.integers(1, 255))
    if data.draw(st.booleans()):
        del raw[data.draw(st.integers(0, len(raw) - 1)) :]
    path = tmp_path / "flipped.stac"
    path.write_bytes(bytes(raw))
    try:
        dec = Decoder.load(path)
    except DecoderFileError:
        return
    est = dec.predict_inputs(X[:5])
    finite = np.isfinite(est.targets).all(axis=1)
    assert (finite | est.invalid).all()
