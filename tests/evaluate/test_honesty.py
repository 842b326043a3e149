"""Reports say exactly what was held out (issue 22, "Honesty of reports"): training data is
training error, a CSV without contact labels is not scored for contact, the paper's figures
appear beside SpectraTac data only, and a ridge model is not said to have run epochs."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from spectratac.cli import main
from spectratac.dataset import Dataset
from spectratac.decode import Decoder
from spectratac.train import TrainSpec, fit

pytestmark = pytest.mark.train

RIDGE = TrainSpec(model="ridge", features="generic", targets=("Fz",))


def _generic(n: int = 400, seed: int = 0) -> Dataset:
    rng = np.random.default_rng(seed)
    x = rng.normal(size=(n, 3))
    y = x @ np.array([1.0, -2.0, 0.5]) + 0.05 * rng.normal(size=n)
    return Dataset.generic(x, y, ["a", "b", "c"], ["Fz"])


def _csv(ds: Dataset, path: Path) -> Path:
    x = ds.inputs
    y = ds.targets[:, 0]
    lines = ["a,b,c,Fz"] + [f"{r[0]},{r[1]},{r[2]},{v}" for r, v in zip(x, y, strict=True)]
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.fixture(scope="module")
def ridge_csv(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    d = tmp_path_factory.mktemp("honest")
    ds = _generic()
    data = _csv(ds, d / "data.csv")
    assert main(["train", str(data), "--model", "ridge", "--features", "generic",
                 "-o", str(d / "m.stac"), "--no-progress"]) == 0  # fmt: skip
    return d / "m.stac", data


def test_evaluating_on_the_training_data_says_training_error(
    ridge_csv: tuple[Path, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    model, data = ridge_csv
    capsys.readouterr()
    assert main(["evaluate", str(model), str(data), "-o", str(tmp_path / "r"),
                 "--json", "--no-progress"]) == 0  # fmt: skip
    rep = json.loads(capsys.readouterr().out)
    assert list(rep["sections"]) == ["training"]
    note = rep["sections"]["training"]["note"]
    assert note.startswith("not held out") and "training error" in note
    md = (tmp_path / "r" / "report.md").read_text()
    assert "held out from training" not in md and "NOT held out" in md


def test_other_data_is_still_held_out(ridge_csv: tuple[Path, Path], tmp_path: Path,
                                      capsys: pytest.CaptureFixture[str]) -> None:  # fmt: skip
    model, _ = ridge_csv
    other = _csv(_generic(seed=1), tmp_path / "other.csv")
    capsys.readouterr()
    assert main(["evaluate", str(model), str(other), "-o", str(tmp_path / "r"),
                 "--json", "--no-progress"]) == 0  # fmt: skip
    rep = json.loads(capsys.readouterr().out)
    assert "held out" in rep["sections"]["all"]["note"]


def test_no_contact_labels_no_paper_figures_no_epochs(
    ridge_csv: tuple[Path, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    model, data = ridge_csv
    capsys.readouterr()
    assert main(["evaluate", str(model), str(data), "-o", str(tmp_path / "r"),
                 "--no-progress"]) == 0  # fmt: skip
    out = capsys.readouterr().out
    assert "paper" not in out, out
    assert "contact accuracy not scored (no labels" in out, out
    rep = json.loads((tmp_path / "r" / "report.json").read_text())
    assert rep["paper"] is None
    assert rep["sections"]["training"]["decoder"]["contact"]["labels"] == "none"
    md = (tmp_path / "r" / "report.md").read_text()
    assert "paper" not in md.lower() and "Contact detection: not scored (no labels" in md
    # training a ridge model says how it was solved, not a number of epochs
    other = _csv(_generic(seed=2), tmp_path / "d.csv")
    assert main(["train", str(other), "--model", "ridge", "--features", "generic",
                 "-o", str(tmp_path / "m.stac"), "--no-progress"]) == 0  # fmt: skip
    trained = capsys.readouterr().out
    assert "closed form" in trained and "epochs" not in trained.split("\n")[1], trained


def test_contact_column_is_scored(tmp_path: Path) -> None:
    from spectratac.dataset.generic_io import load_table

    ds = _generic(50)
    lines = ["a,b,c,Fz,contact"] + [
        f"{r[0]},{r[1]},{r[2]},{v},{int(v > 0)}"
        for r, v in zip(ds.inputs, ds.targets[:, 0], strict=True)
    ]
    (tmp_path / "c.csv").write_text("\n".join(lines) + "\n")
    loaded = load_table(tmp_path / "c.csv")
    assert loaded.meta["contact_labels"] == "given"
    assert load_table(_csv(ds, tmp_path / "n.csv")).meta["contact_labels"] == "none"


def test_fit_without_holdout_records_the_dataset() -> None:
    ds = _generic()
    dec = fit(ds, RIDGE, progress=False).decoder
    from spectratac.train.holdout import resolve

    h = resolve(dec.meta, ds)
    assert h.status == "training" and h.rows is not None and h.rows.size == ds.n
    assert resolve(dec.meta, _generic(seed=3)).status == "other"
    assert isinstance(Decoder, type)


def test_training_rows_are_warned_of_in_the_terminal(
    ridge_csv: tuple[Path, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """On stderr beside the table, not only in report.md (issue 33); held-out data not."""
    model, data = ridge_csv
    capsys.readouterr()
    assert main(["evaluate", str(model), str(data), "-o", str(tmp_path / "r"),
                 "--no-progress"]) == 0  # fmt: skip
    err = capsys.readouterr().err
    warned = [line for line in err.splitlines() if line.startswith("warning:")]
    assert len(warned) == 1 and "own training rows" in warned[0]
    assert "training error" in warned[0]
    other = _csv(_generic(seed=1), tmp_path / "other.csv")
    assert main(["evaluate", str(model), str(other), "-o", str(tmp_path / "o"),
                 "--no-progress"]) == 0  # fmt: skip
    assert "training rows" not in capsys.readouterr().err
