"""The generator's fast paths give what the plain formulations give: contact on a sorted time
stream (press by press) equals the general vectorised contact to the bit, on times that hit
every press boundary; window sums of disjoint segments equal differences of a running total;
the F/T noise with its per-second bias equals the bias gathered row by row."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from spectratac.twin import UnitParams, builtin_scenes
from spectratac.twin.ft import ft_noise, wrench
from spectratac.twin.generate import _segment_sums
from spectratac.twin.scene_model import SORTED_PATH_MIN, ContactState, Scene

FIELDS = ("x", "y", "fx", "fy", "normal", "indenter_radius_mm", "in_contact")


def boundary_times(scene: Scene) -> np.ndarray:
    """Every press's start, end of rise, end of hold and end, and their float neighbours."""
    p = scene.presses
    edges = np.concatenate([p.start, p.start + p.rise, p.start + p.rise + p.hold, p.end])
    return np.concatenate([edges, np.nextafter(edges, -np.inf), np.nextafter(edges, np.inf)])


def assert_same_contact(fast: ContactState, plain: ContactState) -> None:
    for name in FIELDS:
        np.testing.assert_array_equal(getattr(fast, name), getattr(plain, name), err_msg=name)


@settings(max_examples=25, deadline=None)
@given(
    st.integers(0, 10_000),
    st.floats(15.0, 60.0),
    st.integers(SORTED_PATH_MIN, 3 * SORTED_PATH_MIN),
)
def test_sorted_contact_is_the_general_contact(seed: int, duration: float, n: int) -> None:
    scene = builtin_scenes.calibration_session(seed=seed, duration_s=duration)
    rng = np.random.default_rng(seed)
    t = np.sort(
        np.concatenate(
            [rng.uniform(-1.0, duration + 1.0, n), boundary_times(scene), boundary_times(scene)[:1]]
        )
    )  # a repeated time too
    fast = scene.contact(t)
    plain = scene.contact(t[None, :])  # 2-D: the general path
    assert_same_contact(fast, ContactState(*(getattr(plain, f)[0] for f in FIELDS)))
    assert fast.in_contact.any()


def test_sorted_contact_caps_shear_by_friction_as_the_general_path() -> None:
    scene = builtin_scenes.hard_cases()["over_range"].scene
    scene = Scene(scene.name, scene.duration_s, scene.presses, scene.env, friction=0.05)
    t = np.linspace(0.0, scene.duration_s, 2 * SORTED_PATH_MIN)
    fast, plain = scene.contact(t), scene.contact(t[None, :])
    assert_same_contact(fast, ContactState(*(getattr(plain, f)[0] for f in FIELDS)))
    assert np.all(np.hypot(fast.fx, fast.fy) <= 0.05 * fast.normal * (1 + 1e-12))


@settings(max_examples=60, deadline=None)
@given(
    st.lists(st.tuples(st.integers(1, 30), st.integers(0, 5)), min_size=1, max_size=40),
    st.integers(0, 7),
    st.integers(0, 2**31),
)
def test_disjoint_segment_sums_match_a_running_total(
    segments: list[tuple[int, int]], lead: int, seed: int
) -> None:
    lengths, gaps = np.array(segments).T
    lo = lead + np.concatenate([[0], np.cumsum(lengths + gaps)[:-1]])
    hi = lo + lengths
    values = np.random.default_rng(seed).normal(size=(int(hi[-1] + gaps[-1]), 3))
    csum = np.vstack([np.zeros((1, 3)), np.cumsum(values, axis=0)])
    np.testing.assert_allclose(_segment_sums(values, lo, hi), csum[hi] - csum[lo], atol=1e-12)
    np.testing.assert_allclose(
        _segment_sums(values[:, 0], lo, hi), csum[hi, 0] - csum[lo, 0], atol=1e-12
    )


def test_overlapping_segments_are_summed_too() -> None:
    values = np.arange(10.0)[:, None]
    lo, hi = np.array([0, 1, 1, 2]), np.array([1, 2, 2, 3])
    np.testing.assert_array_equal(_segment_sums(values, lo, hi)[:, 0], [0.0, 1.0, 1.0, 2.0])


@pytest.mark.parametrize(("n", "rate"), [(2500, 1000.0), (3000, 1000.0), (7, 10.0), (1, 1000.0)])
def test_ft_noise_adds_each_seconds_bias_to_its_rows(n: int, rate: float) -> None:
    unit = UnitParams.from_seed(4)
    unit = replace(unit, ft_bias_offset=np.arange(6.0) * 0.01)
    got = ft_noise(n, rate, unit, np.random.default_rng(9))
    # The plain formulation: white noise, then the bias of each row's second gathered.
    rng = np.random.default_rng(9)
    white = rng.standard_normal((n, 6), dtype=np.float32) * unit.ft_noise.astype(np.float32)
    seconds = int(np.ceil(n / rate)) + 2
    a = np.exp(-1.0 / unit.ft_bias_tau_s)
    steps = rng.standard_normal((seconds, 6)) * unit.ft_bias_std * np.sqrt(1.0 - a * a)
    bias = np.zeros((seconds, 6))
    for i in range(1, seconds):
        bias[i] = a * bias[i - 1] + steps[i]
    want = white + (bias + unit.ft_bias_offset)[np.arange(n) // int(rate)]
    np.testing.assert_array_equal(got, want)


@pytest.mark.parametrize("tilted", [False, True])
def test_wrench_added_in_place_is_noise_plus_wrench(tilted: bool) -> None:
    unit = UnitParams.from_seed(1)
    if tilted:
        unit = replace(unit, mount_tilt_rad=np.array([0.004, -0.006]))
    n = 40_000  # more than one block
    args = np.random.default_rng(2).normal(size=(8, n))
    noise = np.random.default_rng(3).normal(size=(n, 6))
    got = wrench(*args, unit=unit, add_to=noise.copy())
    np.testing.assert_allclose(got, noise + wrench(*args, unit=unit), rtol=1e-15, atol=1e-15)
    with pytest.raises(ValueError, match="add_to has shape"):
        wrench(*args, unit=unit, add_to=np.zeros((n, 3)))
