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

import math
from collections import deque

import numpy as np
from numpy.typing import NDArray

from spectratac.decode.layout import Layout

F64 = NDArray[np.float64]

TAU = 600.0  # 30 s at 20 Hz: far slower than a press, faster than thermal drift
GATE = 0.03  # RMS relative deviation below which a sample counts as no-contact
STUCK = 2400  # 2 min at 20 Hz without a no-contact sample: the baseline is wrong, follow


class _Ema:
    """Moving averages of the assembled sample; `step` returns them before the update."""

    def __init__(self, taus: tuple[float, ...]) -> None:
        self.alpha = 1.0 / np.asarray(taus, dtype=np.float64)[:, None]
        self.value: F64 | None = None  # (len(taus), base)

    def step(self, cur: F64, out: F64) -> None:
        """Write the averages before this sample into `out` (len(taus) * base,)."""
        if self.value is None:
            self.value = np.tile(cur, (self.alpha.shape[0], 1))
        out[:] = self.value.reshape(-1)  # the past only
        self.value += self.alpha * (cur - self.value)


class _Baseline:
    """Gated running no-contact baseline; `step` writes it as it was before the sample."""

    def __init__(self) -> None:
        self.value: F64 | None = None
        self.out_of_gate = 0

    def step(self, cur: F64, out: F64) -> None:
        base = self.value
        if base is None:
            self.value = cur.copy()
            out[:] = cur
            return
        out[:] = base  # the sample is judged against the baseline before it
        ab = np.abs(base)
        scale = ab + (1e-6 + 0.01 * float(ab.sum()) / ab.shape[0])
        diff = cur - base
        dev = diff / scale
        rel = math.sqrt(float(np.dot(dev, dev)) / dev.shape[0])
        self.out_of_gate = 0 if rel < GATE else self.out_of_gate + 1
        if self.out_of_gate == 0 or self.out_of_gate > STUCK:
            diff /= TAU
            base += diff


class Assembler:
    """Streaming state of one session: latest sample per step, history, EMAs, baseline.

    This is the reference implementation; `assemble` computes the same vectors for whole
    sessions at once (tests check they agree bit for bit).
    """

    def __init__(self, layout: Layout) -> None:
        self.layout = layout
        self._c = len(layout.channels)
        self._latest = np.zeros(layout.base)
        self._seen = np.zeros(layout.steps, bool)
        self._hist: deque[F64] = deque(maxlen=max(layout.lags, default=0) + 1)
        self._ema = _Ema(layout.emas)
        self._base = _Baseline()
        self._out = np.empty(layout.size)

    def reset(self) -> None:
        self._latest[:] = 0.0
        self._seen[:] = False
        self._hist.clear()
        self._ema = _Ema(self.layout.emas)
        self._base = _Baseline()

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
            k = 1 + len(lay.lags)
            self._ema.step(cur, out[k * b : (k + len(lay.emas)) * b])
        if lay.drift:
            self._base.step(cur, out[-b:])
        return out, True


def assemble_session(layout: Layout, x: F64, step: NDArray[np.integer]) -> tuple[F64, NDArray]:
    """What `Assembler.push` gives for each row of one time-ordered session, vectorised
    (forward fill per step, lag indexing) except for the recursive EMAs and baseline."""
    m, b = x.shape[0], layout.base
    ok = np.all(np.isfinite(x), axis=1) & (step >= 0) & (step < layout.steps)
    idx = np.arange(m)
    last = [np.maximum.accumulate(np.where(ok & (step == s), idx, -1)) for s in range(layout.steps)]
    valid = ok & np.all(np.stack(last) >= 0, axis=0)
    u = np.full((m, layout.size), np.nan)
    rows = np.flatnonzero(valid)
    if not rows.size:
        return u, valid
    cur = np.concatenate([x[np.clip(li[rows], 0, None)] for li in last], axis=1)
    u[rows, :b] = cur
    pos = np.arange(rows.size)
    for i, lag in enumerate(layout.lags):
        u[rows, (i + 1) * b : (i + 2) * b] = cur[np.maximum(pos - lag, 0)]
    k = 1 + len(layout.lags)
    if layout.emas:
        ema = _Ema(layout.emas)
        block = np.empty((rows.size, len(layout.emas) * b))
        for p in range(rows.size):
            ema.step(cur[p], block[p])
        u[rows, k * b : (k + len(layout.emas)) * b] = block
    if layout.drift:
        base = _Baseline()
        block = np.empty((rows.size, b))
        for p in range(rows.size):
            base.step(cur[p], block[p])
        u[rows, -b:] = block
    return u, valid


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
    for rows in session_order(ses, tt):
        u[rows], valid[rows] = assemble_session(layout, x[rows], st[rows])
    return u, valid
