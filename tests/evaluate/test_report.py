"""Evaluation end to end with stand-in decoders: holdout resolution, companions, baselines,
the twin oracle floor, and the report files (strict JSON, markdown, Fig. 3 panels)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from spectratac.dataset import Dataset
from spectratac.evaluate import Predictions, evaluate_model, write_report
from spectratac.sim.twin_dataset import from_twin_session
from spectratac.studies.oracle_floor import OracleFloor
from spectratac.train import SplitSpec, split_dataset
from spectratac.train.holdout import fingerprint, mark, resolve
from spectratac.twin import builtin_scenes as scenes
from spectratac.twin import generate_session


class Noisy:
    """Stand-in decoder: the truth plus known noise, a region from the label, contact, std."""

    def __init__(self, scale: float) -> None:
        self.scale = scale
        self.meta: dict = {}
        self.history = [1.0, 0.5, 0.25]

    def predict(self, dataset: Dataset, rows: np.ndarray) -> Predictions:
        rng = np.random.default_rng(int(self.scale * 1000))
        y = dataset.targets[rows]
        sd = self.scale * np.abs(y).mean(axis=0, keepdims=True) + 1e-6
        region = np.where(dataset.region[rows] > 0, dataset.region[rows], 5)
        return Predictions(
            list(dataset.target_names),
            y + rng.normal(size=y.shape) * sd,
            region=region,
            contact=dataset.in_contact[rows].copy(),
            std=np.broadcast_to(sd, y.shape).copy(),
        )


@pytest.fixture(scope="module")
def twin_ds() -> Dataset:
    sc = scenes.calibration_session(seed=7, duration_s=120.0)
    return from_twin_session(generate_session(sc, seed=7), sc)


def test_holdout_rebuilds_the_models_test_rows(twin_ds: Dataset) -> None:
    model = Noisy(0.1)
    split = split_dataset(twin_ds, SplitSpec("blocked", seed=2))
    mark(model, twin_ds, split)
    h = resolve(model.meta, twin_ds)
    assert h.status == "split" and np.array_equal(h.split.test, split.test)
    other = twin_ds.subset(np.arange(twin_ds.n - 10))
    assert fingerprint(other) != fingerprint(twin_ds)
    assert resolve(model.meta, other).status == "other"
    assert resolve({}, twin_ds).status == "unknown"


def test_both_splits_with_companion_baseline_and_oracle(twin_ds: Dataset, tmp_path: Path) -> None:
    models = {}
    for kind in ("blocked", "random"):
        models[kind] = Noisy(0.05)
        mark(models[kind], twin_ds, split_dataset(twin_ds, SplitSpec(kind)))
    base = Noisy(0.2)  # no record: its training rows are unknown
    ev = evaluate_model(
        models["blocked"],
        twin_ds,
        companions={"random": models["random"]},
        baseline=base,
        floor=OracleFloor(40),
    )
    assert list(ev.sections) == ["random", "blocked"]
    for sec in ev.sections.values():
        s = sec.decoder.scores
        assert s["region"]["accuracy"] == 1.0 and s["contact"]["accuracy"] == 1.0
        assert sec.oracle is not None and sec.oracle.scores["n"] == 40
        assert sec.baseline.scores["components"]["Fz"]["mae"] > s["components"]["Fz"]["mae"]
        assert "caveat" in sec.baseline_note
        assert 0.5 < s["coverage"]["Fz"]["0.68"] < 0.85
    rep = write_report(ev, tmp_path, {"path": "cal.npz"}, {"path": "m.stac"}, twin_ds)
    data = json.loads((tmp_path / "report.json").read_text(), parse_constant=pytest.fail)
    assert data["sections"]["blocked"]["decoder"]["n"] == rep["sections"]["blocked"]["n_rows"]
    assert data["paper"]["mae"]["Fz"] == 0.429
    md = (tmp_path / "report.md").read_text()
    assert "oracle MAE (n=40)" in md and "Blocked split" in md and "Random split" in md
    for sec in ("random", "blocked"):
        for panel in ("scatter", "abs_error", "r2", "confusion", "timeseries", "loss"):
            png = tmp_path / f"{sec}_{panel}.png"
            assert png.read_bytes()[:4] == b"\x89PNG" and f"({png.name})" in md


def test_a_split_without_a_companion_is_reported_missing(twin_ds: Dataset) -> None:
    m = Noisy(0.1)
    mark(m, twin_ds, split_dataset(twin_ds, SplitSpec("blocked")))
    ev = evaluate_model(m, twin_ds)
    assert not ev.sections["random"].available
    assert "companion" in ev.sections["random"].note
    # A baseline trained on the random split saw most blocked test rows: not comparable.
    b = Noisy(0.1)
    mark(b, twin_ds, split_dataset(twin_ds, SplitSpec("random")))
    ev = evaluate_model(m, twin_ds, baseline=b)
    assert ev.sections["blocked"].baseline is None
    assert "not comparable" in ev.sections["blocked"].baseline_note


def test_unknown_training_rows_score_the_whole_dataset(twin_ds: Dataset) -> None:
    ev = evaluate_model(Noisy(0.1), twin_ds)
    assert list(ev.sections) == ["all"] and ev.sections["all"].rows.size == twin_ds.n
    assert "every row" in ev.notes[0]


def test_other_sensors_get_no_paper_column(tmp_path: Path) -> None:
    rng = np.random.default_rng(0)
    ds = Dataset.generic(
        rng.normal(size=(200, 4)),
        rng.normal(size=200),
        list("abcd"),
        ["Fz"],
        region=rng.integers(1, 5, 200),
        press=np.repeat(np.arange(20), 10),
    )
    m = Noisy(0.1)
    mark(m, ds, split_dataset(ds, SplitSpec("blocked")))
    write_report(evaluate_model(m, ds), tmp_path, {"path": "g"}, None, ds)
    md = (tmp_path / "report.md").read_text()
    assert "paper" not in md.lower().replace("paper's protocol", "")
    assert "| Fz |" in md and "(oracle" not in md
