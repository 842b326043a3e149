"""Shared fixtures for the twin tests: short sessions, generated once per test session."""

from __future__ import annotations

import numpy as np
import pytest
from spectratac.twin import Scene, Session, UnitParams, builtin_scenes, generate_session


@pytest.fixture(scope="session")
def nominal() -> UnitParams:
    return UnitParams.nominal()


@pytest.fixture(scope="session")
def short_cal() -> tuple[Scene, Session]:
    """A 4-minute calibration-style session (same protocol as the 50-minute one)."""
    sc = builtin_scenes.calibration_session(seed=5, duration_s=240.0)
    return sc, generate_session(sc, seed=5)


@pytest.fixture(scope="session")
def white() -> np.ndarray:
    return np.full((3, 3), 0.25)
