"""Assembling samples into decoder input vectors, in time order, one session at a time.

One implementation serves training, `Decoder.predict` (a loop over rows) and
`Decoder.stream` (one push per live sample), so all three see identical inputs.

Baseline (drift compensation): a per-channel running mean of the assembled sample that moves
only while the sample stays close to it (RMS relative deviation below GATE: no contact), with
time constant TAU samples. If no sample has passed the gate for STUCK samples (a session
that started under contact, or a step change of the light), it follows the samples anyway
until they pass again. Time constants are in samples, not seconds, so that the result does
not depend on clocks.

>>> lay = Layout(channels=("a",), steps=2)
>>> asm = Assembler(lay)
>>> asm.push(0, np.array([1.0]))[1], asm.push(1, np.array([2.0]))[1]
(False, True)
>>> asm.push(0, np.array([3.0]))[0].tolist()
[3.0, 2.0]
"""

from __future__ import annotations

from collections import deque

import numpy as np
from numpy.typing import NDArray

from spectratac.decode.layout import Layout

F64 = NDArray[np.float64]

TAU = 600.0  # 30 s at 20 Hz: far slower than a press, faster than thermal drift
GATE = 0.03  # RMS relative deviation below which a sample counts as no-contact
STUCK = 2400  # 2 min at 20 Hz without a no-contact sample: the baseline is wrong, follow


class Assembler:
    """Streaming state of one session: latest sample per step, history, baseline."""

    def __init__(self, layout: Layout) -> None:
        self.layout = layout
        c = len(layout.channels)
        self._c = c
        self._latest = np.zeros(layout.base)
        self._seen = np.zeros(layout.steps, bool)
        self._hist: deque[F64] = deque(maxlen=max(layout.lags, default=0) + 1)
        self._base: F64 | None = None
        self._ema: F64 | None = None  # (len(emas), base)
        self._alpha = 1.0 / np.asarray(layout.emas, dtype=np.float64)[:, None]
        self._out_of_gate = 0
        self._out = np.empty(layout.size)

    def reset(self) -> None:
        self._latest[:] = 0.0
        self._seen[:] = False
        self._hist.clear()
        self._base = None
        self._ema = None
        self._out_of_gate = 0

    def push(self, step: int, x: F64) -> tuple[F64, bool]:
        """Feed one sample (its step, its C inputs); return (assembled vector, valid).

        The returned array is reused by the next call: copy it to keep it. Invalid results
        (non-finite input, not every step seen yet, bad step) do not change the state.
        """
        lay = self.layout
        if not (0 <= step < lay.steps) or not np.all(np.isfinite(x)):
            self._out[:] = np.nan
            return self._out, False
        c = self._c
        self._latest[step * c : (step + 1) * c] = x
        self._seen[step] = True
        if not self._seen.all():
            self._out[:] = np.nan
            return self._out, False
        cur = self._latest.copy()
        self._hist.append(cur)
        out, b = self._out, lay.base
        out[:b] = cur
        n = len(self._hist)
        for i, lag in enumerate(lay.lags):
            out[(i + 1) * b : (i + 2) * b] = self._hist[max(n - 1 - lag, 0)]
        if lay.emas:
            if self._ema is None:
                self._ema = np.tile(cur, (len(lay.emas), 1))
            k = 1 + len(lay.lags)
            out[k * b : (k + len(lay.emas)) * b] = self._ema.reshape(-1)  # the past only
            self._ema += self._alpha * (cur - self._ema)
        if lay.drift:
            out[-b:] = self._baseline(cur)
        return out, True

    def _baseline(self, cur: F64) -> F64:
        if self._base is None:
            self._base = cur.copy()
            return self._base
        base = self._base.copy()  # the sample is judged against the baseline before it
        scale = np.abs(base) + 1e-6 + 0.01 * float(np.mean(np.abs(base)))
        rel = float(np.sqrt(np.mean(((cur - base) / scale) ** 2)))
        self._out_of_gate = 0 if rel < GATE else self._out_of_gate + 1
        if self._out_of_gate == 0 or self._out_of_gate > STUCK:
            self._base += (cur - self._base) / TAU
        return base


def session_order(session: NDArray[np.integer], t: F64) -> list[NDArray[np.intp]]:
    """Row indices of each session, in time order (ties keep row order)."""
    out = []
    for s in np.unique(session):
        rows = np.flatnonzero(session == s)
        out.append(rows[np.argsort(t[rows], kind="stable")])
    return out


def assemble(
    layout: Layout,
    inputs: F64,
    step: NDArray[np.integer] | None = None,
    session: NDArray[np.integer] | None = None,
    t: F64 | None = None,
) -> tuple[F64, NDArray[np.bool_]]:
    """Assembled vectors (N, D) and validity (N,) for rows of possibly several sessions.

    Rows are processed per session in time order `t` (default: row order); invalid rows are
    NaN. With a trivial layout the inputs pass through unchanged (non-finite rows invalid).
    """
    x = np.asarray(inputs, dtype=np.float64)
    n = x.shape[0]
    finite = np.all(np.isfinite(x), axis=1)
    if layout.trivial:
        u = x.copy()
        u[~finite] = np.nan
        return u, finite
    st = np.zeros(n, np.int64) if step is None else np.asarray(step, np.int64)
    ses = np.zeros(n, np.int64) if session is None else np.asarray(session)
    tt = np.arange(n, dtype=np.float64) if t is None else np.asarray(t, np.float64)
    u = np.full((n, layout.size), np.nan)
    valid = np.zeros(n, bool)
    asm = Assembler(layout)
    for rows in session_order(ses, tt):
        asm.reset()
        for r in rows:
            vec, ok = asm.push(int(st[r]), x[r])
            if ok:
                u[r] = vec
                valid[r] = True
    return u, valid
