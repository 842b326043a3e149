"""`spectratac twin` verbs: generate writes an npz; a reduced report gives sensible figures."""

from __future__ import annotations

import json

import numpy as np
import pytest
from spectratac.cli import main


def test_generate_writes_npz(tmp_path, capsys) -> None:
    out = tmp_path / "s.npz"
    assert (
        main(["twin", "generate", "-o", str(out), "--scene", "idle", "--duration", "2", "--json"])
        == 0
    )
    summary = json.loads(capsys.readouterr().out)
    assert summary["samples"] == 40 and out.exists()
    assert np.load(out)["counts"].shape == (40, 3, 5)


def test_generate_rejects_unknown_scene(tmp_path, capsys) -> None:
    assert main(["twin", "generate", "-o", str(tmp_path / "x.npz"), "--scene", "nope"]) == 3
    assert "unknown scene" in capsys.readouterr().err


@pytest.mark.train
def test_reduced_report_is_sensible(capsys) -> None:
    # 5 minutes, 6 epochs: far from the paper's budget, but the recipe must already learn.
    code = main(
        [
            "twin",
            "report",
            "--json",
            "--duration",
            "300",
            "--epochs",
            "6",
            "--oracle-samples",
            "60",
            "--no-progress",
        ]
    )
    assert code == 0
    rep = json.loads(capsys.readouterr().out)
    rnd = rep["splits"]["random"]["recipe"]
    assert rep["session"]["samples"] == 6000
    assert rnd["axes"]["Fz"]["r2"] > 0.6
    assert rnd["axes"]["Fz"]["mae"] < 1.5
    assert rnd["region_accuracy"] > 0.5
    for split in ("random", "heldout"):
        for who in ("recipe", "oracle"):
            axes = rep["splits"][split][who]["axes"]
            assert all(np.isfinite(axes[a]["mae"]) for a in axes)
