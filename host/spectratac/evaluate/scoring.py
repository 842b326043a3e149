"""Score predictions on rows of a dataset: every metric the report shows, plus the arrays its
plots need.

>>> import numpy as np
>>> from spectratac.dataset import Dataset
>>> ds = Dataset.generic(np.zeros((3, 1)), np.array([0.0, 1.0, 2.0]), ["a"], ["Fz"],
...                      region=np.array([1, 1, -1]))
>>> p = Predictions(["Fz"], np.array([[0.0], [1.5], [2.0]]), region=np.array([1, 2, 3]))
>>> r = score(ds, np.arange(3), p)
>>> r.scores["components"]["Fz"]["mae"], r.scores["region"]["accuracy"]
(0.16666666666666666, 0.5)
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from spectratac.dataset.schema import Dataset
from spectratac.evaluate.metrics import (
    contact_scores,
    interval_coverage,
    region_scores,
    regression_scores,
)
from spectratac.evaluate.predictions import Predictions

F64 = NDArray[np.float64]


@dataclass
class Scored:
    """Scores (JSON-ready) and the aligned arrays behind them."""

    scores: dict[str, Any]
    rows: NDArray[np.int64]
    names: list[str]
    y_true: F64
    y_pred: F64
    region_true: NDArray[np.int64]
    region_pred: NDArray[np.int64] | None


def score(dataset: Dataset, rows: NDArray[np.int64], pred: Predictions) -> Scored:
    """Targets the decoder does not predict are left out; rows with invalid targets ignored."""
    a = dataset.arrays
    rows = np.asarray(rows, dtype=np.int64)
    names = pred.predicts(dataset.target_names) or []
    cols = [dataset.target_names.index(n) for n in names]
    y = np.asarray(a["targets"][rows][:, cols], dtype=np.float64)
    p = pred.aligned(names)
    valid = a["target_valid"][rows]
    scores: dict[str, Any] = {
        "n": int(rows.size),
        "n_valid_targets": int(np.sum(valid)),
        # Rows the decoder returned no estimate for (invalid input, incomplete context).
        "n_unpredicted": int(np.sum(~np.all(np.isfinite(p), axis=1))) if names else 0,
        "components": regression_scores(y, p, names, valid),
    }
    labels = np.asarray(a["region"][rows], dtype=np.int64)
    if pred.region is not None:
        scores["region"] = region_scores(labels, pred.region)
    if pred.contact is not None and not has_contact_labels(dataset):
        scores["contact"] = {"accuracy": None, "labels": "none", "n": 0}
    elif pred.contact is not None:
        scores["contact"] = contact_scores(a["in_contact"][rows], pred.contact)
        cp = pred.contact_prob
        scores["contact"]["source"] = (
            "head" if cp is not None and np.isfinite(cp).any() else "derived from |F|"
        )
    if pred.std is not None:
        scores["coverage"] = interval_coverage(y, p, pred.aligned(names, std=True), names, valid)
    return Scored(scores, rows, names, y, p, labels, pred.region)


def has_contact_labels(dataset: Dataset) -> bool:
    """Whether `dataset.in_contact` is a label (recorded, or a contact column) rather than the
    all-False default of data that has none (meta "contact_labels" == "none")."""
    return dataset.meta.get("contact_labels") != "none"
