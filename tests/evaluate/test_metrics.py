"""Metrics: invalid targets are ignored, scores agree with their definitions, the confusion
matrix counts every labelled row once, coverage measures calibration."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from spectratac.evaluate.metrics import (
    contact_scores,
    improvement,
    interval_coverage,
    region_scores,
    regression_scores,
)
from spectratac.hardware.generated import vocabulary as vocab

FINITE = st.floats(-100, 100, allow_nan=False)


@settings(max_examples=100, deadline=None)
@given(
    arrays(np.float64, st.tuples(st.integers(2, 60), st.just(3)), elements=FINITE),
    arrays(np.float64, st.tuples(st.integers(2, 60), st.just(3)), elements=FINITE),
    st.data(),
)
def test_regression_scores_ignore_invalid_rows(y, noise, data) -> None:
    n = min(y.shape[0], noise.shape[0])
    y, p = y[:n].copy(), y[:n] + noise[:n]
    valid = np.array(data.draw(st.lists(st.booleans(), min_size=n, max_size=n)))
    nan_rows = np.array(data.draw(st.lists(st.booleans(), min_size=n, max_size=n)))
    y_bad = y.copy()
    y_bad[nan_rows, 1] = np.nan
    m = regression_scores(y_bad, p, ["a", "b", "c"], valid)
    for j, name in enumerate("abc"):
        keep = valid & ~(nan_rows if j == 1 else np.zeros(n, bool))
        assert m[name]["n"] == int(keep.sum())
        if keep.any():
            e = np.abs(p[keep, j] - y[keep, j])
            assert np.isclose(m[name]["mae"], e.mean())
            assert np.isclose(m[name]["rmse"], np.sqrt(np.mean(e**2)))
            assert m[name]["p50"] <= m[name]["p95"] <= m[name]["max"] + 1e-12
            assert m[name]["mae"] <= m[name]["rmse"] + 1e-12
        else:
            assert np.isnan(m[name]["mae"])


def test_r2_is_one_for_perfect_and_zero_for_the_mean() -> None:
    y = np.linspace(-3, 3, 50)[:, None]
    assert regression_scores(y, y, ["Fz"])["Fz"]["r2"] == 1.0
    assert abs(regression_scores(y, np.zeros_like(y), ["Fz"])["Fz"]["r2"]) < 1e-12


@settings(max_examples=100, deadline=None)
@given(st.lists(st.tuples(st.sampled_from([-1, *vocab.REGIONS]), st.integers(1, 9)), min_size=1))
def test_confusion_counts_each_labelled_row_once(pairs) -> None:
    lab = np.array([a for a, _ in pairs])
    pred = np.array([b for _, b in pairs])
    r = region_scores(lab, pred)
    conf = np.array(r["confusion"])
    assert conf.shape == (9, 9) and conf.sum() == r["n"] == int(np.sum(lab > 0))
    if r["n"]:
        assert np.isclose(r["accuracy"], np.trace(conf) / r["n"])
    else:
        assert np.isnan(r["accuracy"])


def test_contact_scores() -> None:
    t = np.array([1, 1, 0, 0, 1], bool)
    p = np.array([1, 0, 0, 1, 1], bool)
    c = contact_scores(t, p)
    assert c["accuracy"] == 0.6 and c["precision"] == 2 / 3 and c["recall"] == 2 / 3


def test_coverage_flags_overconfidence() -> None:
    rng = np.random.default_rng(1)
    y = rng.laplace(0, 2.0 / np.sqrt(2.0), (5000, 1))  # Laplace errors of std 2
    right = interval_coverage(y, np.zeros_like(y), np.full_like(y, 2.0), ["Fz"])["Fz"]
    over = interval_coverage(y, np.zeros_like(y), np.full_like(y, 0.5), ["Fz"])["Fz"]
    assert abs(right["0.68"] - 0.68) < 0.03 and abs(right["0.95"] - 0.95) < 0.015
    assert over["0.95"] < 0.6
    # Gaussian errors of the same std are lighter-tailed: the 68 % interval over-covers.
    g = rng.normal(0, 2.0, (5000, 1))
    gauss = interval_coverage(g, np.zeros_like(g), np.full_like(g, 2.0), ["Fz"])["Fz"]
    assert gauss["0.68"] < 0.62 and gauss["0.95"] > 0.95


def test_estimate_intervals_follow_the_coverage_levels() -> None:
    from spectratac.decode import Estimates

    est = Estimates.empty(("Fz",), 3)
    est.targets[:] = [[1.0], [2.0], [3.0]]
    est.std = np.array([[1.0], [0.0], [2.0]])
    lo, hi = est.interval(0.95)
    np.testing.assert_allclose(hi - lo, 2 * 2.1182 * est.std, atol=1e-3)
    np.testing.assert_allclose((lo + hi) / 2, est.targets)
    est.std = None
    assert np.isnan(est.interval(0.68)[0]).all()
    with pytest.raises(ValueError, match="probability"):
        Estimates.empty(("Fz",), 1).interval(1.0)


@given(st.floats(0.01, 10), st.floats(0, 10))
def test_improvement_sign(ref, val) -> None:
    assert (improvement(ref, val) > 0) == (val < ref) or val == ref


def test_confusion_grows_for_sensors_with_more_classes() -> None:
    r = region_scores(np.array([12, 3, -1]), np.array([12, 4, 1]))
    assert np.array(r["confusion"]).shape == (12, 12) and r["accuracy"] == 0.5
