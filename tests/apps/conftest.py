"""A decoder for the interaction apps' tests: trained in a few seconds on twin presses of
every region at forces below and above the Snake threshold, on the same simulated unit
(seed 0) that `sim://?scene=presses` plays."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from spectratac.hardware.generated import vocabulary as vocab

from tests.run_once import made_once

#: The scripted scene the pipeline tests play: a press below the threshold (0.6 N) on
#: "up" must not command; the centre is neutral.
ORDER = ("up", "right", "down", "left", "centre", "up", "left", "5", "down", "right")
FORCES = (2.5, 2.5, 2.5, 2.5, 2.5, 0.6, 2.5, 2.5, 2.5, 2.5)
PRESSES_URL = (
    f"sim://?scene=presses&order={','.join(ORDER)}&force={','.join(map(str, FORCES))}&seed=0"
)


def training_scene():
    from spectratac.twin.scripted_presses import scripted_presses

    rng = np.random.default_rng(5)
    regions = list(vocab.REGIONS) * 6
    rng.shuffle(regions)
    forces = np.tile([0.6, 1.5, 3.0, 2.0, 4.0, 1.0], 9)  # either side of the 1.0 N threshold
    return scripted_presses(regions, forces)


def train_press_model(folder: Path) -> None:
    """Train the press decoder into folder/presses.stac."""
    from spectratac.sim.twin_dataset import from_twin_session
    from spectratac.train import TrainSpec, train
    from spectratac.twin import generate_session

    scene = training_scene()
    ds = from_twin_session(generate_session(scene, seed=0), scene)
    spec = TrainSpec.paper(targets=("Fx", "Fy", "Fz", "region", "contact"), epochs=60,
                           hidden=64, blocks=2, threads=1, context=2, drift="baseline")  # fmt: skip
    train(ds, spec, progress=False).save(folder / "presses.stac")


@pytest.fixture(scope="session")
def press_model(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Path of a .stac decoding Fx, Fy, Fz, region and contact (seconds to train), trained
    once per run: xdist workers share it (read-only; tests write under their own tmp_path)."""
    return made_once(tmp_path_factory, "press-model", train_press_model) / "presses.stac"
