"""Small datasets for decoder tests: a short twin calibration session and a synthetic one."""

from __future__ import annotations

import numpy as np
import pytest
from spectratac.dataset import FT_NAMES, SPECTRATAC_INPUTS, Dataset


@pytest.fixture(scope="session")
def twin_ds() -> Dataset:
    """Two minutes of the twin's calibration protocol (2,400 samples)."""
    from spectratac.sim.twin_dataset import from_twin_session
    from spectratac.twin import builtin_scenes as scenes
    from spectratac.twin import generate_session

    scene = scenes.calibration_session(seed=3, duration_s=120.0)
    return from_twin_session(generate_session(scene, seed=3), scene)


def synthetic(n: int = 600, seed: int = 2) -> Dataset:
    """SpectraTac-shaped data whose targets are simple functions of the counts."""
    rng = np.random.default_rng(seed)
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
    ds = Dataset.generic(raw, ft, SPECTRATAC_INPUTS, FT_NAMES, region=region)
    ds.meta.update(kind="spectratac", unit_id="synthetic", config=None)
    return ds


@pytest.fixture()
def synth_ds() -> Dataset:
    return synthetic()
