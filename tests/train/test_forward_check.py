"""Forward chaining (issue 22 item 4): with sessions in time order the held-out check trains
on earlier sessions and scores later ones beside the round-robin figure, reports the worst
group beside the mean, and `train` prints the figure to expect on a new session."""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from spectratac.cli import main
from spectratac.dataset import Dataset
from spectratac.decode import Decoder
from spectratac.train import TrainSpec, fit, train
from spectratac.train.check import FORWARD_SESSIONS, forward_check

pytestmark = pytest.mark.train

RIDGE = TrainSpec(model="ridge", features="generic", targets=("Fz",))


def drifting(n_sessions: int = 6, n: int = 200, seed: int = 0) -> Dataset:
    """Sessions whose sensor gain falls session after session (ageing): a model interpolates
    between the sessions around a held-out one, but must extrapolate to a later one."""
    rng = np.random.default_rng(seed)
    xs, ys, ss = [], [], []
    for s in range(n_sessions):
        f = rng.uniform(0, 5, n)
        gain = 1.0 - 0.12 * s
        x = np.stack([gain * f + 0.02 * rng.normal(size=n), rng.normal(size=n)], axis=1)
        xs.append(x)
        ys.append(f)
        ss.append(np.full(n, s))
    ds = Dataset.generic(np.concatenate(xs), np.concatenate(ys), ["a", "b"], ["Fz"])
    ds.arrays["session"] = np.concatenate(ss).astype(np.int16)
    ds.meta["sessions"] = [{"source": f"day {s}"} for s in range(n_sessions)]
    return ds


def test_forward_chaining_reports_later_sessions_and_the_worst_group() -> None:
    ds = drifting()
    check = fit(ds, RIDGE, progress=False).check
    assert check.forward is not None and check.forward.sessions == [2, 3, 4, 5]
    fwd = check.forward.mean_mae["Fz"]
    # the round-robin figure interpolates across the ageing; forward chaining does not
    assert fwd > 1.3 * check.heldout_mae["Fz"], (fwd, check.heldout_mae)
    assert check.forward.worst_mae["Fz"] >= fwd
    # each later session weighs twice the one before it: drift grows with time
    folds = [check.forward.per_session[str(s)]["Fz"] for s in (2, 3, 4, 5)]
    assert fwd == pytest.approx(np.dot([1, 2, 4, 8], folds) / 15)
    assert check.heldout_worst["Fz"] >= check.heldout_mae["Fz"] - 1e-12
    expected, source = check.expected()
    assert expected == check.forward.mean_mae and "forward check over 4 sessions" in source
    # it predicts the next, unseen session: train on all six, score the seventh
    later = drifting(n_sessions=7)
    nxt = later.arrays["session"] == 6
    dec = fit(ds, RIDGE, progress=False).decoder
    truth = float(np.mean(np.abs(dec.predict(later).targets[nxt, 0] - later.targets[nxt, 0])))
    # the mean promises less than the next session gives on a sensor that keeps ageing;
    # the worst later session is the conservative figure printed beside it
    assert truth / 1.3 <= check.forward.worst_mae["Fz"] <= 1.3 * truth, (check.forward, truth)
    assert expected["Fz"] > check.heldout_mae["Fz"]


def test_the_worst_held_out_session_is_a_session() -> None:
    """Held out were whole sessions: the worst group reported is one of them (it was a time
    block or a press of the held-out session, labelled as a session)."""
    ds = drifting()
    check = fit(ds, RIDGE, progress=False).check
    assert check.heldout_groups == "session" and check.n_heldout == 200  # one session of six
    assert check.heldout_worst_group in set(np.asarray(ds.session).tolist())
    assert check.heldout_worst == pytest.approx(check.heldout_mae)  # the only one held out


def test_train_prints_what_to_expect_on_a_new_session(tmp_path, capsys) -> None:
    data = drifting().save(tmp_path / "d.npz")
    args = ["train", str(data), "--model", "ridge", "--features", "generic", "--targets", "Fz",
            "-o", str(tmp_path / "m.stac"), "--no-progress"]  # fmt: skip
    assert main(args) == 0
    out = capsys.readouterr().out
    assert "expect on your next session: Fz ~" in out and "forward in time" in out, out
    said = " ".join(out.split())  # the sentence is wrapped to the terminal's width
    assert "forward check over 4 sessions in session number order" in said, out
    assert "worst, session 5: Fz" in said, out
    assert "worst held-out session" in out
    assert main([*args[:-3], "-o", str(tmp_path / "n.stac"), "--json", "--no-progress"]) == 0
    rep = json.loads(capsys.readouterr().out)
    assert rep["expected_mae"]["Fz"] == rep["forward"]["mean_mae"]["Fz"]
    assert rep["expected_text"].startswith("expect on your next session: Fz ~")
    assert rep["forward"]["sessions"] == [2, 3, 4, 5]


def test_one_session_has_no_forward_figure() -> None:
    check = fit(drifting(n_sessions=1, n=2000), RIDGE, progress=False).check
    assert check.forward is None
    assert check.expected()[0] == check.heldout_mae


@pytest.fixture(scope="module")
def one_decoder() -> Decoder:
    return train(drifting(), RIDGE, progress=False)


@st.composite
def recordings(draw: st.DrawFn) -> tuple[Dataset, np.ndarray, list[int]]:
    """Sessions with arbitrary ids, rows in any order, start times in any order or none, and a
    subset of rows; returns (dataset, rows, session ids in recording order)."""
    ids = draw(st.lists(st.integers(0, 12), min_size=3, max_size=7, unique=True))
    sizes = draw(st.lists(st.integers(2, 6), min_size=len(ids), max_size=len(ids)))
    ses = np.repeat(ids, sizes)
    perm = np.asarray(draw(st.permutations(range(ses.size))))
    ses = ses[perm]
    x = np.random.default_rng(len(ids)).normal(size=(ses.size, 2))
    ds = Dataset.generic(x, x[:, :1], ["a", "b"], ["Fz"])
    ds.arrays["session"] = ses.astype(np.int16)
    timed = draw(st.booleans())
    starts = draw(st.permutations(range(13)))  # start time rank of each session id
    ds.meta["sessions"] = [{"started_unix": 1.7e9 + 3600.0 * r} if timed else {} for r in starts]
    in_time = sorted(ids, key=lambda i: starts[i]) if timed else sorted(ids)
    keep = draw(st.lists(st.booleans(), min_size=ses.size, max_size=ses.size))
    rows = np.flatnonzero(
        np.asarray(keep) | np.isin(np.arange(ses.size), np.unique(ses, return_index=True)[1])
    )
    return ds, rows, in_time


@settings(max_examples=40, deadline=None)
@given(recordings())
def test_forward_folds_train_on_every_earlier_session_and_never_a_later_one(
    one_decoder: Decoder, rec: tuple[Dataset, np.ndarray, list[int]]
) -> None:
    ds, rows, in_time = rec
    ses = np.asarray(ds.session, np.int64)
    calls: list[np.ndarray] = []

    def spy(fit_rows: np.ndarray) -> Decoder:
        calls.append(np.asarray(fit_rows))
        return one_decoder

    fwd = forward_check(ds, rows, spy)
    assert fwd is not None
    present = [s for s in in_time if s in set(ses[rows].tolist())]
    k = min(FORWARD_SESSIONS, len(present) - 1)
    assert fwd.sessions == present[-k:]  # the last sessions in recording order
    assert fwd.ordered_by == ("recording" if ds.meta["sessions"][0] else "session number")
    for scored, fit_rows in zip(fwd.sessions, calls, strict=True):
        earlier = present[: present.index(scored)]
        want = rows[np.isin(ses[rows], earlier)]  # all of `rows` recorded before, nothing else
        assert sorted(fit_rows.tolist()) == sorted(want.tolist()), (scored, earlier)


def test_sessions_numbered_out_of_time_order_are_chained_by_their_start_times() -> None:
    """`dataset build` numbers recordings in the order its files were given: the forward check
    follows the recordings' start times, so the sessions it scores are the latest ones."""
    ds = drifting()
    numbered = [3, 0, 5, 1, 4, 2]  # session number of the recording made on day d
    day = np.asarray(ds.session, np.int64)
    ds.arrays["session"] = np.asarray(numbered, np.int16)[day]
    ds.meta["sessions"] = [{"source": f"day {numbered.index(s)}",
                            "started_unix": 1.7e9 + 86400.0 * numbered.index(s)}
                           for s in range(6)]  # fmt: skip
    check = fit(ds, RIDGE, progress=False).check
    assert check.forward is not None and check.forward.ordered_by == "recording"
    assert check.forward.sessions == [5, 1, 4, 2]  # days 2, 3, 4, 5
    assert "in recording order" in " ".join(check.expected_text().split())
    in_order = fit(drifting(), RIDGE, progress=False).check
    assert check.forward.mean_mae["Fz"] == pytest.approx(in_order.forward.mean_mae["Fz"])


@pytest.mark.subprocess
def test_the_bench_gives_the_same_figures_for_the_same_seed(run_bench) -> None:
    args = ("heldout_forward", "--units", "0", "--session-s", "10", "--train", "3",
            "--next", "1", "--seed", "3")  # fmt: skip
    first, again = run_bench(*args), run_bench(*args)
    assert first == again
    fig = first["unit 0 Fz printed figure (ridge)"]
    assert fig["ratio"] == pytest.approx(fig["value"] / fig["reference_value"])
    assert "forward check over 2 sessions" in fig["extra"]["source"]
    assert list(fig["extra"]["forward_sessions"]) == ["1", "2"]
    share = first["share within 1.3x: printed figure"]
    assert share["extra"]["n"] == 3 and share["extra"]["config"]["seed"] == 3
