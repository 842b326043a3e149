"""window_average invariants: constant input gives that constant, gaps give NaN, nothing
outside the F/T record is ever extrapolated, and means match a direct computation."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp
from spectratac.fusion import window_average

finite = st.floats(-1e3, 1e3, allow_nan=False)


@st.composite
def ft_record(draw: st.DrawFn) -> tuple[np.ndarray, float]:
    """Sample times at a jittered rate (sorted), and the nominal period."""
    n = draw(st.integers(2, 400))
    period = draw(st.floats(1e-4, 1e-2))
    start = draw(st.floats(-10.0, 1e4))
    jitter = draw(hnp.arrays(np.float64, n, elements=st.floats(0.0, 0.3)))
    return start + (np.arange(n) + jitter) * period, period


@st.composite
def windows(draw: st.DrawFn, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    k = draw(st.integers(1, 20))
    span = t[-1] - t[0]
    starts = draw(
        hnp.arrays(np.float64, k, elements=st.floats(-0.5, 1.5)).map(lambda a: t[0] + a * span)
    )
    lengths = draw(hnp.arrays(np.float64, k, elements=st.floats(1e-6, 0.5))) * span
    return starts, starts + lengths


@settings(max_examples=200, deadline=None)
@given(data=st.data(), value=hnp.arrays(np.float64, 6, elements=finite))
def test_constant_input_gives_the_constant(data: st.DataObject, value: np.ndarray) -> None:
    t, period = data.draw(ft_record())
    t0, t1 = data.draw(windows(t))
    w = np.tile(value, (t.size, 1))
    mean, valid, count = window_average(t, w, t0, t1, max_gap_s=2 * period)
    np.testing.assert_allclose(mean[valid], np.tile(value, (valid.sum(), 1)), rtol=1e-9, atol=1e-9)
    assert np.all(np.isnan(mean[~valid]))
    assert np.all(count[valid] > 0)


@settings(max_examples=200, deadline=None)
@given(data=st.data())
def test_never_extrapolates_and_matches_direct_mean(data: st.DataObject) -> None:
    t, period = data.draw(ft_record())
    t0, t1 = data.draw(windows(t))
    w = data.draw(hnp.arrays(np.float64, (t.size, 6), elements=finite))
    mean, valid, count = window_average(t, w, t0, t1, max_gap_s=2 * period)
    for i in range(t0.size):
        inside = (t >= t0[i]) & (t < t1[i])
        assert count[i] == inside.sum()
        if valid[i]:
            # covered on both sides by real samples
            assert t[0] <= t0[i] and t[-1] >= t1[i]
            np.testing.assert_allclose(mean[i], w[inside].mean(axis=0), rtol=1e-7, atol=1e-6)
        if t0[i] < t[0] or t1[i] > t[-1]:
            assert not valid[i]


@settings(max_examples=200, deadline=None)
@given(data=st.data())
def test_a_gap_touching_the_window_invalidates_it(data: st.DataObject) -> None:
    t, period = data.draw(ft_record())
    if t.size < 6:
        return
    lo = data.draw(st.integers(1, t.size - 4))
    hi = data.draw(st.integers(lo + 3, t.size - 1))  # drop samples lo..hi-1: a big gap
    kept = np.r_[t[:lo], t[hi:]]
    gap = (t[lo - 1], t[hi])
    w = np.ones((kept.size, 6))
    t0, t1 = data.draw(windows(t))
    mean, valid, _ = window_average(kept, w, t0, t1, max_gap_s=1.5 * period)
    touches = (t0 < gap[1]) & (t1 > gap[0])
    assert not np.any(valid & touches & (gap[1] - gap[0] > 1.5 * period))
    assert np.all(np.isnan(mean[~valid]))


def test_default_gap_is_three_periods_and_nan_rows_are_missing() -> None:
    t = np.arange(0.0, 1.0, 0.001)
    w = np.ones((t.size, 6))
    w[500:503] = np.nan  # three missing samples: a 4 ms step, over 3 periods
    _, valid, _ = window_average(t, w, [0.49, 0.1], [0.51, 0.2])
    assert valid.tolist() == [False, True]
    w[500:503] = 1.0
    w[500:502] = np.nan  # two missing: a 3 ms step, still within 3 periods
    _, valid, _ = window_average(t, w, [0.49], [0.51])
    assert valid.tolist() == [True]


def test_unsorted_times_are_sorted_and_empty_input_is_all_invalid() -> None:
    t = np.array([0.003, 0.0, 0.002, 0.001, 0.004])
    w = np.arange(5.0)[:, None].repeat(6, axis=1)
    mean, valid, _ = window_average(t, w, [0.0], [0.0025])
    assert valid[0] and mean[0, 0] == np.mean([1.0, 3.0, 2.0])
    mean, valid, count = window_average([], np.empty((0, 6)), [0.0], [1.0])
    assert not valid[0] and np.isnan(mean[0]).all() and count[0] == 0
