"""Evaluation metrics: per-component regression scores with invalid rows ignored, error
percentiles, region accuracy with its 9x9 confusion matrix, contact detection, and the
coverage of predicted uncertainty intervals.

The scores are built on training's own definitions of MAE, RMSE, R² and accuracy
(`spectratac.train.metrics`: one implementation for the held-out check and evaluation); they
decide which rows count (finite target, target_valid) and add what the paper's Fig. 3 shows.

>>> import numpy as np
>>> y = np.array([[0.0], [1.0], [np.nan], [3.0]])
>>> p = np.array([[0.5], [1.0], [9.0], [3.0]])
>>> m = regression_scores(y, p, ["Fz"])["Fz"]
>>> m["n"], m["mae"], m["p50"]
(3, 0.16666666666666666, 0.0)
>>> c = region_scores(np.array([1, 2, -1, 2]), np.array([1, 3, 5, 2]))
>>> c["accuracy"], c["n"], c["confusion"][1][2]
(0.6666666666666666, 3, 1)
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from spectratac.decode.estimates import interval_factor
from spectratac.hardware.generated import vocabulary as vocab
from spectratac.train.metrics import region_accuracy, regression_metrics

F64 = NDArray[np.float64]
PERCENTILES = (50, 90, 95, 99)
#: Central interval levels reported for calibrated uncertainty.
COVERAGE_LEVELS = (0.68, 0.95)


def valid_rows(y_true: ArrayLike, valid: ArrayLike | None = None) -> NDArray[np.bool_]:
    """(N, T) mask: the target is finite and its row is flagged valid."""
    y = np.asarray(y_true, dtype=np.float64)
    ok = np.isfinite(y)
    if valid is not None:
        ok &= np.asarray(valid, dtype=bool).reshape(-1, 1)
    return ok


def regression_scores(
    y_true: ArrayLike,
    y_pred: ArrayLike,
    names: Sequence[str],
    valid: ArrayLike | None = None,
) -> dict[str, dict[str, float]]:
    """Per component: n, MAE, RMSE, R², absolute-error percentiles and maximum.

    Rows whose target is NaN/inf or whose `valid` flag is False are ignored for that
    component; a component without any valid row reports n = 0 and NaN scores.
    """
    y = np.asarray(y_true, dtype=np.float64)
    p = np.asarray(y_pred, dtype=np.float64)
    if y.shape != p.shape or y.ndim != 2 or y.shape[1] != len(names):
        raise ValueError(f"targets {y.shape} and predictions {p.shape} must match {len(names)}")
    ok = valid_rows(y, valid) & np.isfinite(p)
    out: dict[str, dict[str, float]] = {}
    for j, name in enumerate(names):
        rows = ok[:, j]
        n = int(rows.sum())
        if n == 0:
            out[name] = {"n": 0, "mae": np.nan, "rmse": np.nan, "r2": np.nan}
            continue
        m = regression_metrics(y[rows, j : j + 1], p[rows, j : j + 1], (name,))[name]
        err = np.abs(p[rows, j] - y[rows, j])
        m.update({f"p{q}": float(np.percentile(err, q)) for q in PERCENTILES})
        out[name] = {"n": n, **m, "max": float(err.max())}
    return out


def region_scores(
    labels: ArrayLike, predicted: ArrayLike, n_classes: int = vocab.N_REGIONS
) -> dict[str, Any]:
    """Accuracy over labelled rows (label >= 1; -1 ignored) and the confusion matrix (row: true
    class, column: predicted; counts as nested lists). The matrix has `n_classes` rows, or
    more if a label or prediction is larger (other sensors may have other class counts)."""
    lab = np.asarray(labels).astype(np.int64)
    pred = np.asarray(predicted).astype(np.int64)
    ok = lab >= 1
    k = int(max(n_classes, lab.max(initial=0), pred.max(initial=0)))
    conf = np.zeros((k, k), np.int64)
    inside = ok & (pred >= 1)
    np.add.at(conf, (lab[inside] - 1, pred[inside] - 1), 1)
    return {
        "n": int(ok.sum()),
        "accuracy": region_accuracy(lab, pred),
        "confusion": conf.tolist(),
    }


def contact_scores(truth: ArrayLike, predicted: ArrayLike) -> dict[str, float]:
    """Contact/no-contact detection: accuracy, precision, recall and F1 of `predicted`."""
    t = np.asarray(truth, dtype=bool)
    p = np.asarray(predicted, dtype=bool)
    tp = float(np.sum(t & p))
    fp = float(np.sum(~t & p))
    fn = float(np.sum(t & ~p))
    prec = tp / (tp + fp) if tp + fp else float("nan")
    rec = tp / (tp + fn) if tp + fn else float("nan")
    f1 = 2 * prec * rec / (prec + rec) if prec + rec > 0 else float("nan")
    return {
        "n": int(t.size),
        "accuracy": float(np.mean(t == p)) if t.size else float("nan"),
        "precision": prec,
        "recall": rec,
        "f1": f1,
    }


def interval_coverage(
    y_true: ArrayLike,
    mean: ArrayLike,
    std: ArrayLike,
    names: Sequence[str],
    valid: ArrayLike | None = None,
    levels: Sequence[float] = COVERAGE_LEVELS,
) -> dict[str, dict[str, float]]:
    """Fraction of valid targets inside the decoder's central interval mean ± k·std per
    level (`decode.estimates.interval_factor`: the uncertainty head's errors are Laplace),
    so that a calibrated 68 % interval holds ~68 % of them; plus the mean predicted std.

    >>> import numpy as np
    >>> y = np.random.default_rng(0).laplace(scale=1 / np.sqrt(2), size=(4000, 1))
    >>> c = interval_coverage(y, np.zeros_like(y), np.ones_like(y), ["Fz"])["Fz"]
    >>> abs(c["0.68"] - 0.68) < 0.03, abs(c["0.95"] - 0.95) < 0.02
    (True, True)
    """
    y = np.asarray(y_true, dtype=np.float64)
    mu = np.asarray(mean, dtype=np.float64)
    sd = np.asarray(std, dtype=np.float64)
    ok = valid_rows(y, valid) & np.isfinite(mu) & np.isfinite(sd)
    out: dict[str, dict[str, float]] = {}
    for j, name in enumerate(names):
        rows = ok[:, j]
        z = np.abs(y[rows, j] - mu[rows, j]) / np.maximum(sd[rows, j], 1e-12)
        d: dict[str, float] = {"n": int(rows.sum())}
        for lv in levels:
            k = interval_factor(lv)
            d[f"{lv:g}"] = float(np.mean(z <= k)) if rows.any() else float("nan")
        d["mean_std"] = float(np.mean(sd[rows, j])) if rows.any() else float("nan")
        out[name] = d
    return out


def improvement(reference: float, value: float) -> float:
    """Relative error reduction in percent: 25.0 means `value` is 25 % below `reference`.

    >>> round(improvement(0.4, 0.3), 6)
    25.0
    """
    if not np.isfinite(reference) or reference == 0 or not np.isfinite(value):
        return float("nan")
    return float(100.0 * (reference - value) / reference)
