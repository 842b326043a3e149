"""Groups of rows that validation holds out whole: sessions, presses or time blocks.

Neighbouring samples of a time series are near-duplicates, and rows of one session share its
offsets and drift, so a random-row validation set measures interpolation between
near-duplicates, not the error on a new session. Validation (the early-stopping set, the
uncertainty calibration, `--recipe auto`'s cross-validation) therefore holds out whole
groups, the coarsest the data has:

- "session": every session its own group, when the rows span more than one session;
- "press": a press together with the idle gap after it, when presses are labelled;
- "block": contiguous time blocks of each session, with `guard` rows purged on either side
  of a held-out block (the temporal context and the elastomer's creep reach across a cut).

>>> import numpy as np
>>> g = row_groups(np.array([0, 0, 1, 1, 2]), np.full(5, -1), np.arange(5.0))
>>> g.kind, g.ids.tolist()
('session', [0, 0, 1, 1, 2])
>>> g = row_groups(np.zeros(6, int), np.array([-1, 0, 0, -1, 1, -1]), np.arange(6.0))
>>> g.kind, g.ids.tolist()
('press', [0, 0, 0, 0, 1, 1])
>>> order = np.arange(100)
>>> fit, val = val_split(order, 0.2, row_groups(np.zeros(100, int), np.full(100, -1),
...                      np.arange(100.0), n_blocks=10), guard=2)
>>> val.size, fit.size, bool(np.intersect1d(fit, val).size == 0)
(20, 72, True)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from spectratac.decode.errors import DecoderDataError

I64 = NDArray[np.int64]
N_BLOCKS = 20  # time blocks per dataset when it has neither sessions nor presses
GUARD_ROWS = 20  # rows purged beside a held-out block (1 s at 20 Hz, 0.2 s at 100 Hz)


@dataclass(frozen=True)
class Groups:
    """A group id per row (-1: none) and how they were formed."""

    ids: I64
    kind: str  # "session" | "press" | "block"

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
    n = ses.shape[0]
    sel = np.arange(n) if rows is None else np.asarray(rows)
    if np.unique(ses[sel]).size > 1:
        return Groups(ses.copy(), "session")
    if np.any(prs[sel] >= 0):
        return Groups(_press_groups(ses, prs, tt), "press")
    return Groups(_time_blocks(ses, tt, n_blocks), "block")


def _press_groups(ses: I64, prs: I64, t: NDArray[np.float64]) -> I64:
    """A press and the idle gap after it share an id; rows before a session's first press
    join that press."""
    ids = np.full(ses.shape[0], -1, np.int64)
    for s in np.unique(ses):
        rows = np.flatnonzero(ses == s)
        rows = rows[np.argsort(t[rows], kind="stable")]
        p = prs[rows]
        last = np.maximum.accumulate(np.where(p >= 0, np.arange(p.size), -1))
        first = np.argmax(p >= 0) if np.any(p >= 0) else -1
        if first < 0:
            continue
        owner = np.where(last >= 0, last, first)
        ids[rows] = p[owner]
    return ids


def _time_blocks(ses: I64, t: NDArray[np.float64], n_blocks: int) -> I64:
    """Ids of `n_blocks` contiguous blocks of equal row count over all sessions in time
    order."""
    order = _time_order(ses, t)
    ids = np.empty(ses.shape[0], np.int64)
    for k, block in enumerate(np.array_split(order, max(1, n_blocks))):
        ids[block] = k
    return ids


def _time_order(ses: I64, t: NDArray[np.float64]) -> NDArray[np.intp]:
    return np.lexsort((np.arange(ses.shape[0]), t, ses))


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
    for time blocks; other group kinds need no guard."""
    if groups.kind != "block" or guard <= 0:
        return fit
    order = _time_order(session, t)
    is_held = np.isin(order, held)
    near = _near(is_held, guard)
    near &= ~is_held
    return np.setdiff1d(fit, order[near])
