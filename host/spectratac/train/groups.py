"""Which rows are held out together: the one grouping and splitting module.

Neighbouring samples of a time series are near-duplicates, and rows of one session share its
offsets and drift, so neither validation nor a test split may take random rows and call them
unseen. Both hold out whole groups, found here in one way:

- `press_units`: a press together with the idle rows after it (rows of a session before its
  first press form their own unit); `time_blocks`: contiguous blocks of `block_s` seconds
  per session, or `n_blocks` blocks of equal row count over the data.
- Validation inside training (`row_groups`, `val_split`, `group_folds`: the early-stopping
  set, the uncertainty calibration, `--recipe auto`'s cross-validation, the held-out check)
  works in rows: the coarsest groups the data has, sessions, else presses (the leading idle
  rows join the first press), else `n_blocks` time blocks with `guard` rows purged on
  either side of a held-out block (the temporal context and the elastomer's creep reach
  across a cut).
- The train/test split (`make_split`, `SplitSpec`) works in seconds: the paper's random
  split, or the honest blocked split holding out whole press units or `block_s` time blocks
  and purging every training row that shares a press with a test row or lies within
  `guard_s` of one (same session). A `SplitSpec` is a small dict that travels in a model's
  metadata so that evaluation can rebuild the exact test rows; both are deterministic.

>>> g = row_groups(np.array([0, 0, 1, 1, 2]), np.full(5, -1), np.arange(5.0))
>>> g.kind, g.ids.tolist()
('session', [0, 0, 1, 1, 2])
>>> g = row_groups(np.zeros(6, int), np.array([-1, 0, 0, -1, 1, -1]), np.arange(6.0))
>>> g.kind, g.ids.tolist()
('press', [0, 0, 0, 0, 1, 1])
>>> press_units(np.arange(6.0), np.zeros(6, int), np.array([-1, 0, 0, -1, 1, -1])).tolist()
[0, 1, 1, 1, 2, 2]
>>> order = np.arange(100)
>>> fit, val = val_split(order, 0.2, row_groups(np.zeros(100, int), np.full(100, -1),
...                      np.arange(100.0), n_blocks=10), guard=2)
>>> val.size, fit.size, bool(np.intersect1d(fit, val).size == 0)
(20, 72, True)
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
from spectratac.decode.errors import DecoderDataError
from spectratac.errors import SpectraTacError

KINDS: tuple[str, ...] = ("random", "blocked")
I64 = NDArray[np.int64]
N_BLOCKS = 20  # time blocks per dataset when it has neither sessions nor presses
GUARD_ROWS = 20  # rows purged beside a held-out block (1 s at 20 Hz, 0.2 s at 100 Hz)


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
    units = (
        press_units(t0, ses, prs) if by == "press" else time_blocks(t0, ses, block_s=spec.block_s)
    )
    test_mask = _pick_units(units, spec.test_fraction, rng)
    train_mask = ~test_mask & ~purge_seconds(t0, t1, ses, prs, test_mask, spec.guard_s)
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
    """`make_split` over a `spectratac.dataset.Dataset`, in device time when the dataset has
    it (`device_time`): block lengths and guard bands are durations of the sensor's life."""
    a = dataset.arrays
    t0, t1 = device_time(dataset)
    return make_split(spec, t0, t1, a["session"], a["press"])


def device_time(dataset: Dataset) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Window (start, end) of each row in seconds of the device clock when the dataset records
    it (`device_time_us`), else its host times. A paced simulation runs the device clock
    `speed` times faster than the host's, so host seconds would shrink every time block and
    widen every guard band by `speed`; the host window is mapped per session through the
    least-squares line from host to device time (the window ends are what both clocks
    stamp)."""
    a = dataset.arrays
    h0 = np.asarray(a["t_start"], np.float64)
    h1 = np.asarray(a["t_end"], np.float64)
    dev = a.get("device_time_us")
    if dev is None:
        return h0, h1
    d1 = np.asarray(dev, np.float64) * 1e-6
    t0, t1 = h0.copy(), h1.copy()
    ses = np.asarray(a["session"], np.int64)
    for s in np.unique(ses):
        m = ses == s
        if m.sum() < 2 or np.ptp(h1[m]) <= 0:
            continue
        slope, icpt = np.polyfit(h1[m] - h1[m][0], d1[m], 1)
        if not (np.isfinite(slope) and slope > 0):
            continue
        t0[m] = icpt + slope * (h0[m] - h1[m][0])
        t1[m] = icpt + slope * (h1[m] - h1[m][0])
    return t0, t1


def press_units(t: ArrayLike, session: ArrayLike, press: ArrayLike) -> I64:
    """Unit id per row: a press plus the idle rows after it (rows before the first press of a
    session form their own unit), in time order per session. Ids are unique across
    sessions and number the units in order (sessions ascending, then time)."""
    tt = np.asarray(t, np.float64)
    ses = np.asarray(session, np.int64)
    prs = np.asarray(press, np.int64)
    out = np.empty(tt.shape[0], np.int64)
    base = 0
    for s in np.unique(ses):
        rows = _session_rows(ses, tt, s)
        p = prs[rows]
        # a new unit wherever a press id starts (differs from the row before it)
        started = p >= 0
        change = np.ones(rows.size, bool)
        change[1:] = started[1:] & (p[1:] != p[:-1])
        change[0] = True
        ids = np.cumsum(change) - 1
        out[rows] = ids + base
        base += int(ids.max()) + 1
    return out


def time_blocks(
    t: ArrayLike, session: ArrayLike, *, block_s: float | None = None, n_blocks: int = N_BLOCKS
) -> I64:
    """Block id per row: contiguous blocks of `block_s` (time units) from each session's first
    sample, ids unique across sessions; without `block_s`, `n_blocks` blocks of equal row
    count over all sessions in time order."""
    tt = np.asarray(t, np.float64)
    ses = np.asarray(session, np.int64)
    out = np.empty(tt.shape[0], np.int64)
    if block_s is None:
        for k, block in enumerate(np.array_split(_time_order(ses, tt), max(1, n_blocks))):
            out[block] = k
        return out
    base = 0
    for s in np.unique(ses):
        rows = np.flatnonzero(ses == s)
        ids = np.floor((tt[rows] - tt[rows].min()) / block_s).astype(np.int64)
        _, ids = np.unique(ids, return_inverse=True)
        out[rows] = ids + base
        base += int(ids.max()) + 1
    return out


def _session_rows(ses: I64, t: NDArray[np.float64], s: int) -> NDArray[np.intp]:
    """Rows of session `s` in time order (ties: row order)."""
    rows = np.flatnonzero(ses == s)
    return rows[np.argsort(t[rows], kind="stable")]


def _time_order(ses: I64, t: NDArray[np.float64]) -> NDArray[np.intp]:
    return np.lexsort((np.arange(ses.shape[0]), t, ses))


@dataclass(frozen=True)
class Groups:
    """A group id per row (-1: none) and how they were formed."""

    ids: I64
    kind: str  # "session" | "press" | "block" | "given"

    @property
    def n_groups(self) -> int:
        return int(np.unique(self.ids[self.ids >= 0]).size)


def row_groups(
    session: ArrayLike,
    press: ArrayLike,
    t: ArrayLike,
    rows: ArrayLike | None = None,
    n_blocks: int = N_BLOCKS,
) -> Groups:
    """Group ids for every row, chosen from the rows `rows` (default all) span: sessions if
    more than one, else presses, else `n_blocks` contiguous time blocks."""
    ses = np.asarray(session, np.int64)
    prs = np.asarray(press, np.int64)
    tt = np.asarray(t, np.float64)
    sel = np.arange(ses.shape[0]) if rows is None else np.asarray(rows)
    if np.unique(ses[sel]).size > 1:
        return Groups(ses.copy(), "session")
    if np.any(prs[sel] >= 0):
        return Groups(_press_groups(ses, prs, tt), "press")
    return Groups(time_blocks(tt, ses, n_blocks=n_blocks), "block")


def _press_groups(ses: I64, prs: I64, t: NDArray[np.float64]) -> I64:
    """The press id of each row's press unit; a session's leading idle rows join its first
    press (validation keeps them with a press rather than holding out idle rows alone)."""
    units = press_units(t, ses, prs)
    press_of = np.full(int(units.max(initial=-1)) + 1, -1, np.int64)
    np.maximum.at(press_of, units, prs)  # a unit's rows carry its press id or -1
    for s in np.unique(ses):
        u = units[ses == s]  # consecutive ids, the first unit first
        if press_of[u.min()] < 0 and u.max() > u.min():
            press_of[u.min()] = press_of[u.min() + 1]
    return press_of[units]


def spread(n_groups: int, k: int) -> NDArray[np.intp]:
    """`k` group positions out of `n_groups`, spread evenly (the middle of k equal parts).

    >>> spread(10, 2).tolist(), spread(3, 5).tolist()
    ([2, 7], [0, 1, 2])
    """
    k = min(k, n_groups)
    return np.unique(((np.arange(k) + 0.5) * n_groups / max(k, 1)).astype(np.intp))


def val_split(
    order: NDArray[np.intp], fraction: float, groups: Groups, guard: int = GUARD_ROWS
) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """(fit, validation) rows of `order` (time order per session): whole groups, about
    `fraction` of them, spread over the data, held out; with time blocks, `guard` rows on
    either side of a held-out block are left out of both."""
    if fraction <= 0:
        return order, order[:0]
    ids = groups.ids[order]
    present = list(dict.fromkeys(ids[ids >= 0].tolist()))  # in time order
    if len(present) < 2:
        raise DecoderDataError(
            f"validation needs at least 2 {groups.kind}s to hold one out; the rows have "
            f"{len(present)}: give more data or set val_fraction=0"
        )
    k = min(len(present) - 1, max(1, round(fraction * len(present))))
    held = {present[i] for i in spread(len(present), k)}
    is_val = np.isin(ids, list(held))
    fit = ~is_val & (ids >= 0)
    if groups.kind == "block" and guard > 0:
        fit &= ~_near(is_val, guard)
    return order[fit], order[is_val]


def _near(is_val: NDArray[np.bool_], guard: int) -> NDArray[np.bool_]:
    """Positions within `guard` positions of a validation position (a dilation of is_val)."""
    kernel = np.ones(2 * guard + 1)
    return np.convolve(is_val.astype(np.float64), kernel, mode="same") > 0


def group_folds(ids: I64, rows: NDArray[np.intp], k: int) -> list[NDArray[np.intp]]:
    """Held-out rows of each of `k` folds: the groups of `rows` in order of appearance,
    dealt round-robin to the folds (every fold gets groups from all over the data).

    >>> [f.tolist() for f in group_folds(np.array([0, 0, 1, 2, 2, 3]), np.arange(6), 2)]
    [[0, 1, 3, 4], [2, 5]]
    """
    present = list(dict.fromkeys(ids[rows][ids[rows] >= 0].tolist()))
    if len(present) < k:
        raise DecoderDataError(
            f"{k}-fold cross-validation by group needs at least {k} groups; the rows have "
            f"{len(present)}: give more sessions, presses or a longer recording"
        )
    fold_of = {g: i % k for i, g in enumerate(present)}
    which = np.array([fold_of.get(int(g), -1) for g in ids[rows]])
    return [rows[which == f] for f in range(k)]


def purge(fit: NDArray[np.intp], held: NDArray[np.intp], groups: Groups, session: I64,
          t: NDArray[np.float64], guard: int = GUARD_ROWS) -> NDArray[np.intp]:  # fmt: skip
    """`fit` without the rows within `guard` rows (time order, same session) of a `held` row,
    for time blocks; other group kinds need no guard (the rows counterpart of
    `purge_seconds`)."""
    if groups.kind != "block" or guard <= 0:
        return fit
    order = _time_order(session, t)
    is_held = np.isin(order, held)
    near = _near(is_held, guard)
    near &= ~is_held
    return np.setdiff1d(fit, order[near])


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


def purge_seconds(
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
