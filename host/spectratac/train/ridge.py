"""Ridge regression in closed form: the linear head of a decoder fitted by least squares.

`TrainSpec(model="ridge", degree=2 or 3)` is a polynomial ridge regression: the feature set's
monomials up to `degree` (decode/feature_matrices.py), z-scored, then one linear layer fitted
by solving the regularised normal equations. The result is an ordinary `Decoder`: the same
.stac file, the same torch-free Runtime, the same exports. Fitting needs NumPy only.

The penalty `alpha` multiplies the number of rows, so that it means the same for any amount of
data (features are z-scored: alpha 1e-3 shrinks a weight noticeably only where a feature's
share of variance is below 1e-3). With `ridge_alpha=0` it is chosen among ALPHAS by K-fold
cross-validation over the training rows' groups (whole sessions, presses or time blocks:
train/groups.py), minimising the mean absolute error the decoder is judged by.

>>> rng = np.random.default_rng(0)
>>> z = rng.normal(size=(200, 3))
>>> y = (z @ [1.0, -2.0, 0.5] + 3.0)[:, None]
>>> w, b = solve(gram(z, y), 1e-8, 200)
>>> np.round(w.ravel(), 3).tolist(), np.round(b, 3).tolist()
([1.0, -2.0, 0.5], [3.0])
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from spectratac.dataset.schema import Dataset
from spectratac.decode.errors import DecoderConfigError, DecoderDataError
from spectratac.train.groups import group_folds, row_groups

F64 = NDArray[np.float64]
ALPHAS = tuple(float(a) for a in np.logspace(-5, 1, 7))
CV_FOLDS = 5


@dataclass(frozen=True)
class Gram:
    """Sufficient statistics of a least-squares fit with an intercept: [z, 1]' [z, 1] and
    [z, 1]' y over some rows."""

    zz: F64
    zy: F64
    n: int

    def __sub__(self, other: Gram) -> Gram:
        return Gram(self.zz - other.zz, self.zy - other.zy, self.n - other.n)


def gram(z: F64, y: F64) -> Gram:
    z1 = np.concatenate([z, np.ones((z.shape[0], 1))], axis=1)
    return Gram(z1.T @ z1, z1.T @ y, int(z.shape[0]))


def solve(g: Gram, alpha: float, n_scale: int) -> tuple[F64, F64]:
    """(W (F, T), intercept (T,)) minimising |y - z W - b|^2 + alpha n_scale |W|^2."""
    f = g.zz.shape[0] - 1
    pen = np.full(f + 1, alpha * n_scale)
    pen[-1] = 0.0  # the intercept is not shrunk
    a = g.zz + np.diag(pen)
    try:
        wb = np.linalg.solve(a, g.zy)
    except np.linalg.LinAlgError:
        wb = np.linalg.lstsq(a, g.zy, rcond=None)[0]
    return wb[:f], wb[f]


def choose_alpha(z: F64, y: F64, ids: NDArray[np.int64], k: int = CV_FOLDS) -> tuple[float, F64]:
    """The alpha of ALPHAS with the lowest K-fold grouped CV mean absolute error, and every
    alpha's CV error (mean over targets of scaled y)."""
    rows = np.arange(z.shape[0])
    n_groups = np.unique(ids[ids >= 0]).size
    if n_groups < 2:
        return ALPHAS[len(ALPHAS) // 2], np.full(len(ALPHAS), np.nan)
    folds = group_folds(ids, rows, min(k, n_groups))
    total = gram(z, y)
    err = np.zeros(len(ALPHAS))
    for held in folds:
        g_fit = total - gram(z[held], y[held])
        for i, alpha in enumerate(ALPHAS):
            w, b = solve(g_fit, alpha, g_fit.n)
            err[i] += np.mean(np.abs(z[held] @ w + b - y[held])) * held.size
    err /= rows.size
    return ALPHAS[int(np.argmin(err))], err


def fit_ridge(
    spec: Any,
    p: Any,
    data: dict[str, Any],
    fit_rows: NDArray[np.intp],
    val_rows: NDArray[np.intp],
    dataset: Dataset,
) -> tuple[dict[str, NDArray[np.float32]], list[float], list[float], dict[str, Any]]:
    """Head weights (the torch module's names), [training MAE], [validation MAE] in scaled
    target units, and the penalty chosen (with its CV curve), for `train`'s plan `p`."""
    heads = p.heads
    if heads.n_classes or heads.contact or heads.uncertainty or not heads.n_reg:
        raise DecoderConfigError(
            "model='ridge' fits regression targets only (no classes, contact or uncertainty "
            "heads): drop those targets or train a network model"
        )
    ok = data["y_ok"][fit_rows]
    rows = fit_rows[ok]
    if rows.size < 2:
        raise DecoderDataError("ridge regression needs at least 2 rows with valid targets")
    z, y = data["z"][rows], data["y"][rows]
    alpha = float(spec.ridge_alpha)
    cv: list[float] = []
    if alpha == 0.0:
        g = row_groups(dataset.session, dataset.press, dataset.t_end, rows)
        alpha, errs = choose_alpha(z, y, g.ids[rows])
        cv = [float(e) for e in errs]
    w, b = solve(gram(z, y), alpha, rows.size)
    history = [float(np.mean(np.abs(z @ w + b - y)))]
    val_history: list[float] = []
    vr = val_rows[data["y_ok"][val_rows]]
    if vr.size:
        val_history.append(float(np.mean(np.abs(data["z"][vr] @ w + b - data["y"][vr]))))
    weights = {
        "head.weight": np.ascontiguousarray(w.T, np.float32),
        "head.bias": np.asarray(b, np.float32),
    }
    info = {"alpha": alpha, "alphas": list(ALPHAS), "cv_mae_scaled": cv}
    return weights, history, val_history, info
