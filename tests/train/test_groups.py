"""Validation holds out whole groups: sessions, else presses, else guarded time blocks."""

from __future__ import annotations

import numpy as np
import pytest
from spectratac.decode.errors import DecoderDataError
from spectratac.sim.generic_skin import generic_skin
from spectratac.train.groups import (
    group_folds,
    press_units,
    purge,
    row_groups,
    time_blocks,
    val_split,
)


def test_sessions_are_the_groups_when_there_are_several() -> None:
    ds = generic_skin(sessions=5, session_s=2.0, seed=0)
    g = row_groups(ds.session, ds.press, ds.t_end)
    assert g.kind == "session" and g.n_groups == 5
    fit, val = val_split(np.arange(ds.n), 0.2, g)
    # whole sessions: no session has rows on both sides
    assert not set(ds.session[fit]) & set(ds.session[val])
    assert fit.size + val.size == ds.n and np.unique(ds.session[val]).size == 1


def test_presses_with_their_idle_gap_when_one_session() -> None:
    ds = generic_skin(sessions=1, session_s=20.0, seed=1)
    g = row_groups(ds.session, ds.press, ds.t_end)
    assert g.kind == "press" and np.all(g.ids >= 0)
    fit, val = val_split(np.arange(ds.n), 0.25, g)
    pressed_val = set(ds.press[val][ds.press[val] >= 0])
    assert pressed_val and not pressed_val & set(ds.press[fit][ds.press[fit] >= 0])


def test_time_blocks_with_a_guard_when_no_presses_either() -> None:
    n = 1000
    g = row_groups(np.zeros(n, int), np.full(n, -1), np.arange(n, dtype=float), n_blocks=10)
    assert g.kind == "block" and g.n_groups == 10
    fit, val = val_split(np.arange(n), 0.2, g, guard=15)
    assert val.size == 200
    # every fitting row is more than the guard away from every validation row
    assert np.min(np.abs(fit[:, None] - val[None, :])) > 15
    # contiguous blocks, not random rows
    assert np.all(np.diff(np.sort(val)) >= 1) and np.sum(np.diff(np.sort(val)) > 1) == 1


def test_one_group_cannot_be_split() -> None:
    g = row_groups(np.zeros(10, int), np.zeros(10, int), np.arange(10.0))
    with pytest.raises(DecoderDataError, match="at least 2 press"):
        val_split(np.arange(10), 0.2, g)


def test_folds_partition_the_rows_by_group_and_purge_next_to_blocks() -> None:
    ds = generic_skin(sessions=7, session_s=1.0, seed=2)
    g = row_groups(ds.session, ds.press, ds.t_end)
    folds = group_folds(g.ids, np.arange(ds.n), 3)
    assert sorted(np.concatenate(folds).tolist()) == list(range(ds.n))
    assert [np.unique(ds.session[f]).size for f in folds] == [3, 2, 2]
    n = 300
    tb = row_groups(np.zeros(n, int), np.full(n, -1), np.arange(n, dtype=float), n_blocks=6)
    held = group_folds(tb.ids, np.arange(n), 3)[0]
    fit = purge(np.setdiff1d(np.arange(n), held), held, tb, np.zeros(n, int), np.arange(n * 1.0),
                guard=5)  # fmt: skip
    assert np.min(np.abs(fit[:, None] - held[None, :])) > 5
    with pytest.raises(DecoderDataError, match="at least 8 groups"):
        group_folds(g.ids, np.arange(ds.n), 8)


def test_validation_press_groups_are_the_splits_press_units() -> None:
    """One grouping: a validation press group is the split's press units of that press, the
    session's leading idle unit joined to its first press."""
    rng = np.random.default_rng(7)
    for _ in range(200):
        n = int(rng.integers(2, 80))
        session = np.zeros(n, np.int64)
        t = rng.permutation(n).astype(np.float64)
        press = np.where(rng.random(n) < 0.4, -1, rng.integers(0, 5, n))
        g = row_groups(session, press, t)
        if g.kind != "press":
            continue
        units = press_units(t, session, press)
        in_time = press[np.argsort(t, kind="stable")]
        first_press = in_time[in_time >= 0][0]
        for u in np.unique(units):
            ids = np.unique(g.ids[units == u])
            assert ids.size == 1  # a unit never straddles two groups
            own = press[units == u]
            assert ids[0] == (own.max() if own.max() >= 0 else first_press)


def test_time_blocks_in_seconds_and_in_rows() -> None:
    t = np.arange(10.0)
    session = np.array([0] * 5 + [1] * 5)
    assert time_blocks(t, session, block_s=2.0).tolist() == [0, 0, 1, 1, 2, 3, 3, 4, 4, 5]
    assert time_blocks(t, session, n_blocks=2).tolist() == [0] * 5 + [1] * 5
