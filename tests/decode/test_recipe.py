"""The paper's recipe: features, scaling, masked multitask training, NumPy inference."""

from __future__ import annotations

import numpy as np
import pytest
from spectratac.decode import (
    EPS,
    FEATURE_NAMES,
    FeatureError,
    PaperDecoder,
    TrainConfig,
    ZeroAnchoredScaler,
    features33,
    raw12_from_counts,
    train_paper_recipe,
)


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


def test_training_masks_unlabelled_samples_and_inference_is_numpy(tmp_path) -> None:
    rng = np.random.default_rng(2)
    n = 600
    raw = rng.uniform(1000, 30000, (n, 12))
    ft = np.stack(
        [
            raw[:, 0] / 1e4,
            raw[:, 4] / 1e4,
            -raw[:, 8] / 5e3,
            raw[:, 1] / 1e6,
            raw[:, 2] / 1e6,
            raw[:, 3] / 1e6,
        ],
        axis=1,
    )
    region = np.where(raw[:, 0] > raw[:, 4], 3, 7)
    region[::3] = -1  # unlabelled rows still train the F/T head
    dec = train_paper_recipe(
        raw, ft, region, TrainConfig(epochs=25, batch_size=128, hidden=32, blocks=1)
    )
    assert all(np.isfinite(dec.history)) and dec.history[-1] < dec.history[0]
    pred = dec.predict(raw)
    assert pred.ft.shape == (n, 6) and set(np.unique(pred.region)) <= set(range(1, 10))
    valid = region > 0
    assert np.mean(pred.region[valid] == region[valid]) > 0.8
    path = tmp_path / "d.npz"
    dec.save(path)
    again = PaperDecoder.load(path).predict(raw)
    np.testing.assert_allclose(again.ft, pred.ft, rtol=1e-6, atol=1e-6)


def test_training_rejects_bad_labels() -> None:
    with pytest.raises(FeatureError, match=r"1\.\.9"):
        train_paper_recipe(np.ones((4, 12)), np.zeros((4, 6)), np.array([0, 1, 2, 3]))
