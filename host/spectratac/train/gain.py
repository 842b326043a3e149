"""Features of assembled inputs under a gain, without recomputing them: gain augmentation.

A gain g scales a row's whole assembled vector u (sample, lags, moving averages and drift
baseline alike). Its features follow in closed form: linear ones (u - c) L' become
g (u - c) L' + (g - 1) c L', ratio ones (u P') / (|u| Q' + eps) become
g (u P') / (g |u| Q' + eps), and monomials multiply those. So the parts are computed once per
row and every batch's gain costs a few element-wise operations instead of the feature
matrices' products (measured: those took 14 ms of every 256-row batch of TrainSpec.best()).

>>> from spectratac.decode.feature_matrices import build_features
>>> from spectratac.decode.layout import Layout
>>> from spectratac.decode.networks import init_weights
>>> from spectratac.decode.heads import Heads
>>> from spectratac.decode.runtime import Runtime
>>> lay = Layout(channels=("a", "b"), drift=True)
>>> fs = build_features("generic", lay)
>>> u = np.random.default_rng(0).uniform(10, 100, (5, lay.size))
>>> w = init_weights(("linear", 0, 0), fs.n_features, 1, np.random.default_rng(0))
>>> rt = Runtime.create(fs, ("linear", 0, 0), w, Heads(("Fz",)), u)
>>> view, g = GainView(rt, u), np.full((5, 1), 1.1)
>>> want = rt.with_dtype(np.float64).normalised(u * g)
>>> float(np.abs(view.z(np.arange(5), g) - want).max()) < 1e-4  # parts kept in float32
True
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from spectratac.decode.paper_features import EPS

F64 = NDArray[np.float64]


class GainView:
    """The z-scored features of rows of `u` (N, D) under per-row gains, for runtime `rt`."""

    def __init__(self, rt: Any, u: NDArray[Any]) -> None:
        fs = rt.features
        u = np.asarray(u, np.float64)
        self.lin = ((u - rt.center) @ fs.L.T).astype(np.float32)
        self.c_lin = rt.center @ fs.L.T
        self.has_rat = fs.P.shape[0] > 0
        self.num = (u @ fs.P.T).astype(np.float32) if self.has_rat else None
        self.den = (np.abs(u) @ fs.Q.T).astype(np.float32) if self.has_rat else None
        self.mon = fs.M
        self.mean, self.std = rt.scaler.mean, rt.scaler.std

    def parts(
        self, rows: NDArray[np.intp]
    ) -> tuple[NDArray[np.float32], NDArray[np.float32] | None, NDArray[np.float32] | None]:
        """The per-row parts (linear, ratio numerator, ratio denominator) of `rows`, for a
        loop that applies the gains itself (train/torch_loop.py: GainJitter)."""
        num = None if self.num is None else self.num[rows]
        den = None if self.den is None else self.den[rows]
        return self.lin[rows], num, den

    def z(self, rows: NDArray[np.intp], factor: F64) -> F64:
        """z-scored features (len(rows), F) of u[rows] * factor (factor: (len(rows), 1))."""
        g = np.asarray(factor, np.float64)
        f = g * self.lin[rows] + (g - 1.0) * self.c_lin
        if self.num is not None and self.den is not None:
            rat = g * self.num[rows] / (g * self.den[rows] + EPS)
            f = np.concatenate([f, rat], axis=1)
        if self.mon.shape[0]:
            padded = np.concatenate([f, np.ones((f.shape[0], 1))], axis=1)
            f = np.concatenate([f, np.prod(padded[:, self.mon], axis=-1)], axis=1)
        return (f - self.mean) / self.std
