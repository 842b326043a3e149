"""Training error against held-out-group error, and when their ratio calls for a warning.

A decoder whose error on whole held-out groups (sessions, presses, time blocks) is many times
its error on its training rows has learnt what is particular to the training groups: session
offsets, drift, the exact presses. GAP_WARN = 2, from measurements on the synthetic skin
(`spectratac.sim.generic_skin`, 8 sessions of 8 s, the paper's recipe, 10 epochs): with
sessions that are alike (drift=False) the ratio is 1.2, the cost of a new session's noise
and unseen press positions; with session-level gains, offsets and ageing (drift=True) it is
5.8, and 19.5 training on 24 sessions of 20 s and testing on 12 later ones. The CV ratios of
the ridge baselines on the drifting skin stay at 1.0-1.2. A ratio above 2 is no longer noise.

>>> gap({"Fz": 0.25}, {"Fz": 4.8})
(19.2, 'held-out error is 19.2x the training error (Fz; warning above 2x)')
>>> gap({"Fz": 1.0}, {"Fz": 1.3})
(1.3, None)
"""

from __future__ import annotations

import math

GAP_WARN = 2.0


def gap(train: dict[str, float], held: dict[str, float]) -> tuple[float, str | None]:
    """(largest held-out / training MAE ratio over targets, warning text or None)."""
    ratios = {
        t: held[t] / train[t]
        for t in held
        if t in train and math.isfinite(held[t]) and math.isfinite(train[t]) and train[t] > 0
    }
    if not ratios:
        return float("nan"), None
    worst = max(ratios, key=lambda t: ratios[t])
    r = round(ratios[worst], 2)
    if r <= GAP_WARN:
        return r, None
    return r, f"held-out error is {r}x the training error ({worst}; warning above {GAP_WARN:g}x)"
