"""What the skin looks like at rest, and which way a press moves it: learned from training data
so that a live baseline can tell a pressed skin from a resting one before it adapts.

`rest` is the median assembled sample (every LED step's counts, layout `base` long) over rows
without contact; `press` is the unit direction in log counts along which contact moves a
sample away from rest. A press on SpectraTac raises red and lowers green, blue and clear, so
the projection `score(x) = press . log x` rises with force on every unit; its level at rest
differs between units, its rise does not, which is what `assemble._Baseline` relies on.

>>> import numpy as np
>>> x = np.array([[10.0, 100.0], [10.0, 101.0], [20.0, 50.0]])
>>> rest, press = rest_signature(x, np.array([False, False, True]), min_rows=1)
>>> rest.tolist(), press.round(2).tolist()
([10.0, 100.5], [0.7, -0.71])
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

F64 = NDArray[np.float64]
MIN_ROWS = 10  # rows needed on each side (rest, contact) for a usable signature


def log_counts(x: F64) -> F64:
    """log of counts floored at 1 (a dark channel has no log)."""
    return np.log(np.maximum(x, 1.0))


def rest_signature(
    cur: F64, contact: NDArray[np.bool_], min_rows: int = MIN_ROWS
) -> tuple[F64, F64]:
    """(rest, press) from current samples `cur` (N, B) and their contact labels (N,);
    empty arrays when either side has fewer than `min_rows` rows or contact does not move
    the counts (then the baseline behaves as it did before it had a signature)."""
    ok = np.all(np.isfinite(cur), axis=1)
    rest_rows, press_rows = cur[ok & ~contact], cur[ok & contact]
    if min(len(rest_rows), len(press_rows)) < min_rows:
        return np.zeros(0), np.zeros(0)
    rest = np.median(rest_rows, axis=0)
    d = np.median(log_counts(press_rows), axis=0) - log_counts(rest)
    norm = float(np.linalg.norm(d))
    if not np.isfinite(norm) or norm < 1e-9:
        return np.zeros(0), np.zeros(0)
    return rest, d / norm
