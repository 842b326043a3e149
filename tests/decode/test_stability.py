"""Numerical stability: dark and saturated inputs, constant features,
NaN/inf rows, forces beyond the training range, float32 against float64."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from spectratac.dataset import FT_NAMES, SPECTRATAC_INPUTS, Dataset
from spectratac.decode import Decoder, DecoderDataError
from spectratac.decode.feature_matrices import build_features
from spectratac.decode.layout import Layout
from spectratac.decode.scaling import Standardizer
from spectratac.train import TrainSpec, train

from tests.decode.conftest import synthetic

pytestmark = pytest.mark.train

TINY = {"epochs": 3, "hidden": 16, "blocks": 1, "threads": 1, "batch_size": 256}
counts = arrays(np.float64, (5, 12), elements=st.integers(0, 65535).map(float))


@pytest.fixture(scope="module")
def dec() -> Decoder:
    return train(synthetic(800), TrainSpec.paper(**TINY), progress=False)


@settings(max_examples=60, deadline=None)
@given(x=counts, dark=st.lists(st.sampled_from([3, 7, 11]), max_size=3))
def test_dark_and_near_dark_inputs_give_finite_features(x, dark) -> None:
    x[:, dark] = 0.0  # Clear = 0 (R, G, B may still be non-zero)
    for kind in ("paper33", "raw", "generic"):
        f = build_features(kind, Layout(SPECTRATAC_INPUTS, lags=(1,), drift=True)).apply(
            np.concatenate([x, x, x], axis=1)
        )
        assert np.all(np.isfinite(f))


@settings(max_examples=30, deadline=None)
@given(x=counts, col=st.integers(0, 11))
def test_dark_or_saturated_samples_are_flagged_ood_never_nan(dec, x, col) -> None:
    x[:, col] = 0.0 if col % 4 == 3 else 65535.0  # a dark Clear or a saturated channel
    est = dec.predict_inputs(x)
    assert np.all(np.isfinite(est.targets)) and np.all(np.isfinite(est.region_prob))
    assert est.ood.all() and not est.invalid.any()


def test_constant_features_do_not_divide_by_zero() -> None:
    ds = synthetic(400)
    ds.inputs[:, 5] = 1234.0  # a zero-variance channel (and so some zero-variance features)
    s = Standardizer.fit(ds.inputs)
    assert s.std[5] == 1.0 and np.all(np.isfinite(s.transform(ds.inputs)))
    d = train(ds, TrainSpec.paper(**TINY), progress=False)
    assert np.all(np.isfinite(d.runtime.scaler.std)) and np.all(d.runtime.scaler.std > 0)
    assert np.all(np.isfinite(d.predict(ds).targets))


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_training_refuses_nonfinite_inputs_naming_rows(bad) -> None:
    ds = synthetic(300)
    ds.inputs[[7, 42, 43], 2] = bad
    with pytest.raises(DecoderDataError, match=r"3 training row.*rows 7, 42, 43.*drop those rows"):
        train(ds, TrainSpec.paper(**TINY), progress=False)
    # leaving them out of the training rows is the fix
    keep = np.ones(ds.n, bool)
    keep[[7, 42, 43]] = False
    d = train(ds, TrainSpec.paper(**TINY), rows=keep, progress=False)
    est = d.predict(ds)
    assert est.invalid.tolist() == (~keep).tolist()
    assert np.all(np.isnan(est.targets[~keep])) and np.all(np.isfinite(est.targets[keep]))
    assert np.all(est.region[~keep] == -1) and not est.ood[~keep].any()


def test_dropout_targets_are_excluded_not_errors() -> None:
    ds = synthetic(300)
    ds.targets[10:20] = np.nan
    ds.target_valid[10:20] = False
    d = train(ds, TrainSpec.paper(**TINY), progress=False)
    assert np.all(np.isfinite(d.meta["history"]))
    ds.target_valid[10] = True  # NaN although marked valid: refused, naming the row
    with pytest.raises(DecoderDataError, match=r"1 training row.*target_valid.*rows 10\b"):
        train(ds, TrainSpec.paper(**TINY), progress=False)


def test_forces_beyond_the_training_range_are_flagged_ood() -> None:
    rng = np.random.default_rng(5)
    x = rng.uniform(0, 1, (600, 3))
    fz = 4.0 * x[:, 0] + x[:, 1]
    ds = Dataset.generic(x, fz[:, None], ["a", "b", "c"], ["Fz"])
    d = train(ds, TrainSpec(features="raw", model="linear", targets=("Fz",), epochs=60,
                            batch_size=64, lr=3e-2), progress=False)  # fmt: skip
    # training rows away from the edge of the training forces (the top and bottom 5 % of
    # the span are flagged: a saturating model reads loads beyond them as ones there)
    lo, hi = fz.min(), fz.max()
    mid = (fz > lo + 0.1 * (hi - lo)) & (fz < hi - 0.1 * (hi - lo))
    inside = d.predict_inputs(x[:50][mid[:50]])
    assert not inside.ood.any()
    far = d.predict_inputs(np.array([[3.0, 0.5, 0.5], [0.5, 0.5, -2.0]]))
    assert far.ood.all()
    # inputs inside the per-channel ranges whose decoded force is beyond the training range
    corner = d.predict_inputs(np.array([[1.09, 1.09, 0.5]]))
    assert corner.targets[0, 0] > fz.max() and corner.ood[0]


@settings(max_examples=40, deadline=None)
@given(scale=st.floats(0.8, 1.2), shift=st.floats(-2000, 2000), seed=st.integers(0, 1000))
def test_float32_runtime_agrees_with_float64(dec, scale, shift, seed) -> None:
    x = synthetic(20, seed).inputs * scale + shift
    u = np.clip(x, 0, 65535)
    f64 = dec.runtime.with_dtype(np.float64).run(u)
    np.testing.assert_allclose(dec.runtime.run(u), f64, rtol=1e-5, atol=1e-5)
    fused = np.stack([dec.runtime.run1(v).copy() for v in u])
    np.testing.assert_allclose(fused, f64, rtol=1e-5, atol=1e-5)


def test_spectratac_status_bits_mark_rows_ood(twin_ds) -> None:
    d = train(twin_ds, TrainSpec.paper(**TINY), progress=False)
    status = np.zeros((twin_ds.n, 3), np.uint8)
    status[5, 1] = 0x02  # SENSOR_BUS_FAULT
    est = d.predict_inputs(twin_ds.inputs, status=status)
    assert est.ood[5] and est.ood.sum() <= 0.05 * twin_ds.n + 1


def test_ft_names_match_estimates(dec) -> None:
    est = dec.predict_inputs(synthetic(5).inputs)
    assert est.target_names == FT_NAMES


def test_threads_decoding_with_one_runtime_keep_their_own_outputs(dec) -> None:
    """Two streams of one model in two threads (e.g. two joins of a bench, or two sensors):
    the fused plan's buffers were shared, so one thread's call overwrote the output another
    thread was still reading (and at load raised 'output array is read-only')."""
    import pickle
    import threading

    u = np.clip(synthetic(2, 5).inputs, 0, 65535)
    expected = [dec.runtime.run(u[i : i + 1])[0] for i in range(2)]
    outs: dict[int, np.ndarray] = {}

    def decode(i: int) -> None:
        outs[i] = dec.runtime.run1(u[i])  # not copied: the array the thread's plan returns

    for i in range(2):  # one after the other: no race needed to see the sharing
        t = threading.Thread(target=decode, args=(i,))
        t.start()
        t.join()
    for i in range(2):
        np.testing.assert_allclose(outs[i], expected[i], rtol=1e-5, atol=1e-5)
    # a runtime that has run still pickles (worker processes hand decoders back), plans left out
    again = pickle.loads(pickle.dumps(dec.runtime))
    np.testing.assert_allclose(again.run1(u[0]), expected[0], rtol=1e-5, atol=1e-5)
