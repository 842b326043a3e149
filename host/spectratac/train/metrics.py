"""Mean absolute error and class accuracy: the one definition that training's held-out check,
the auto recipe's cross-validation, `spectratac train`'s summary and evaluation score with.

`regression_metrics` and `region_accuracy` are the plain definitions over given arrays;
`target_mae` decides which rows of a decoder's estimates count (a valid estimate, a finite
target flagged valid) and `decoder_mae` predicts first.

>>> regression_metrics(np.array([[0.0], [2.0]]), np.array([[1.0], [2.0]]), ("Fz",))["Fz"]
{'mae': 0.5, 'rmse': 0.7071067811865476, 'r2': 0.5}
>>> region_accuracy(np.array([1, 2, -1, 2]), np.array([1, 3, 5, 2]))
0.6666666666666666
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from spectratac.dataset.schema import Dataset
from spectratac.decode.decoder import Decoder
from spectratac.decode.estimates import Estimates


def regression_metrics(
    y_true: NDArray[np.float64], y_pred: NDArray[np.float64], names: Sequence[str]
) -> dict[str, dict[str, float]]:
    """MAE, RMSE and R² per named column, over every row."""
    err = y_pred - y_true
    out: dict[str, dict[str, float]] = {}
    for i, name in enumerate(names):
        e = err[:, i]
        ss_res = float(np.sum(e * e))
        ss_tot = float(np.sum((y_true[:, i] - y_true[:, i].mean()) ** 2))
        out[name] = {
            "mae": float(np.mean(np.abs(e))),
            "rmse": float(np.sqrt(np.mean(e * e))),
            "r2": 1.0 - ss_res / ss_tot if ss_tot > 0 else float("nan"),
        }
    return out


def region_accuracy(labels: NDArray[np.integer], predicted: NDArray[np.integer]) -> float:
    """Accuracy over samples with a valid label (label -1 excluded)."""
    valid = labels > 0
    if not np.any(valid):
        return float("nan")
    return float(np.mean(predicted[valid] == labels[valid]))


def target_mae(
    est: Estimates, dataset: Dataset, rows: ArrayLike, names: Sequence[str]
) -> dict[str, float]:
    """MAE per decoded target `names` (est.targets' columns) of the estimates of `rows`, over
    the rows with a valid estimate and a finite target flagged valid (NaN if none)."""
    r = np.asarray(rows, np.intp)
    columns = list(dataset.target_names)
    tv = np.asarray(dataset.target_valid, bool)[r] & ~est.invalid
    out = {}
    for i, t in enumerate(names):
        y = np.asarray(dataset.targets, np.float64)[r, columns.index(t)]
        ok = tv & np.isfinite(y)
        if not ok.any():
            out[t] = float("nan")
            continue
        pred = est.targets[ok, i : i + 1]
        out[t] = regression_metrics(y[ok][:, None], pred, (t,))[t]["mae"]
    return out


def decoder_mae(dec: Decoder, dataset: Dataset, rows: ArrayLike) -> dict[str, float]:
    """MAE per regression target of `dec` on `rows` of `dataset` (see `target_mae`)."""
    r = np.asarray(rows, np.intp)
    return target_mae(dec.predict(dataset, r), dataset, r, dec.target_names)
