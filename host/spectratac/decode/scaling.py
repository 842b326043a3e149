"""Input z-scoring and zero-anchored target scaling, fitted on the training set only.

Targets are divided by their standard deviation without subtracting a mean, so that the
resting state (zero force, zero torque) stays exactly zero in the scaled space.

>>> y = np.array([[0.0, 1.0], [0.0, -1.0], [2.0, 3.0]])
>>> s = ZeroAnchoredScaler.fit(y)
>>> s.transform(np.zeros((1, 2))).tolist()
[[0.0, 0.0]]
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

F64 = NDArray[np.float64]


def _safe_std(x: F64) -> F64:
    sd = x.std(axis=0)
    return np.where(sd > 1e-12, sd, 1.0)


@dataclass(frozen=True)
class Standardizer:
    """z = (x - mean) / std per column."""

    mean: F64
    std: F64

    @staticmethod
    def fit(x: F64) -> Standardizer:
        return Standardizer(mean=x.mean(axis=0), std=_safe_std(x))

    def transform(self, x: F64) -> F64:
        return (x - self.mean) / self.std


@dataclass(frozen=True)
class ZeroAnchoredScaler:
    """y~ = y / std per column (no centring)."""

    std: F64

    @staticmethod
    def fit(y: F64) -> ZeroAnchoredScaler:
        return ZeroAnchoredScaler(std=_safe_std(y))

    def transform(self, y: F64) -> F64:
        return y / self.std

    def inverse(self, y: F64) -> F64:
        return y * self.std
