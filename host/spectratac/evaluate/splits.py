"""Train/test splits of a dataset: the paper's random split and the honest blocked split.

Neighbouring samples of a time series are near-duplicates, so a random split leaks: almost
every test sample has a training sample 50 ms away. The blocked split holds out whole units
(a press together with the idle gap after it, or a contiguous time block), then purges from
training every row that shares a press with a test row or lies within `guard_s` of one (same
session), so no press and no near-duplicate neighbour straddles train and test.

Both are deterministic given the seed, and a `SplitSpec` is a small dict that travels in a
model's metadata so that evaluation can rebuild the exact test rows.

>>> import numpy as np
>>> t = np.arange(200) * 0.05
>>> press = np.repeat(np.arange(10), 20)
>>> s = make_split(SplitSpec("blocked", seed=0), t, t + 0.05, np.zeros(200, int), press)
>>> s.kind, s.n_test, s.n_train + s.n_test + s.n_guard
('blocked', 40, 200)
>>> bool(np.intersect1d(press[s.train], press[s.test]).size == 0)
True
>>> make_split(SplitSpec("random", seed=0), t, t, np.zeros(200, int), press).n_test
40
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from spectratac.dataset.schema import Dataset
from spectratac.errors import SpectraTacError

KINDS: tuple[str, ...] = ("random", "blocked")
I64 = NDArray[np.int64]


class SplitError(SpectraTacError):
    """A split cannot be made as asked (unknown kind, too few rows or units)."""


@dataclass(frozen=True)
class SplitSpec:
    """How to split; `by` is "press", "time" or "auto" (press if the dataset has presses).

    `block_s` is the length of a time block, `guard_s` the minimum time between any training
    row and any test row of the same session (blocked split only), both in the dataset's
    time unit (seconds for SpectraTac recordings).
    """

    kind: str = "blocked"
    seed: int = 0
    test_fraction: float = 0.2
    by: str = "auto"
    block_s: float = 10.0
    guard_s: float = 0.5

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise SplitError(f"unknown split kind {self.kind!r}; choose one of {KINDS}")
        if self.by not in ("auto", "press", "time"):
            raise SplitError(f"split by {self.by!r}? choose 'auto', 'press' or 'time'")
        if not 0.0 < self.test_fraction < 1.0:
            raise SplitError(f"test_fraction must be in (0, 1), got {self.test_fraction}")
        if self.block_s <= 0 or self.guard_s < 0:
            raise SplitError("block_s must be > 0 and guard_s >= 0")

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    @staticmethod
    def from_dict(d: dict[str, Any]) -> SplitSpec:
        known = SplitSpec.__dataclass_fields__
        return SplitSpec(**{k: v for k, v in d.items() if k in known})


@dataclass(frozen=True)
class Split:
    """Sorted row indices; `guard` rows are in neither set (purged near-duplicates)."""

    spec: SplitSpec
    train: I64
    test: I64
    guard: I64
    unit: str  # what was held out: "rows", "presses" or "time blocks"

    @property
    def kind(self) -> str:
        return self.spec.kind

    @property
    def n_train(self) -> int:
        return int(self.train.size)

    @property
    def n_test(self) -> int:
        return int(self.test.size)

    @property
    def n_guard(self) -> int:
        return int(self.guard.size)

    def describe(self) -> str:
        s = self.spec
        if s.kind == "random":
            return (
                f"random split (paper): {self.n_test} test rows drawn uniformly "
                f"({100 * s.test_fraction:.0f} %, seed {s.seed}), {self.n_train} training rows"
            )
        return (
            f"blocked split: {self.n_test} test rows in whole {self.unit} "
            f"({100 * s.test_fraction:.0f} %, seed {s.seed}), {self.n_train} training rows, "
            f"{self.n_guard} rows purged (same press or within {s.guard_s:g} s of a test row)"
        )


def make_split(
    spec: SplitSpec,
    t_start: ArrayLike,
    t_end: ArrayLike,
    session: ArrayLike,
    press: ArrayLike,
) -> Split:
    """Split rows described by their window times, session index and press id (-1: none)."""
    t0 = np.asarray(t_start, dtype=np.float64)
    t1 = np.asarray(t_end, dtype=np.float64)
    ses = np.asarray(session, dtype=np.int64)
    prs = np.asarray(press, dtype=np.int64)
    n = t0.shape[0]
    if not (t1.shape == ses.shape == prs.shape == (n,)):
        raise SplitError("t_start, t_end, session and press must be 1-D arrays of equal length")
    if n < 2:
        raise SplitError(f"cannot split {n} row(s): need at least 2")
    rng = np.random.default_rng([int(spec.seed), 0x5B17])
    if spec.kind == "random":
        n_test = min(n - 1, max(1, round(spec.test_fraction * n)))
        perm = rng.permutation(n)
        empty = np.zeros(0, np.int64)
        return Split(spec, np.sort(perm[n_test:]), np.sort(perm[:n_test]), empty, "rows")
    by = spec.by
    if by == "auto":
        by = "press" if np.any(prs >= 0) else "time"
    units = press_units(t0, ses, prs) if by == "press" else time_units(t0, ses, spec.block_s)
    test_mask = _pick_units(units, spec.test_fraction, rng)
    train_mask = ~test_mask & ~_purged(t0, t1, ses, prs, test_mask, spec.guard_s)
    if not train_mask.any():
        raise SplitError(
            f"the blocked split left no training rows (guard {spec.guard_s} s is too wide "
            "for this dataset): lower guard_s or record more presses"
        )
    return Split(
        spec,
        np.flatnonzero(train_mask),
        np.flatnonzero(test_mask),
        np.flatnonzero(~train_mask & ~test_mask),
        "presses" if by == "press" else "time blocks",
    )


def split_dataset(dataset: Dataset, spec: SplitSpec) -> Split:
    """`make_split` over a `spectratac.dataset.Dataset`."""
    a = dataset.arrays
    return make_split(spec, a["t_start"], a["t_end"], a["session"], a["press"])


def press_units(t: NDArray[np.float64], session: I64, press: I64) -> I64:
    """Unit id per row: a press plus the idle rows after it (rows before the first press of a
    session form their own unit). Ids are unique across sessions."""
    out = np.empty(t.shape[0], np.int64)
    base = 0
    for s in np.unique(session):
        rows = np.flatnonzero(session == s)
        rows = rows[np.argsort(t[rows], kind="stable")]
        p = press[rows]
        # Forward-fill the last press id seen; new id whenever the press id changes.
        started = p >= 0
        change = np.ones(rows.size, bool)
        change[1:] = started[1:] & (p[1:] != p[:-1])
        change[0] = True
        ids = np.cumsum(change) - 1
        out[rows] = ids + base
        base += int(ids.max()) + 1
    return out


def time_units(t: NDArray[np.float64], session: I64, block_s: float) -> I64:
    """Unit id per row: contiguous blocks of `block_s` from each session's first sample."""
    out = np.empty(t.shape[0], np.int64)
    base = 0
    for s in np.unique(session):
        rows = np.flatnonzero(session == s)
        ids = np.floor((t[rows] - t[rows].min()) / block_s).astype(np.int64)
        _, ids = np.unique(ids, return_inverse=True)
        out[rows] = ids + base
        base += int(ids.max()) + 1
    return out


def _pick_units(units: I64, fraction: float, rng: np.random.Generator) -> NDArray[np.bool_]:
    """Random whole units until `fraction` of the rows are in test (at least one unit, and
    never all of them)."""
    ids, sizes = np.unique(units, return_counts=True)
    if ids.size < 2:
        raise SplitError(
            "the blocked split needs at least 2 presses or time blocks; this dataset has "
            f"{ids.size}: record more presses or use a shorter block_s"
        )
    order = rng.permutation(ids.size)
    need = fraction * units.size
    cum = np.cumsum(sizes[order])
    k = int(np.searchsorted(cum, need)) + 1
    k = min(max(k, 1), ids.size - 1)
    return np.isin(units, ids[order[:k]])


def _purged(
    t0: NDArray[np.float64],
    t1: NDArray[np.float64],
    session: I64,
    press: I64,
    test: NDArray[np.bool_],
    guard_s: float,
) -> NDArray[np.bool_]:
    """Non-test rows to drop: they share a press with a test row, or their window comes
    within `guard_s` of a test row's window in the same session."""
    drop = np.zeros(t0.shape[0], bool)
    for s in np.unique(session[test]):
        in_s = session == s
        tp = np.unique(press[test & in_s])
        drop |= in_s & np.isin(press, tp[tp >= 0])
        # Distance from each row's window to the nearest test window, via sorted test starts
        # and ends (windows may overlap, so test both neighbours on each side).
        ts = np.sort(t0[test & in_s])
        te = np.sort(t1[test & in_s])
        rows = np.flatnonzero(in_s & ~test)
        # Nearest test window starting after this row's end, ending before its start.
        after = np.searchsorted(ts, t1[rows], side="left")
        gap_after = np.where(after < ts.size, ts[np.minimum(after, ts.size - 1)] - t1[rows], np.inf)
        before = np.searchsorted(te, t0[rows], side="right") - 1
        gap_before = np.where(before >= 0, t0[rows] - te[np.maximum(before, 0)], np.inf)
        # A test window overlapping this row's window: some test start <= t1 and end >= t0.
        n_started = np.searchsorted(ts, t1[rows], side="right")
        n_ended = np.searchsorted(te, t0[rows], side="left")
        overlap = n_started > n_ended
        close = (gap_after < guard_s) | (gap_before < guard_s) | overlap
        drop[rows[close]] = True
    return drop & ~test
