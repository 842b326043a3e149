"""The paper's recipe: features, scaling, masked multitask training, NumPy inference."""

from __future__ import annotations

import numpy as np
import pytest
from spectratac.decode import (
    EPS,
    FEATURE_NAMES,
    Decoder,
    DecoderDataError,
    FeatureError,
    ZeroAnchoredScaler,
    features33,
    raw12_from_counts,
)
from spectratac.decode.feature_matrices import build_features
from spectratac.decode.layout import Layout
from spectratac.train import TrainSpec, train

from tests.decode.conftest import SPECTRATAC_INPUTS

pytestmark = pytest.mark.train

TINY = {"epochs": 25, "batch_size": 128, "hidden": 32, "blocks": 1, "threads": 1}


def test_feature_layout() -> None:
    rng = np.random.default_rng(0)
    raw = rng.uniform(100, 30000, (5, 12))
    f = features33(raw)
    assert f.shape == (5, 33) and len(FEATURE_NAMES) == 33
    np.testing.assert_array_equal(f[:, :12], raw)
    s = raw.reshape(5, 3, 4)
    np.testing.assert_allclose(f[:, 12], s[:, 0, 0] / (s[:, 0, 3] + EPS))
    np.testing.assert_allclose(f[:, 20], s[:, 2, 2] / (s[:, 2, 3] + EPS))
    np.testing.assert_allclose(f[:, 21:25], s[:, 0] - s[:, 1])
    np.testing.assert_allclose(f[:, 29:33], s[:, 2] - s[:, 0])
    assert FEATURE_NAMES[12] == "R1/C1" and FEATURE_NAMES[29] == "R3-R1"


def test_feature_set_paper33_is_the_papers_33_features() -> None:
    raw = np.random.default_rng(1).uniform(0, 65535, (7, 12))
    fs = build_features("paper33", Layout(SPECTRATAC_INPUTS))
    mine = fs.apply(raw)
    paper = features33(raw)
    # same columns, in the order [raw 12, differences 12, ratios 9]
    order = list(range(12)) + list(range(21, 33)) + list(range(12, 21))
    np.testing.assert_allclose(mine, paper[:, order], rtol=1e-12)


def test_features_survive_dark_sensors_and_reject_bad_input() -> None:
    assert np.all(np.isfinite(features33(np.zeros((2, 12)))))
    with pytest.raises(FeatureError, match=r"\(N, 12\)"):
        features33(np.zeros((2, 11)))
    with pytest.raises(FeatureError, match="NaN"):
        features33(np.full((1, 12), np.nan))
    with pytest.raises(FeatureError, match=r"\(N, 3, 5\)"):
        raw12_from_counts(np.zeros((2, 5, 3)))
    assert raw12_from_counts(np.ones((2, 3, 5), np.uint16)).shape == (2, 12)


def test_zero_anchored_scaling_keeps_rest_at_zero() -> None:
    y = np.random.default_rng(1).normal(3.0, 2.0, (100, 6))
    s = ZeroAnchoredScaler.fit(y)
    assert np.all(s.transform(np.zeros((1, 6))) == 0)
    np.testing.assert_allclose(s.inverse(s.transform(y)), y)


def test_training_masks_unlabelled_samples_and_inference_is_numpy(synth_ds, tmp_path) -> None:
    dec = train(synth_ds, TrainSpec.paper(**TINY), progress=False)
    hist = dec.meta["history"]
    assert all(np.isfinite(hist)) and hist[-1] < hist[0]
    est = dec.predict(synth_ds)
    n = synth_ds.n
    assert est.targets.shape == (n, 6) and est.force.shape == (n, 3)
    assert set(np.unique(est.region)) <= set(range(1, 10))
    valid = synth_ds.region > 0
    assert np.mean(est.region[valid] == synth_ds.region[valid]) > 0.8
    path = dec.save(tmp_path / "d.stac")
    again = Decoder.load(path).predict(synth_ds)
    np.testing.assert_array_equal(again.targets, est.targets)
    np.testing.assert_array_equal(again.region, est.region)


def test_training_rejects_bad_labels(synth_ds) -> None:
    synth_ds.region[[4, 9]] = 0
    with pytest.raises(DecoderDataError, match=r"2 training row.*1\.\.9.*rows 4, 9"):
        train(synth_ds, TrainSpec.paper(**TINY), progress=False)
