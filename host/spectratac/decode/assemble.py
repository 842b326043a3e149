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

import numpy as np
from numpy.typing import NDArray

from spectratac.decode.layout import Layout

F64 = NDArray[np.float64]

TAU = 600.0  # 30 s at 20 Hz: far slower than a press, faster than thermal drift
GATE = 0.03  # RMS relative deviation below which a sample counts as no-contact
STUCK = 2400  # 2 min at 20 Hz without a no-contact sample: the baseline is wrong, follow
# The search for rest (a layout with a rest signature), in press-score units (log counts
# along the press direction): at rest the score's noise is ~0.01, a 0.3 N press raises it
# by ~0.12 on every twin unit, and units' rest levels differ by up to ~0.2.
JOIN = 0.06  # a first sample this far above the model's rest is pressed
DROP = 0.04  # a fall (or rise) of the score this large is contact ending (or starting)
STILL = 2  # samples still after coming down that make the low rest
HOLD = 20  # samples still, never having come down, after which another unit's skin stands in


class _Ema:
    """Moving averages of the assembled sample; `step` returns them before the update."""

    def __init__(self, taus: tuple[float, ...]) -> None:
        self.alpha = 1.0 / np.asarray(taus, dtype=np.float64)[:, None]
        self.value: F64 | None = None  # (len(taus), base)
        self._tmp: F64 | None = None

    def step(self, cur: F64, out: F64) -> None:
        """Write the averages before this sample into `out` (len(taus) * base,)."""
        if self.value is None:
            self.value = np.tile(cur, (self.alpha.shape[0], 1))
            self._tmp = np.empty_like(self.value)
        out[:] = self.value.reshape(-1)  # the past only
        tmp = self._tmp
        np.subtract(cur, self.value, out=tmp)
        tmp *= self.alpha
        self.value += tmp


class _Baseline:
    """Gated running no-contact baseline; `step` writes it as it was before the sample.

    With the layout's rest signature (`rest`, `press`: decode.rest_signature) it first makes
    sure it starts from rest. A first sample whose press score (press . log x) lies above the
    model's rest by more than JOIN is pressed: the model's rest stands in while the lowest
    sample seen so far (`low`) is followed down, each fall of more than DROP showing that
    what came before was contact. The low is rest once the skin stays there STILL samples
    after coming down (or presses again from it); then the usual gated average takes over.
    Units' rests differ as much as a press moves one, so on another unit (or an unknown one)
    a skin that sits still HOLD samples without having come down stands in for the model's
    rest (it may be that unit's rest), not yet called rest; on the model's own unit
    (`same_unit`) a still skin that far above its rest is a held press and is never used.
    `rest_seen` says whether the baseline stands on a rest it has seen; `tare` makes the
    next sample it.
    """

    def __init__(
        self, rest: F64 | None = None, press: F64 | None = None, same_unit: bool = False
    ) -> None:
        self.value: F64 | None = None
        self._same_unit = same_unit
        self.out_of_gate = 0
        self.rest_seen = False
        self._rest, self._press = rest, press
        self._rest_score = self._score(rest) if rest is not None else 0.0
        self._tare = False
        self._diff: F64 | None = None
        self._dev: F64 | None = None
        # the search for rest (signature only)
        self._searching = False
        self._low: F64 | None = None
        self._low_score = 0.0
        self._armed = False  # the skin came down onto the low: what was above it was contact
        self._still = 0
        self._on_rest = False  # the output is the model's rest, not this skin's

    def tare(self) -> None:
        """Take the next sample as the zero (the user says the skin is at rest)."""
        self._tare = True

    def _score(self, x: F64) -> float:
        assert self._press is not None
        return float(np.dot(self._press, np.log(np.maximum(x, 1.0))))

    def _start(self, value: F64) -> None:
        self.value = value.copy()
        self.out_of_gate = 0
        if self._diff is None:
            self._diff, self._dev = np.empty_like(value), np.empty_like(value)

    def _rel(self, cur: F64, base: F64) -> float:
        """RMS deviation of `cur` from `base` relative to |base| (plus a floor)."""
        n = base.shape[0]
        dev, diff = self._dev, self._diff
        assert dev is not None and diff is not None
        np.abs(base, out=dev)
        dev += 1e-6 + 0.01 * float(dev.sum()) / n  # scale: |base| + a floor
        np.subtract(cur, base, out=diff)
        np.divide(diff, dev, out=dev)  # relative deviation
        return math.sqrt(float(np.dot(dev, dev)) / n)

    def step(self, cur: F64, out: F64) -> None:
        if self._tare:
            self._tare, self._searching, self.rest_seen = False, False, True
            self._start(cur)
            out[:] = cur
            return
        base = self.value
        if base is None:
            self._first(cur)
            assert self.value is not None
            out[:] = self.value
            return
        out[:] = base  # the sample is judged against the baseline before it
        if self._searching:
            self._search(cur)
            return
        rel = self._rel(cur, base)
        self.out_of_gate = 0 if rel < GATE else self.out_of_gate + 1
        if self.out_of_gate == 0 or self.out_of_gate > STUCK:
            diff = self._diff
            assert diff is not None
            diff /= TAU
            base += diff

    def _first(self, cur: F64) -> None:
        self._start(cur)
        if self._press is None or self._rest is None:
            return  # no signature: as before, and rest is never known to be seen
        s = self._score(cur)
        if s <= self._rest_score + JOIN:
            self.rest_seen = True
            return
        self._searching, self._on_rest = True, True
        self._start(self._rest)
        self._low, self._low_score = cur.copy(), s

    def _search(self, cur: F64) -> None:
        low = self._low
        assert low is not None and self.value is not None
        s = self._score(cur)
        if s < self._low_score - DROP:  # came down: what was above was contact
            low[:] = cur
            self._low_score, self._armed, self._still = s, True, 0
        elif s > self._low_score + DROP:  # pressed (again) from the low
            if self._armed:
                self._found()
                return
            self._still = 0
        elif self._rel(cur, low) < GATE:
            self._still += 1
            low += (cur - low) / (self._still + 1)  # the mean of the still stretch
            self._low_score = self._score(low)
        if self._armed and self._still >= STILL:
            self._found()
        elif self._still >= HOLD and self._on_rest and not self._same_unit:
            self._on_rest = False
            self.value[:] = low  # this skin, still for a while: better than another's rest
        elif not self._on_rest:
            self.value[:] = low

    def _found(self) -> None:
        assert self._low is not None
        self._start(self._low)
        self._searching, self.rest_seen = False, True


class Assembler:
    """Streaming state of one session: latest sample per step, history, EMAs, baseline.

    This is the reference implementation; `assemble` computes the same vectors for whole
    sessions at once (tests check they agree bit for bit). It runs once per live sample, so
    it keeps its NumPy calls few: past samples sit in a shift register (newest first,
    filled with the first sample so that early lags repeat the oldest one there is). With
    lags 1..L the register is the head of the output itself; other lags are gathered from
    it in one `take`.
    """

    def __init__(self, layout: Layout, same_unit: bool = False) -> None:
        """`same_unit`: the samples come from the unit the layout's rest was learned on."""
        self.layout = layout
        self.same_unit = same_unit
        self._c = len(layout.channels)
        b, lags = layout.base, layout.lags
        self._out = np.empty(layout.size)
        k = 1 + len(lags)
        contiguous = lags == tuple(range(1, len(lags) + 1))
        # [x_t, x_t-1, ..., x_t-max]
        self._reg = self._out[: k * b] if contiguous else np.zeros((max(lags) + 1) * b)
        self._lag_idx = (np.asarray(lags, np.intp)[:, None] * b + np.arange(b)).ravel()
        self._gather = not contiguous
        self._lag_out = self._out[b : k * b]
        self._ema_out = self._out[k * b : (k + len(layout.emas)) * b]
        self._base_out = self._out[self._out.size - b :]
        self.reset()

    def reset(self) -> None:
        self._latest = np.zeros(self.layout.base)
        self._seen = np.zeros(self.layout.steps, bool)
        self._n_seen = 0
        self._started = False
        self._ema = _Ema(self.layout.emas)
        self._base = _baseline(self.layout, self.same_unit)

    @property
    def rest_seen(self) -> bool:
        """False while the drift baseline has not stood on a rest it has seen (always True
        without a baseline)."""
        return not self.layout.drift or self._base.rest_seen

    def tare(self) -> None:
        """Make the next valid sample the baseline's zero (the skin is at rest now)."""
        self._base.tare()

    def push(self, step: int, x: F64) -> tuple[F64, bool]:
        """Feed one sample (its step, its C inputs); return (assembled vector, valid).

        A valid result's array is reused by the next call: copy it to keep it. Invalid results
        (non-finite input, not every step seen yet, bad step; all NaN) leave the state as it
        was.
        """
        lay = self.layout
        if not (0 <= step < lay.steps) or not np.isfinite(x).all():
            return self._invalid()
        c = self._c
        self._latest[step * c : (step + 1) * c] = x
        if not self._seen[step]:
            self._seen[step] = True
            self._n_seen += 1
        if self._n_seen < lay.steps:
            return self._invalid()
        reg, out, b = self._reg, self._out, lay.base
        if self._started:
            reg[b:] = reg[:-b]  # every past sample one lag older
        else:
            reg.reshape(-1, b)[:] = self._latest
            self._started = True
        reg[:b] = self._latest
        if self._gather:
            np.take(reg, self._lag_idx, out=self._lag_out)
            out[:b] = self._latest
        cur = reg[:b]
        if lay.emas:
            self._ema.step(cur, self._ema_out)
        if lay.drift:
            self._base.step(cur, self._base_out)
        return out, True

    def _invalid(self) -> tuple[F64, bool]:
        # A new array: the output's head may hold the history (the shift register).
        return np.full(self.layout.size, np.nan), False


def _baseline(layout: Layout, same_unit: bool) -> _Baseline:
    if layout.rest and layout.press:
        return _Baseline(np.asarray(layout.rest), np.asarray(layout.press), same_unit)
    return _Baseline()


def assemble_session(
    layout: Layout,
    x: F64,
    step: NDArray[np.integer],
    seen: NDArray[np.bool_] | None = None,
    same_unit: bool = False,
) -> tuple[F64, NDArray]:
    """What `Assembler.push` gives for each row of one time-ordered session, vectorised
    (forward fill per step, lag indexing) except for the recursive EMAs and baseline.
    `seen` (M,), if given, receives `Assembler.rest_seen` after each row."""
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
        base = _baseline(layout, same_unit)
        block = np.empty((rows.size, b))
        flags = np.empty(rows.size, bool)
        for p in range(rows.size):
            base.step(cur[p], block[p])
            flags[p] = base.rest_seen
        u[rows, -b:] = block
        if seen is not None:  # a row before the first valid one has seen nothing
            seen[:] = False
            seen[rows] = flags
    elif seen is not None:
        seen[:] = True
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
    seen: NDArray[np.bool_] | None = None,
    same_unit: bool = False,
) -> tuple[F64, NDArray[np.bool_]]:
    """Assembled vectors (N, D) and validity (N,) for rows of possibly several sessions.

    Rows are processed per session in time order `t` (default: row order); invalid rows are
    NaN. With a trivial layout the inputs pass through unchanged (non-finite rows invalid).
    `seen` (N,), if given, receives whether each row's baseline stood on a seen rest;
    `same_unit`: the rows come from the unit the layout's rest was learned on.
    """
    x = np.asarray(inputs, dtype=np.float64)
    n = x.shape[0]
    finite = np.all(np.isfinite(x), axis=1)
    if layout.trivial:
        u = x.copy()
        u[~finite] = np.nan
        if seen is not None:
            seen[:] = True
        return u, finite
    st = np.zeros(n, np.int64) if step is None else np.asarray(step, np.int64)
    ses = np.zeros(n, np.int64) if session is None else np.asarray(session)
    tt = np.arange(n, dtype=np.float64) if t is None else np.asarray(t, np.float64)
    u = np.full((n, layout.size), np.nan)
    valid = np.zeros(n, bool)
    part = None if seen is None else np.zeros(n, bool)
    for rows in session_order(ses, tt):
        sub = None if part is None else np.zeros(rows.size, bool)
        u[rows], valid[rows] = assemble_session(layout, x[rows], st[rows], sub, same_unit)
        if part is not None and sub is not None:
            part[rows] = sub
    if seen is not None and part is not None:
        seen[:] = part
    return u, valid
