"""Regression and classification metrics for F/T decoders.

>>> import numpy as np
>>> m = regression_metrics(np.array([[0.0], [2.0]]), np.array([[1.0], [2.0]]), ("Fz",))
>>> m["Fz"]["mae"], bool(m["Fz"]["rmse"] == np.sqrt(0.5)), m["Fz"]["r2"]
(0.5, True, 0.5)
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

AXES = ("Fx", "Fy", "Fz", "Mx", "My", "Mz")


def regression_metrics(
    y_true: NDArray[np.float64], y_pred: NDArray[np.float64], axes: tuple[str, ...] = AXES
) -> dict[str, dict[str, float]]:
    """MAE, RMSE and R^2 per axis."""
    err = y_pred - y_true
    out: dict[str, dict[str, float]] = {}
    for i, name in enumerate(axes):
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
