"""Polynomial ridge decoders: fitted in closed form, ordinary .stac files, every export."""

from __future__ import annotations

import numpy as np
import pytest
from spectratac.dataset import Dataset
from spectratac.decode import Decoder, DecoderError
from spectratac.decode.assemble import assemble
from spectratac.train import TrainSpec, train

from tests.decode.test_export import run_c

pytestmark = [pytest.mark.train, pytest.mark.subprocess]


def cubic_data(n: int = 3000, seed: int = 0) -> tuple[Dataset, np.ndarray]:
    rng = np.random.default_rng(seed)
    x = rng.uniform(1.0, 2.0, (n, 3))
    y = x[:, 0] ** 3 - 2 * x[:, 1] * x[:, 2] + 0.5 * x[:, 2] ** 2 + 0.01 * rng.normal(size=n)
    press = np.repeat(np.arange(n // 100), 100)
    return Dataset.generic(x, y, ["a", "b", "c"], ["Fz"], press=press), y


def mae(dec: Decoder, ds: Dataset, y: np.ndarray) -> float:
    return float(np.mean(np.abs(dec.predict(ds).targets[:, 0] - y)))


def test_degree_three_recovers_a_cubic_and_degree_one_cannot() -> None:
    ds, y = cubic_data()
    spec = TrainSpec(features="raw", model="ridge", targets=("Fz",))
    lin = train(ds, spec, progress=False)
    cubic = train(ds, TrainSpec.from_dict({**spec.to_dict(), "degree": 3}), progress=False)
    assert mae(cubic, ds, y) < 0.02 < 0.1 < mae(lin, ds, y)
    # the penalty was chosen by grouped CV among the candidates, and recorded
    assert cubic.meta["ridge"]["alpha"] in cubic.meta["ridge"]["alphas"]
    assert len(cubic.meta["ridge"]["cv_mae_scaled"]) == len(cubic.meta["ridge"]["alphas"])
    assert cubic.runtime.arch == ("linear", 0, 0) and cubic.runtime.features.M.shape == (
        16,
        3,
    )  # 6 squares and products + 10 cubes
    # products are counted in the inference cost
    assert cubic.flops_per_sample > lin.flops_per_sample + 16


def test_a_fixed_penalty_is_used_as_given() -> None:
    ds, _ = cubic_data(500)
    dec = train(ds, TrainSpec(features="raw", model="ridge", degree=2, ridge_alpha=0.5,
                              targets=("Fz",)), progress=False)  # fmt: skip
    assert dec.meta["ridge"] == {
        "alpha": 0.5,
        "alphas": dec.meta["ridge"]["alphas"],
        "cv_mae_scaled": [],
    }


def test_saved_file_fused_path_and_exports_match(tmp_path) -> None:
    import onnxruntime as ort

    ds, _ = cubic_data(800)
    spec = TrainSpec(features="generic", model="ridge", degree=2, targets=("Fz",), context=2)
    dec = train(ds, spec, progress=False)
    u, ok = assemble(dec.layout, ds.inputs, ds.step, ds.session, ds.t_end)
    u = u[ok][:50]
    ref = dec.runtime.with_dtype(np.float64).run(u)
    loaded = Decoder.load(dec.save(tmp_path / "m.stac"))
    np.testing.assert_allclose(loaded.runtime.run(u), ref, rtol=1e-4, atol=1e-4)
    np.testing.assert_allclose(loaded.runtime.run1(u[0]), ref[0], rtol=1e-4, atol=1e-4)
    sess = ort.InferenceSession(str(dec.export("onnx", tmp_path / "m.onnx")))
    got = sess.run(None, {sess.get_inputs()[0].name: u.astype(np.float32)})[0]
    np.testing.assert_allclose(got, ref, rtol=1e-3, atol=1e-3)
    header = dec.export("c", tmp_path / "stac_decoder.h")
    c_out = run_c(header, u, "double", False, tmp_path)
    np.testing.assert_allclose(c_out[:, 1:], ref, rtol=1e-6, atol=1e-6)


def test_ridge_refuses_class_targets_and_bad_degrees() -> None:
    with pytest.raises(DecoderError, match="regression targets only"):
        TrainSpec(model="ridge", targets=("Fz", "region"))
    with pytest.raises(DecoderError, match="degree=4"):
        TrainSpec(model="ridge", degree=4, targets=("Fz",))
