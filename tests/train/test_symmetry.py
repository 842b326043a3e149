"""Symmetry augmentation: the transforms form the group D3, and the twin agrees that a
rotated or mirrored press reads the permuted counts and the transformed wrench."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from spectratac.dataset import FT_NAMES
from spectratac.decode.errors import DecoderConfigError
from spectratac.train import TrainSpec, train
from spectratac.train.symmetry import (
    check_symmetric,
    permute_assembled,
    rotate_targets,
    transform_labels,
    transforms,
)

pytestmark = pytest.mark.train

finite = st.floats(-50, 50, allow_nan=False)


@given(st.lists(st.lists(finite, min_size=6, max_size=6), min_size=1, max_size=5),
       st.integers(0, 2), st.booleans())  # fmt: skip
def test_each_transform_is_undone_by_its_inverse(rows, turns, mirror) -> None:
    y = np.array(rows)
    u = np.arange(len(rows) * 36, dtype=float).reshape(len(rows), 36)
    once_y = rotate_targets(y, FT_NAMES, turns, mirror)
    once_u = permute_assembled(u, turns, mirror)
    # inverse: a mirror is its own inverse; a rotation's is the opposite rotation
    back_y = (rotate_targets(once_y, FT_NAMES, 0, True) if mirror
              else rotate_targets(once_y, FT_NAMES, -turns % 3, False))  # fmt: skip
    back_u = (permute_assembled(once_u, 0, True) if mirror
              else permute_assembled(once_u, -turns % 3, False))  # fmt: skip
    if mirror and turns:  # (R M)^-1 = M R^-1
        back_y = rotate_targets(rotate_targets(once_y, FT_NAMES, -turns % 3, False), FT_NAMES,
                                0, True)  # fmt: skip
        back_u = permute_assembled(permute_assembled(once_u, -turns % 3, False), 0, True)
    np.testing.assert_allclose(back_y, y, atol=1e-9)
    np.testing.assert_array_equal(back_u, u)
    # magnitudes and the normal force are invariant
    np.testing.assert_allclose(np.hypot(once_y[:, 0], once_y[:, 1]), np.hypot(y[:, 0], y[:, 1]),
                               atol=1e-9)  # fmt: skip
    np.testing.assert_allclose(once_y[:, 2], y[:, 2])


def test_transform_sets_and_labels() -> None:
    assert transforms("none") == [] and len(transforms("rotate")) == 2
    assert len(transforms("rotate+mirror")) == 5
    lab = np.arange(-1, 10)
    assert transform_labels(lab, 1, False).tolist() == [-1, 0] + [-1] * 4 + [5] + [-1] * 4
    mirrored = transform_labels(lab, 0, True)
    assert transform_labels(mirrored, 0, True).tolist() == lab.tolist()


def _rotated(scene, turns: int, mirror: bool):
    """The scene with every press mirrored in the x axis (if `mirror`), then turned."""
    a = 2 * np.pi * turns / 3
    c, s = np.cos(a), np.sin(a)
    p = scene.presses
    x, y = p.x, (-p.y if mirror else p.y)
    # shear F(t) = amp cos(w t + phase) per axis: rotate the complex amplitudes (phasors)
    ph = p.shear_amp * np.exp(1j * p.shear_phase) * ([1.0, -1.0] if mirror else [1.0, 1.0])
    ph = np.stack([c * ph[:, 0] - s * ph[:, 1], s * ph[:, 0] + c * ph[:, 1]], axis=1)
    pr = replace(p, x=c * x - s * y, y=s * x + c * y, shear_amp=np.abs(ph),
                 shear_phase=np.angle(ph))  # fmt: skip
    return replace(scene, presses=pr)


@pytest.mark.parametrize(("turns", "mirror"), [(1, False), (2, False), (0, True), (1, True)])
def test_the_twin_obeys_the_symmetry(turns: int, mirror: bool) -> None:
    from spectratac.sim.twin_dataset import from_twin_session
    from spectratac.twin import builtin_scenes as scenes
    from spectratac.twin import generate_session
    from spectratac.twin.unit import UnitParams

    scene = scenes.calibration_session(seed=4, duration_s=30.0)
    unit = UnitParams.nominal()  # placement and binning variation would break it slightly
    a = from_twin_session(generate_session(scene, seed=4, unit=unit), scene)
    rot = _rotated(scene, turns, mirror)
    b = from_twin_session(generate_session(rot, seed=4, unit=unit), rot)
    pressed = np.abs(a.targets[:, 2]) > 1.0
    assert pressed.sum() > 50
    want = permute_assembled(a.inputs, turns, mirror)
    rel = np.abs(b.inputs - want) / np.maximum(want, 1.0)
    assert np.median(rel[pressed]) < 0.01  # shot noise (~0.5 %); a wrong permutation: ~7 %
    wrench = rotate_targets(a.targets, a.target_names, turns, mirror)
    np.testing.assert_allclose(b.targets[pressed], wrench[pressed], atol=0.08)
    wrong = rotate_targets(a.targets, a.target_names, (turns + 1) % 3, mirror)
    assert not np.allclose(b.targets[pressed], wrong[pressed], atol=0.08)


def test_augmented_training_and_its_refusals(twin_ds) -> None:
    spec = TrainSpec.paper(augment="rotate+mirror", epochs=2, hidden=16, blocks=1, threads=1)
    dec = train(twin_ds, spec, rows=np.arange(600), progress=False)
    assert dec.meta["spec"]["augment"] == "rotate+mirror"
    assert np.isfinite(dec.predict(twin_ds, np.arange(600, 700)).targets).all()
    with pytest.raises(DecoderConfigError, match="12 SpectraTac inputs"):
        check_symmetric(["a", "b"], None)
    asym = {"leds": [[[250, 0, 0], [0, 0, 0], [0, 0, 0]]]}
    with pytest.raises(DecoderConfigError, match="LED step 0 drives the three LEDs"):
        check_symmetric(twin_ds.input_names, asym)
    with pytest.raises(DecoderConfigError, match="augment='spin'"):
        transforms("spin")
