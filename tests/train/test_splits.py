"""Splits: the random split is the paper's; the blocked split never lets a press or a
near-duplicate neighbour straddle train and test, and both are deterministic by seed."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from spectratac.dataset import Dataset
from spectratac.train.groups import SplitError, SplitSpec, make_split


@st.composite
def timelines(draw: st.DrawFn) -> tuple[np.ndarray, ...]:
    """Sessions of back-to-back windows with presses separated by idle gaps."""
    n_sessions = draw(st.integers(1, 3))
    period = draw(st.sampled_from([0.05, 0.1, 0.2, 0.4]))
    t0, sess, press = [], [], []
    pid = 0
    for s in range(n_sessions):
        pattern = draw(st.lists(st.tuples(st.integers(0, 12), st.integers(1, 25)), min_size=2))
        ids: list[int] = []
        for gap, length in pattern:
            ids += [-1] * gap + [pid] * length
            pid += 1
        n = len(ids)
        t0.append(np.arange(n) * period + draw(st.floats(0, 100)))
        sess.append(np.full(n, s))
        press.append(np.array(ids))
    t = np.concatenate(t0)
    return t, t + period, np.concatenate(sess), np.concatenate(press)


SPECS = st.builds(
    SplitSpec,
    kind=st.just("blocked"),
    seed=st.integers(0, 10_000),
    test_fraction=st.floats(0.05, 0.6),
    by=st.sampled_from(["auto", "press", "time"]),
    block_s=st.floats(0.3, 5.0),
    guard_s=st.floats(0.0, 1.0),
)


@settings(max_examples=150, deadline=None)
@given(timelines(), SPECS)
def test_blocked_split_separates_presses_and_respects_guard(tl, spec) -> None:
    t0, t1, sess, press = tl
    try:
        s = make_split(spec, t0, t1, sess, press)
    except SplitError as exc:
        assert "guard" in str(exc) or "at least 2" in str(exc)
        return
    n = t0.size
    # Train, test and guard partition the rows.
    assert np.array_equal(np.sort(np.concatenate([s.train, s.test, s.guard])), np.arange(n))
    assert s.n_train > 0 and s.n_test > 0
    # No press on both sides.
    tr_p, te_p = press[s.train], press[s.test]
    assert np.intersect1d(tr_p[tr_p >= 0], te_p[te_p >= 0]).size == 0
    # Every training window is at least guard_s from every test window of its session.
    for ses in np.unique(sess):
        tr = s.train[sess[s.train] == ses]
        te = s.test[sess[s.test] == ses]
        if tr.size and te.size:
            gap = np.maximum(t0[te][None, :] - t1[tr][:, None], t0[tr][:, None] - t1[te][None, :])
            assert gap.min() >= spec.guard_s - 1e-9


@settings(max_examples=50, deadline=None)
@given(timelines(), SPECS)
def test_splits_are_deterministic_by_seed(tl, spec) -> None:
    try:
        a = make_split(spec, *tl)
    except SplitError:
        return
    b = make_split(spec, *tl)
    assert np.array_equal(a.train, b.train) and np.array_equal(a.test, b.test)


@settings(max_examples=50, deadline=None)
@given(st.integers(2, 500), st.integers(0, 1000), st.floats(0.05, 0.95))
def test_random_split_is_a_partition_of_the_asked_size(n, seed, frac) -> None:
    t = np.arange(n) * 0.05
    s = make_split(SplitSpec("random", seed, frac), t, t, np.zeros(n), np.full(n, -1))
    assert np.array_equal(np.sort(np.concatenate([s.train, s.test])), np.arange(n))
    assert abs(s.n_test - frac * n) <= 1 and s.n_guard == 0


def test_blocked_split_holds_out_about_the_fraction_in_whole_presses() -> None:
    press = np.repeat(np.arange(100), 20)
    t = np.arange(press.size) * 0.05
    s = make_split(SplitSpec("blocked", seed=4), t, t + 0.05, np.zeros(t.size), press)
    assert s.unit == "presses" and np.unique(press[s.test]).size == 20
    assert 0.19 <= s.n_test / t.size <= 0.21
    other = make_split(SplitSpec("blocked", seed=5), t, t + 0.05, np.zeros(t.size), press)
    assert not np.array_equal(s.test, other.test)
    assert "purged" in s.describe()


def test_time_blocks_when_there_are_no_presses() -> None:
    t = np.arange(1000) * 0.05
    s = make_split(SplitSpec("blocked", block_s=5.0), t, t + 0.05, np.zeros(1000), -np.ones(1000))
    assert s.unit == "time blocks"
    block = (t // 5.0).astype(int)
    in_test = np.isin(np.arange(1000), s.test)
    for b in np.unique(block):  # whole blocks are held out, never parts of one
        assert in_test[block == b].all() or not in_test[block == b].any()
    assert np.unique(block[s.test]).size == 2


def test_bad_specs_and_degenerate_data_are_refused_with_reasons() -> None:
    with pytest.raises(SplitError, match="choose one of"):
        SplitSpec("kfold")
    with pytest.raises(SplitError, match="test_fraction"):
        SplitSpec(test_fraction=1.5)
    t = np.arange(10.0)
    with pytest.raises(SplitError, match="at least 2 presses"):
        make_split(SplitSpec(by="press"), t, t, np.zeros(10), np.zeros(10))
    with pytest.raises(SplitError, match="guard"):
        make_split(SplitSpec(guard_s=100.0, block_s=1.0), t, t, np.zeros(10), -np.ones(10))
    assert SplitSpec.from_dict({**SplitSpec().to_dict(), "future_field": 1}) == SplitSpec()


def test_blocked_split_guard_band_is_in_device_time() -> None:
    """A paced simulation at speed=20 stamps host times 20x closer together than the device
    clock; its blocked split must purge what the same recording at speed=1 purges."""
    from spectratac.train.groups import SplitSpec, split_dataset

    dev_s = np.arange(6000) * 0.01  # 60 s of samples at 100 Hz on the device clock
    purged = {}
    for speed in (1.0, 20.0):
        ds = Dataset.generic(np.zeros((dev_s.size, 1)), np.zeros(dev_s.size), ["a"], ["Fz"],
                             t=dev_s / speed)  # fmt: skip
        ds.arrays["device_time_us"] = (dev_s * 1e6).astype(np.int64)
        sp = split_dataset(ds, SplitSpec("blocked", seed=0, by="time"))
        purged[speed] = sp.n_guard / ds.n
    assert purged[20.0] == pytest.approx(purged[1.0]), purged
    assert purged[1.0] < 0.1, purged
