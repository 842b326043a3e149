"""Drift-baseline ratio features x/b stay bounded where the baseline is near zero (issue 22:
±2·10⁴ seen on a sensor whose dark offset is ~0), in every runtime that reads the matrices."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from spectratac.decode.feature_matrices import RATIO_BOUND, build_features
from spectratac.decode.layout import Layout

finite = st.floats(-1e6, 1e6, allow_nan=False)


@settings(max_examples=200, deadline=None)
@given(x=finite, b=st.floats(-1e-3, 1e-3, allow_nan=False))
def test_ratio_to_a_near_zero_baseline_is_bounded(x: float, b: float) -> None:
    fs = build_features("raw", Layout(("a",), drift=True))
    f = fs.apply(np.array([[x, b]]))
    ratio = f[0, fs.names.index("a/base:a")]
    assert np.isfinite(f).all()
    assert abs(ratio) <= RATIO_BOUND


@settings(max_examples=100, deadline=None)
@given(b=st.floats(10.0, 1e5), rel=st.floats(0.5, 2.0))
def test_ratio_keeps_its_meaning_where_the_baseline_is_large(b: float, rel: float) -> None:
    fs = build_features("raw", Layout(("a",), drift=True))
    ratio = fs.apply(np.array([[rel * b, b]]))[0, -1]
    assert abs(ratio - rel) <= 0.03 * rel  # within 3 % of x/b for x within 0.5-2x of b
