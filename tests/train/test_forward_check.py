"""Forward chaining (issue 22 item 4): with sessions in time order the held-out check trains
on earlier sessions and scores later ones beside the round-robin figure, reports the worst
group beside the mean, and `train` prints the figure to expect on a new session."""

from __future__ import annotations

import json

import numpy as np
import pytest
from spectratac.cli import main
from spectratac.dataset import Dataset
from spectratac.train import TrainSpec, fit

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
    assert check.forward is not None and check.forward.sessions == [3, 4, 5]
    fwd = check.forward.mean_mae["Fz"]
    # the round-robin figure interpolates across the ageing; forward chaining does not
    assert fwd > 1.3 * check.heldout_mae["Fz"], (fwd, check.heldout_mae)
    assert check.forward.worst_mae["Fz"] >= fwd
    assert check.heldout_worst["Fz"] >= check.heldout_mae["Fz"] - 1e-12
    expected, source = check.expected()
    assert expected == check.forward.mean_mae and "forward chaining" in source
    # it predicts the next, unseen session: train on all six, score the seventh
    later = drifting(n_sessions=7)
    nxt = later.arrays["session"] == 6
    dec = fit(ds, RIDGE, progress=False).decoder
    truth = float(np.mean(np.abs(dec.predict(later).targets[nxt, 0] - later.targets[nxt, 0])))
    # the mean promises less than the next session gives on a sensor that keeps ageing;
    # the worst later session is the conservative figure printed beside it
    assert truth / 1.3 <= check.forward.worst_mae["Fz"] <= 1.3 * truth, (check.forward, truth)
    assert expected["Fz"] > check.heldout_mae["Fz"]


def test_train_prints_what_to_expect_on_a_new_session(tmp_path, capsys) -> None:
    data = drifting().save(tmp_path / "d.npz")
    args = ["train", str(data), "--model", "ridge", "--features", "generic", "--targets", "Fz",
            "-o", str(tmp_path / "m.stac"), "--no-progress"]  # fmt: skip
    assert main(args) == 0
    out = capsys.readouterr().out
    assert "expect on a new session: MAE Fz" in out and "forward in time" in out, out
    assert "worst held-out session" in out
    assert main([*args[:-3], "-o", str(tmp_path / "n.stac"), "--json", "--no-progress"]) == 0
    rep = json.loads(capsys.readouterr().out)
    assert rep["expected_mae"]["Fz"] == rep["forward"]["mean_mae"]["Fz"]
    assert rep["forward"]["sessions"] == [3, 4, 5]


def test_one_session_has_no_forward_figure() -> None:
    check = fit(drifting(n_sessions=1, n=2000), RIDGE, progress=False).check
    assert check.forward is None
    assert check.expected()[0] == check.heldout_mae
