"""Hypothesis property tests for the numerics."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from spectratac.hardware.generated import vocabulary as vocab
from spectratac.twin import UnitParams, region_of
from spectratac.twin.electronics import INTEGRATION_MS, SensorConfig, digitise
from spectratac.twin.mechanics import lowpass

finite = st.floats(-1e3, 1e3, allow_nan=False, allow_infinity=False)


@settings(max_examples=40, deadline=None)
@given(arrays(np.float64, st.integers(1, 3000), elements=finite), st.floats(0.002, 5.0))
def test_blockwise_lowpass_matches_the_recursion(x: np.ndarray, tau: float) -> None:
    dt = 0.001
    a = np.exp(-dt / tau)
    ref = np.empty_like(x)
    prev = 0.0
    for i, v in enumerate(x):
        prev = a * prev + (1 - a) * v
        ref[i] = prev
    np.testing.assert_allclose(lowpass(x, dt, tau), ref, rtol=1e-7, atol=1e-7)


@settings(max_examples=60, deadline=None)
@given(
    arrays(np.float64, (4, 3, 5), elements=st.floats(0, 1e7, allow_nan=False)),
    st.sampled_from(INTEGRATION_MS),
    st.sampled_from([0.5, 1.0, 2.0, 4.0]),
    st.sampled_from([1, 2, 4]),
)
def test_digitise_stays_in_range_and_flags_full_scale(
    analog: np.ndarray, it: int, gain: float, dg: int
) -> None:
    cfg = SensorConfig(integration_ms=it, gain=gain, dg=dg)
    counts, sat = digitise(analog, cfg, UnitParams.nominal(), np.random.default_rng(0))
    assert counts.dtype == np.uint16
    np.testing.assert_array_equal(sat, np.any(counts == 65535, axis=-1))
    if dg > 1:
        assert np.all((counts % dg == 0) | (counts == 65535))


@settings(max_examples=100, deadline=None)
@given(st.floats(0, 9.6), st.floats(-720, 720))
def test_regions_rotate_with_the_board(r: float, deg: float) -> None:
    a = np.deg2rad(deg)
    x, y = r * np.cos(a), r * np.sin(a)
    reg = int(region_of(x, y))
    assert reg in (-1, *vocab.REGIONS)
    # Mirror across x = 0 swaps left and right columns of the keypad.
    mirror = {1: 3, 3: 1, 4: 6, 6: 4, 7: 9, 9: 7, 2: 2, 5: 5, 8: 8, -1: -1}
    on_border = abs((np.degrees(np.arctan2(y, x)) + 22.5) % 45.0) < 1e-6
    if not on_border:
        assert int(region_of(-x, y)) == mirror[reg]


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 2**31 - 1))
def test_units_from_any_seed_are_finite(seed: int) -> None:
    u = UnitParams.from_seed(seed)
    u.validate()
    assert np.all(u.direct > 0)
