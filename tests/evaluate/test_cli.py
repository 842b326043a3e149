"""`spectratac evaluate` on tiny data (real training)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from spectratac.cli import main
from spectratac.dataset import Dataset
from spectratac.decode import Decoder
from spectratac.evaluate.fit_both_splits import fit_and_evaluate, save_models
from spectratac.sim.twin_dataset import from_twin_session
from spectratac.train import TrainSpec
from spectratac.twin import builtin_scenes as scenes
from spectratac.twin import generate_session

pytestmark = pytest.mark.train

TINY = TrainSpec.paper(epochs=2, hidden=16, blocks=1)


def _twin(seed: int, duration: float = 60.0) -> Dataset:
    sc = scenes.calibration_session(seed=seed, duration_s=duration)
    return from_twin_session(generate_session(sc, seed=seed), sc)


@pytest.fixture(scope="module")
def trained(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path, Dataset]:
    d = tmp_path_factory.mktemp("models")
    ds = _twin(5)
    data = ds.save(d / "cal.npz")
    res = fit_and_evaluate(ds, TINY)
    files = save_models(res, d / "model.stac")
    return files["blocked"], data, ds


def _json(capsys: pytest.CaptureFixture[str], argv: list[str]) -> dict:
    assert main(argv) == 0
    return json.loads(capsys.readouterr().out)


def test_fit_and_evaluate_records_its_split(trained) -> None:
    model, _, ds = trained
    dec = Decoder.load(model)
    rec = dec.meta["holdout"]
    assert rec["split"]["kind"] == "blocked" and rec["companions"] == {
        "random": "model.random.stac"
    }
    assert rec["n_train"] + rec["n_test"] <= ds.n


def test_evaluate_both_splits_on_the_training_dataset(trained, tmp_path, capsys) -> None:
    model, data, _ = trained
    rep = _json(
        capsys,
        [
            "evaluate",
            str(model),
            str(data),
            "-o",
            str(tmp_path),
            "--json",
            "--no-progress",
            "--oracle-samples",
            "15",
        ],
    )
    assert [k for k, s in rep["sections"].items() if s["available"]] == ["random", "blocked"]
    blocked = rep["sections"]["blocked"]
    assert blocked["decoder"]["n"] == Decoder.load(model).meta["holdout"]["n_test"]
    assert blocked["oracle"]["n"] == 15 and "Fz" in blocked["decoder"]["components"]
    assert (tmp_path / "report.md").exists() and (tmp_path / "blocked_confusion.png").exists()
    # Human output names the splits and where the report is.
    assert (
        main(
            [
                "evaluate",
                str(model),
                str(data),
                "-o",
                str(tmp_path / "h"),
                "--split",
                "blocked",
                "--no-progress",
                "--oracle-samples",
                "0",
            ]
        )
        == 0
    )
    out = capsys.readouterr().out
    assert "blocked split" in out and "report:" in out and "random:" not in out


def test_evaluate_on_another_dataset_scores_every_row(trained, tmp_path, capsys) -> None:
    model, _, _ = trained
    other = _twin(6, 30.0)
    path = other.save(tmp_path / "other.npz")
    argv = ["evaluate", str(model), str(path), "-o", str(tmp_path / "r"), "--json"]
    argv += ["--no-progress", "--oracle-samples", "0", "--baseline", str(model)]
    assert main(argv) == 0
    out = capsys.readouterr()
    rep = json.loads(out.out)
    # the CLI says it as one line a person reads (no Python file:line), naming both units
    lines = [s for s in out.err.splitlines() if "twin-6" in s]  # the model and the baseline
    assert len(lines) == 2, out.err
    for line in lines:
        assert line.startswith("spectratac: warning:") and "twin-5" in line and ".py:" not in line
    sec = rep["sections"]["all"]
    assert sec["n_rows"] == other.n and "another dataset" in rep["notes"][0]
    assert "unit 'twin-5'" in rep["notes"][1]
    assert sec["baseline"]["components"]["Fz"]["mae"] == pytest.approx(
        sec["decoder"]["components"]["Fz"]["mae"]
    )


def test_evaluate_errors_exit_3(trained, tmp_path, capsys) -> None:
    model, data, _ = trained
    assert main(["evaluate", str(model), str(tmp_path / "none.npz"), "-o", "x"]) == 3
    assert "cannot read dataset" in capsys.readouterr().err
    with pytest.raises(SystemExit) as exit_:  # a usage error (cli.values), before any work
        main(["evaluate", str(model), str(data), "-o", "x", "--oracle-samples", "-1"])
    assert exit_.value.code == 2 and "--oracle-samples: -1 is" in capsys.readouterr().err
    generic = Dataset.generic(np.ones((10, 2)), np.zeros(10), ["a", "b"], ["Fz"])
    g = generic.save(tmp_path / "g.npz")
    assert main(["evaluate", str(model), str(g), "-o", str(tmp_path / "g")]) == 3
    assert "inputs" in capsys.readouterr().err


def test_evaluate_says_its_time_before_it_starts(trained, tmp_path, capsys, monkeypatch) -> None:
    """Issue 26: the estimate (prediction and the twin's inverse, rates measured now) is on
    stderr before the progress bar, which then shows the time left; --json carries it."""
    from tests.terminal import assert_estimate_first, pretend_terminal

    pretend_terminal(monkeypatch)
    model, data, _ = trained
    assert main(["evaluate", str(model), str(data), "-o", str(tmp_path / "a"),
                 "--oracle-samples", "30"]) == 0  # fmt: skip
    line = assert_estimate_first(capsys.readouterr().err, "evaluate")
    assert "predict" in line and "oracle" in line
    rep = _json(capsys, ["evaluate", str(model), str(data), "-o", str(tmp_path / "b"),
                         "--oracle-samples", "30", "--json"])  # fmt: skip
    assert rep["estimate"]["parts_s"]["oracle"] > 0 and rep["estimate"]["calibration_s"] > 0
