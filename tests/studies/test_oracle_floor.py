"""The twin oracle's floor: its scene is rebuilt from a twin dataset's metadata and checked
against the recorded contacts, and `OracleFloor` is the floor column evaluation takes."""

from __future__ import annotations

import numpy as np
import pytest
from spectratac.dataset import Dataset
from spectratac.evaluate import evaluate_model
from spectratac.evaluate.predictions import Predictions
from spectratac.sim.twin_dataset import from_twin_session
from spectratac.studies.oracle_floor import OracleFloor, twin_oracle
from spectratac.twin import builtin_scenes as scenes
from spectratac.twin import generate_session


@pytest.fixture(scope="module")
def twin_ds() -> Dataset:
    sc = scenes.calibration_session(seed=7, duration_s=120.0)
    return from_twin_session(generate_session(sc, seed=7), sc)


def test_oracle_scene_is_rebuilt_and_checked(twin_ds: Dataset) -> None:
    o = twin_oracle(twin_ds)
    assert o.oracle is not None and o.scene_name == "calibration"
    wrong = scenes.calibration_session(seed=8, duration_s=120.0)
    assert "does not match" in twin_oracle(twin_ds, scene=wrong).reason
    generic = Dataset.generic(np.zeros((5, 2)), np.zeros(5), ["a", "b"], ["Fz"])
    assert "not a SpectraTac" in twin_oracle(generic).reason


class Truth:
    """Stand-in decoder that predicts the targets exactly."""

    def __init__(self) -> None:
        self.meta: dict = {}

    def predict(self, dataset: Dataset, rows: np.ndarray) -> Predictions:
        return Predictions(["Fx", "Fy", "Fz"], dataset.targets[rows][:, :3])


def test_the_floor_column_scores_the_oracle_on_a_subsample(twin_ds: Dataset) -> None:
    ev = evaluate_model(Truth(), twin_ds, floor=OracleFloor(30))
    sec = ev.sections["all"]
    assert sec.oracle is not None and sec.oracle.scores["n"] == 30
    assert "deterministic subsample of 30" in sec.oracle_note
    assert evaluate_model(Truth(), twin_ds).sections["all"].oracle is None
