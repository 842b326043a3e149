"""The writing verbs' inputs, made once per module: a short recording, a generic CSV and a
ridge model trained on it."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from spectratac.cli import main
from spectratac.record import RecordOptions, record_url

RIDGE = ["--model", "ridge", "--features", "generic", "--no-progress"]


@pytest.fixture(scope="module")
def made(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """{"recording", "csv", "model"}: the inputs the verbs under test read."""
    d = tmp_path_factory.mktemp("inputs")
    rec = d / "rec1.mcap"
    record_url("sim://?scene=tour&speed=max&ft=bota", rec, RecordOptions(samples=80))
    x = np.random.default_rng(0).normal(size=(300, 3))
    y = x @ np.array([1.0, -2.0, 0.5])
    csv = d / "data.csv"
    csv.write_text(
        "a,b,c,Fz\n" + "".join(f"{a},{b},{c},{t}\n" for (a, b, c), t in zip(x, y, strict=True))
    )
    assert main(["train", str(csv), "-o", str(d / "m.stac"), *RIDGE]) == 0
    return {"recording": rec, "csv": csv, "model": d / "m.stac"}
