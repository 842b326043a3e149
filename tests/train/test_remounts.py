"""Re-mountings found in the light at rest (`spectratac.train.remounts`), and the forward
figure that allows for them (`check.remount_figure`): a re-mounting ahead cannot be foreseen,
so the range says what one would cost, from the folds that met one."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from spectratac.dataset import Dataset
from spectratac.sim.ageing_skin import ageing_skin
from spectratac.train.check import poisson_quantile, remount_figure
from spectratac.train.remounts import remounted_sessions


def truth(ds: Dataset) -> list[int]:
    return [m["session_index"] for m in ds.meta["sessions"] if m["remounted"]]


@pytest.mark.parametrize("session_s", [2.0, 10.0, 40.0])
def test_every_re_mounting_of_the_ageing_skin_is_found_and_nothing_else(session_s: float) -> None:
    """Ten units each: the skin's ageing and the LEDs' dimming and warm-up move every channel
    together, a re-mounting each its own way."""
    for seed in range(10):
        ds = ageing_skin(sessions=36, session_s=session_s, seed=seed)
        assert remounted_sessions(ds, list(range(36))) == truth(ds), seed


def test_a_skin_never_re_mounted_has_none() -> None:
    for seed in range(5):
        ds = ageing_skin(sessions=36, session_s=10.0, seed=seed, remount_every=None)
        assert remounted_sessions(ds, list(range(36))) == []


def test_sessions_are_judged_in_the_order_given() -> None:
    """The order is time order (`check.time_order`): a step is from the session before."""
    ds = ageing_skin(sessions=12, session_s=4.0, seed=2)
    assert truth(ds) == [2, 9]
    backwards = list(range(11, -1, -1))  # 9 -> 8 and 2 -> 1 are now the steps
    assert remounted_sessions(ds, backwards) == [8, 1]


def sessions(rest: np.ndarray, common: np.ndarray, rows: int, seed: int) -> Dataset:
    """Sessions of `rows` rows each: a press dims channels 0-1 and lifts 2-3 (a SpectraTac
    press raises red and lowers the others), idle rows read each session's `rest` light
    times its `common` factor (LED dimming: every channel alike)."""
    rng = np.random.default_rng(seed)
    parts, ses, force = [], [], []
    for k, (r, c) in enumerate(zip(rest, common, strict=True)):
        press = (np.arange(rows) % 50) >= 30
        light = np.tile(r * c, (rows, 1))
        light[press] *= np.array([0.7, 0.8, 1.2, 1.3])
        parts.append(light * (1.0 + 0.002 * rng.normal(size=light.shape)))
        ses.append(np.full(rows, k))
        force.append(np.where(press, 3.0, 0.0))
    ds = Dataset.generic(np.concatenate(parts), np.concatenate(force), ["a", "b", "c", "d"], ["Fz"])
    ds.arrays["session"] = np.concatenate(ses).astype(np.int16)
    return ds


@settings(max_examples=30, deadline=None)
@given(
    n=st.integers(6, 14),
    common=st.lists(st.floats(0.5, 1.5), min_size=14, max_size=14),
    at=st.integers(1, 13),
    size=st.floats(0.04, 0.3),
    sign=st.sampled_from([-1.0, 1.0]),
    seed=st.integers(0, 2**16),
)
def test_a_channel_step_is_a_re_mounting_and_dimming_alike_is_not(
    n: int, common: list[float], at: int, size: float, sign: float, seed: int
) -> None:
    """However much the LEDs dim or brighten from session to session (every channel by the
    same factor), no session is flagged; one channel moving against the others by 4 % or
    more is, at the session it moved."""
    base = np.array([20000.0, 15000.0, 9000.0, 30000.0])
    rest = np.tile(base, (n, 1))
    assert remounted_sessions(sessions(rest, np.asarray(common[:n]), 200, seed),
                              list(range(n))) == []  # fmt: skip
    at = min(at, n - 1)
    rest[at:, seed % 4] *= 1.0 + sign * size
    found = remounted_sessions(sessions(rest, np.asarray(common[:n]), 200, seed), list(range(n)))
    assert found == [at]


@settings(max_examples=60, deadline=None)
@given(
    a=st.floats(0.0, 0.5),
    g=st.floats(0.0, 0.1),
    b=st.floats(0.01, 1.0),
    own=st.floats(0.01, 1.0),
    mark=st.integers(10, 24),
)
def test_the_figure_takes_apart_drift_and_a_re_mounting(
    a: float, g: float, b: float, own: float, mark: int
) -> None:
    """Folds whose excess is exactly a + g i + b r (i sessions ahead, r re-mountings their
    model did not see): the figure is own + a + g i + b i rate over the horizon, the range
    from no re-mounting ahead to q before the next session."""
    horizon, order = 8, list(range(28))
    folds = []
    for k in (9, 13, 16, 20):
        ses = list(range(k, k + horizon))
        err = [own + a + g * i + b * (k <= mark <= s) for i, s in enumerate(ses, start=1)]
        folds.append({"trained_on": k, "train_mae": {"Fz": own}, "sessions": ses,
                      "session_mae": [{"Fz": e} for e in err]})  # fmt: skip
    got = remount_figure(folds, "Fz", order, [mark], horizon, own)
    if not any(k <= mark < k + horizon for k in (9, 13, 16, 20)) or mark <= 9:
        return  # no fold met it unseen, or every one did: nothing tells the two apart
    assert got is not None
    figure, low, high, q = got
    rate, mid = 1 / 27, (horizon + 1) / 2
    assert figure == pytest.approx(own + a + g * mid + b * rate * mid, rel=1e-6, abs=1e-9)
    assert low == pytest.approx(own + a + g * mid, rel=1e-6, abs=1e-9)
    assert high == pytest.approx(own + a + g * mid + b * q, rel=1e-6, abs=1e-9)
    assert q == 1 and low <= figure <= high


def test_without_a_re_mounting_in_or_out_of_the_folds_there_is_no_such_figure() -> None:
    folds = [{"trained_on": k, "train_mae": {"Fz": 0.1}, "sessions": [k, k + 1],
              "session_mae": [{"Fz": 0.2}, {"Fz": 0.3}]} for k in (4, 6)]  # fmt: skip
    assert remount_figure(folds, "Fz", list(range(10)), [], 2, 0.1) is None
    assert remount_figure(folds, "Fz", list(range(10)), [2], 2, 0.1) is None  # all seen
    assert remount_figure(folds, "Fz", list(range(10)), [5], 2, None) is None


@given(lam=st.floats(0.0, 30.0), p=st.floats(0.01, 0.99))
def test_the_poisson_quantile_is_the_smallest_count_reaching_p(lam: float, p: float) -> None:
    q = poisson_quantile(p, lam)

    def cdf(k: int) -> float:
        return sum(math.exp(-lam) * lam**j / math.factorial(j) for j in range(k + 1))

    assert cdf(q) >= p - 1e-12
    assert q == 0 or cdf(q - 1) < p + 1e-12


def test_the_range_prices_re_mountings_ahead_at_the_dearer_ones_met() -> None:
    """Two re-mountings met by the folds, one costing 0.1 N and one 0.8 N: the mean cost
    would price the next one at well under the dear one; the high end allows for a dear
    one (a re-mounting's gain steps are drawn afresh each time)."""
    horizon, order, cost = 8, list(range(28)), {12: 0.1, 22: 0.8}
    folds = []
    for k in (9, 13, 16, 20):
        ses = list(range(k, k + horizon))
        err = [0.2 + 0.02 * i + sum(c for m, c in cost.items() if k <= m <= s)
               for i, s in enumerate(ses, start=1)]  # fmt: skip
        folds.append({"trained_on": k, "train_mae": {"Fz": 0.2}, "sessions": ses,
                      "session_mae": [{"Fz": e} for e in err]})  # fmt: skip
    got = remount_figure(folds, "Fz", order, sorted(cost), horizon, 0.2)
    assert got is not None
    figure, low, high, q = got
    assert high - low >= 0.7 * q
    assert figure - low < 0.7  # the figure prices them at the history's rate, not the dearest
