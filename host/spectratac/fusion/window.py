"""The reference F/T over each optical integration window: the mean of the F/T samples
inside it, never an interpolation across missing data.

A window is valid only when F/T samples cover it: there is a sample at or before its start
and one at or after its end, and no two neighbouring samples from the one before the start
to the one after the end are more than max_gap_s apart. Anything else (a dropout inside or
at the edge of the window, a window outside the recording) gives NaN and valid = False.

>>> t = np.arange(0.0, 1.0, 0.001)                    # 1 kHz F/T on the host clock
>>> w = np.zeros((t.size, 6)); w[:, 2] = -t           # Fz ramps down
>>> gone = (t > 0.5) & (t < 0.6)                       # a 100 ms dropout
>>> mean, valid, count = window_average(t[~gone], w[~gone], [0.1, 0.5, 0.9], [0.2, 0.55, 1.5])
>>> np.round(mean[:, 2], 4).tolist(), valid.tolist(), count.tolist()
([-0.1495, nan, nan], [True, False, False], [100, 1, 100])
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from spectratac.fusion.clock import ClockFitError

F64 = NDArray[np.float64]

GAP_PERIODS = 3.0  # default max_gap_s, in median F/T sample periods


def window_average(
    ft_host_time: ArrayLike,
    wrench: ArrayLike,
    t_start_host: ArrayLike,
    t_end_host: ArrayLike,
    *,
    max_gap_s: float | None = None,
) -> tuple[F64, NDArray[np.bool_], NDArray[np.int64]]:
    """Mean wrench (N, 6) over each window [t_start, t_end), whether it is valid, and how many
    F/T samples it averaged. F/T times must be on the host clock (ClockModel.to_host of the
    sensor times, not raw arrival times); rows with a non-finite time or wrench count as
    missing. max_gap_s defaults to GAP_PERIODS median sample periods."""
    t = np.asarray(ft_host_time, dtype=np.float64).ravel()
    w = np.asarray(wrench, dtype=np.float64)
    t0 = np.atleast_1d(np.asarray(t_start_host, dtype=np.float64))
    t1 = np.atleast_1d(np.asarray(t_end_host, dtype=np.float64))
    if w.ndim != 2 or w.shape[0] != t.size:
        raise ClockFitError(f"wrench has shape {w.shape}; give one row per F/T time ({t.size})")
    if t0.shape != t1.shape:
        raise ClockFitError("window starts and ends must pair up")
    ok = np.isfinite(t) & np.all(np.isfinite(w), axis=1)
    t, w = t[ok], w[ok]
    if t.size > 1 and np.any(np.diff(t) < 0):
        order = np.argsort(t, kind="stable")
        t, w = t[order], w[order]
    n_win = t0.size
    mean = np.full((n_win, w.shape[1]), np.nan)
    count = np.zeros(n_win, dtype=np.int64)
    valid = np.zeros(n_win, dtype=bool)
    if t.size == 0:
        return mean, valid, count
    if max_gap_s is None:
        max_gap_s = GAP_PERIODS * float(np.median(np.diff(t))) if t.size > 1 else 0.0
    i0 = np.searchsorted(t, t0, side="left")  # first sample inside
    i1 = np.searchsorted(t, t1, side="left")  # first sample at or after the end
    count = np.maximum(i1 - i0, 0)
    before = np.searchsorted(t, t0, side="right") - 1  # last sample at or before the start
    # big[i]: the step from sample i to i+1 is a gap; prefix sums count gaps between indices
    big = np.r_[0, np.cumsum(np.diff(t) > max_gap_s)]
    covered = (before >= 0) & (i1 < t.size) & np.isfinite(t0) & np.isfinite(t1) & (t1 > t0)
    b, e = np.clip(before, 0, t.size - 1), np.clip(i1, 0, t.size - 1)
    valid = covered & (big[e] - big[b] == 0) & (count > 0)
    sums = np.vstack([np.zeros((1, w.shape[1])), np.cumsum(w, axis=0)])
    idx = np.flatnonzero(valid)
    mean[idx] = (sums[i1[idx]] - sums[i0[idx]]) / count[idx, None]
    return mean, valid, count
