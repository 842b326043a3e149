"""The full demo pipeline on a short scene: every stage runs and leaves its artefacts."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from spectratac.apps.calibration_demo import DemoOptions, results_table, run_demo
from spectratac.dataset import Dataset
from spectratac.hardware.generated import vocabulary as vocab
from spectratac.studies.oracle_floor import OracleFloor

pytestmark = pytest.mark.train


@pytest.mark.slow
def test_demo_records_builds_trains_and_reports(tmp_path: Path) -> None:
    said: list[str] = []
    opts = DemoOptions(
        out=tmp_path, scene_s=60, speed=15, epochs=2, floor=OracleFloor(20), progress=False
    )
    summary = run_demo(opts, say=said.append)
    json.dumps(summary)  # JSON-ready
    rec = summary["recording"]
    assert rec["samples"] > 600 and rec["lost"] == 0 and rec["stopped_by"] == "scene_end"
    ds = Dataset.load(tmp_path / "data.npz")
    assert ds.n == summary["dataset"]["samples"] == rec["samples"]
    assert np.nanmin(ds.targets[:, 2]) < -1.0  # presses reach the reference as negative Fz
    for name in ("paper", "best"):
        assert (tmp_path / f"{name}.stac").exists()
        assert (tmp_path / f"report-{name}" / "report.md").exists()
        assert list((tmp_path / f"report-{name}").glob("*.png"))
        res = summary["results"][name]
        for kind in ("random", "blocked"):
            assert set(res[kind]["mae"]) == set(vocab.FT_AXES)
            assert all(np.isfinite(v) and v > 0 for v in res[kind]["mae"].values())
    table = results_table(summary["results"])
    assert table[2].startswith("Fx") and "0.161" in table[2]
    oracle = summary["results"]["paper"]["blocked"]["oracle_mae"]
    assert oracle is not None and set(oracle) == set(vocab.FT_AXES)
    assert any("[4/4]" in line for line in said)
