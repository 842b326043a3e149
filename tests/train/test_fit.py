"""`spectratac.train.fit` from Python: the decoder comes with its held-out check, as on the
command line, whichever rows it holds out and whichever recipe it follows."""

from __future__ import annotations

import json

import numpy as np
import pytest
from spectratac.cli import main
from spectratac.dataset import Dataset
from spectratac.decode import Decoder, DecoderConfigError
from spectratac.sim.generic_skin import generic_skin
from spectratac.train import FinetuneOptions, SplitSpec, Trained, TrainSpec, fit
from spectratac.train.holdout import resolve

RIDGE = TrainSpec(features="generic", model="ridge", targets=("Fz",))


def sessions_ds(n_sessions: int = 4, rows: int = 100) -> Dataset:
    """A linear sensor with noise, `n_sessions` sessions alike."""
    rng = np.random.default_rng(0)
    x = rng.normal(size=(n_sessions * rows, 2))
    session = np.repeat(np.arange(n_sessions), rows)
    y = x @ [1.0, -2.0] + 0.1 * rng.normal(size=x.shape[0])
    ds = Dataset.generic(x, y[:, None], ["a", "b"], ["Fz"])
    ds.arrays["session"][:] = session
    return ds


def test_a_check_model_holds_whole_groups_out_when_the_model_keeps_every_row() -> None:
    trained = fit(sessions_ds(), RIDGE)
    c = trained.check
    assert isinstance(trained, Trained) and trained.summary["n_train"] == 400
    assert (c.heldout_groups, c.heldout_source) == (
        "session",
        "a check model trained on the other groups",
    )
    assert c.n_heldout == 100 and set(c.train_mae) == set(c.heldout_mae) == {"Fz"}
    assert c.gap == pytest.approx(c.heldout_mae["Fz"] / c.train_mae["Fz"], abs=0.01)
    assert c.warning is None and trained.summary["mae_rows"] == "all (training rows included)"


def test_a_model_that_fits_what_is_particular_to_its_sessions_is_flagged() -> None:
    # Fz is shifted by 0, 5, 0, 5 N in sessions 0-3, and one input carries the session
    # index: a quadratic ridge fits the three training sessions' shifts exactly and
    # interpolates the held-out session's wrongly (the same gap `spectratac train` warns of)
    rng = np.random.default_rng(0)
    x = rng.normal(size=(400, 2))
    s = np.repeat(np.arange(4), 100)
    y = x @ [1.0, -2.0] + 0.1 * rng.normal(size=400) + np.array([0.0, 5.0, 0.0, 5.0])[s]
    ds = Dataset.generic(np.c_[x, s], y[:, None], ["a", "b", "c"], ["Fz"])
    ds.arrays["session"][:] = s
    spec = TrainSpec(features="generic", model="ridge", targets=("Fz",), degree=2,
                     ridge_alpha=1e-6)  # fmt: skip
    trained = fit(ds, spec)
    assert trained.check.gap > 10 and trained.check.heldout_mae["Fz"] > 3
    assert trained.check.warning.startswith("held-out error is")
    assert trained.report()["warning"] == trained.check.warning
    assert fit(sessions_ds(), RIDGE).check.warning is None  # alike sessions: no warning


def test_holdout_split_and_sessions_are_recorded_and_checked_on_their_test_rows() -> None:
    ds = sessions_ds()
    split = fit(ds, RIDGE, holdout=SplitSpec("blocked", seed=1))
    assert split.check.heldout_source == "holdout split"
    assert resolve(split.decoder.meta, ds).status == "split"
    assert split.summary["mae_rows"] == "held-out" and split.summary["n_test"] > 0
    held = fit(ds, RIDGE, holdout_sessions="2-3")
    assert held.check.heldout_source == "--holdout-sessions" and held.check.n_heldout == 200
    assert held.summary["n_test"] == 200 and held.summary["n_train"] == 200
    assert held.summary["holdout"]["held_out"] == [2, 3]
    same = fit(ds, RIDGE, holdout_sessions=[3, 2])
    assert same.check == held.check


def test_refusals() -> None:
    ds = sessions_ds()
    with pytest.raises(DecoderConfigError, match="not both"):
        fit(ds, RIDGE, holdout=SplitSpec(), holdout_sessions=[1])
    with pytest.raises(DecoderConfigError, match="base's recipe"):
        fit(ds, RIDGE, finetune_from=fit(ds, RIDGE).decoder)
    with pytest.raises(Exception, match="leaves no training row"):
        fit(ds, RIDGE, holdout_sessions="0-3")


def test_report_is_the_command_lines_json(tmp_path, capsys) -> None:
    ds = sessions_ds()
    data = ds.save(tmp_path / "d.npz")
    out = tmp_path / "m.stac"
    argv = ["train", str(data), "-o", str(out), "--model", "ridge", "--json", "--no-progress"]
    assert main(argv) == 0
    cli = json.loads(capsys.readouterr().out)
    trained = fit(ds, RIDGE)
    mine = json.loads(json.dumps(trained.report({"model": str(out)})))
    for d in (cli, mine):
        d.pop("train_seconds")
    assert list(mine) == list(cli) and mine == cli


@pytest.mark.train
def test_the_drifting_skin_warns_from_python_as_on_the_command_line() -> None:
    ds = generic_skin(sessions=8, session_s=8.0, seed=0, drift=True)
    spec = TrainSpec.paper(features="generic", targets=("Fz",), epochs=10, threads=1)
    trained = fit(ds, spec, progress=False)
    assert trained.check.heldout_groups == "session" and trained.check.gap > 2
    assert "held-out error is" in trained.check.warning
    assert trained.decoder.meta["n_val"] == 0  # the check model held the sessions out


@pytest.mark.train
def test_fine_tuning_and_the_auto_recipe_go_through_fit(tmp_path) -> None:
    ds = generic_skin(sessions=4, session_s=8.0, seed=0, drift=False)
    base = fit(ds, TrainSpec.paper(features="generic", targets=("Fz",), epochs=2, threads=1),
               progress=False).decoder  # fmt: skip
    path = base.save(tmp_path / "base.stac")
    tuned = fit(ds, finetune_from=path, finetune_options=FinetuneOptions(epochs=1),
                progress=False)  # fmt: skip
    assert tuned.summary["finetuned_from"]["path"] == str(path)
    assert tuned.check.heldout_mae["Fz"] > 0
    auto = fit(ds, RIDGE, budget=2.0, workers=1, progress=False)
    assert auto.search is not None and auto.report()["auto_recipe"] == auto.search.report
    assert auto.check.heldout_source.endswith("cross-validation of the chosen candidate")
    assert isinstance(Decoder.load(auto.decoder.save(tmp_path / "a.stac")), Decoder)
