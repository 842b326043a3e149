"""Issue 35 items 2-4 on the ageing skin (`spectratac.sim.ageing_skin`): forward-in-time folds
(the auto recipe ranks on them), a figure the sessions that follow do not beat by 2x, a
gain-only recalibration from 30 s of a later session that beats the base, and a check that
costs at most one more fit and is counted in `train`'s estimate."""

from __future__ import annotations

import json

import numpy as np
import pytest
from spectratac.cli import main
from spectratac.dataset import Dataset
from spectratac.decode import Decoder
from spectratac.sim.ageing_skin import ageing_skin
from spectratac.train import FinetuneOptions, TrainSpec, fit, train
from spectratac.train.auto_recipe import search
from spectratac.train.auto_recipe.search import _forward_folds
from spectratac.train.auto_recipe.space import Candidate
from spectratac.train.check import check_rows_for_options, held_out_check
from spectratac.train.metrics import decoder_mae

SESSION_S, SEED = 10.0, 0  # the network test's ageing skin
RIDGE = TrainSpec(model="ridge", degree=2, features="generic", targets=("Fz",))


@pytest.fixture(scope="module")
def skin() -> Dataset:
    return ageing_skin(sessions=12, session_s=3.0, seed=2)


def test_the_skin_reads_later_sessions_low() -> None:
    """A decoder of the first sessions reads the later ones low: the multiplicative
    under-read of the real skin (the ageing alone; re-mountings add steps)."""
    ds = ageing_skin(sessions=20, session_s=10.0, seed=0, remount_every=None)
    ses = np.asarray(ds.session, np.int64)
    dec = train(ds, RIDGE, rows=np.flatnonzero(ses < 8), progress=False)
    y, p = ds.targets[:, 0], dec.predict(ds).column("Fz")

    def read(lo: int, hi: int) -> float:
        r = (ses >= lo) & (ses < hi) & (y > 2.0)
        return float(np.sum(p[r] * y[r]) / np.sum(y[r] * y[r]))

    assert 0.9 < read(0, 8) < 1.1
    assert read(8, 14) < 0.85 and read(14, 20) < 0.85


def test_auto_folds_train_only_on_earlier_sessions_in_recording_order(skin: Dataset) -> None:
    ds = Dataset(dict(skin.arrays), dict(skin.meta))
    # the files were given out of order: recording times decide, not session numbers
    order = np.random.default_rng(0).permutation(12)
    ds.meta["sessions"] = [dict(m, started_unix=float(order[i]))
                           for i, m in enumerate(skin.meta["sessions"])]  # fmt: skip
    folds, plan = _forward_folds(ds, np.arange(ds.n))  # type: ignore[misc]
    assert plan["ordered_by"] == "recording" and plan["horizon"] == 4
    when = order[np.asarray(ds.session, np.int64)]  # each row's place in time
    for (fit_rows, held), k in zip(folds, plan["trained_on"], strict=True):
        assert set(when[fit_rows].tolist()) == set(range(k))
        assert set(when[held].tolist()) == set(range(k, k + 4))


def test_auto_ranks_on_forward_folds_and_prints_the_next_sessions(skin: Dataset) -> None:
    space = [Candidate("linear", "classical", TrainSpec(
        model="ridge", degree=1, features="generic", targets=("Fz",)))]  # fmt: skip
    res = search(skin, 60.0, space=space, workers=1)
    assert res.report["fold_kind"] == "forward" and res.report["forward"]["horizon"] == 4
    trained = fit(skin, TrainSpec(features="generic", targets=("Fz",)), budget=60.0, workers=1,
                  progress=False)  # fmt: skip
    assert trained.check.forward is not None
    assert trained.check.expected_text().startswith("expect on your next session and the 3")


def test_the_printed_figure_is_not_beaten_twice_by_the_next_sessions() -> None:
    """Weeks of sessions, trained on the first 28, scored on the 8 after them (as on the
    real skin): one-session-ahead folds promised a third of the error met."""
    ds = ageing_skin(sessions=36, session_s=6.0, seed=1)
    ses = np.asarray(ds.session, np.int64)
    trained = fit(ds.subset(np.flatnonzero(ses < 28)), RIDGE, progress=False)
    printed = trained.check.expected()[0]["Fz"]
    truth = decoder_mae(trained.decoder, ds, np.flatnonzero(ses >= 28))["Fz"]
    assert truth / 2 <= printed <= 2 * truth, (printed, truth, trained.check.forward)


@pytest.mark.train
def test_a_networks_figure_holds_within_1_5x_on_the_next_sessions() -> None:
    """The paper's network on weeks of sessions, trained on the first 28 and scored on the
    8 after them: the figure within 1.5x of what those sessions measure. The check's
    models trained on a third of the rows at the real model's batch took a third of its
    steps, erred far more than it and printed a figure the next sessions beat by 2x."""
    ds = ageing_skin(sessions=36, session_s=SESSION_S, seed=SEED)
    ses = np.asarray(ds.session, np.int64)
    spec = TrainSpec.paper(features="generic", targets=("Fz",))
    trained = fit(ds.subset(np.flatnonzero(ses < 28)), spec, progress=False)
    printed = trained.check.expected()[0]["Fz"]
    truth = decoder_mae(trained.decoder, ds, np.flatnonzero(ses >= 28))["Fz"]
    assert truth / 1.5 <= printed <= 1.5 * truth, (printed, truth, trained.check.forward)
    low, high = trained.check.expected_range()["Fz"]
    assert low < printed < high


@pytest.mark.train
def test_re_mountings_ahead_are_inside_the_printed_range() -> None:
    """Seed 1 re-mounts three times in the 8 sessions after the 28 trained on (twice in the
    27 before): no figure from the past foresees that, and the paper network's printed
    figure was half the error those sessions measured, its range far below it. The range
    now runs to the re-mountings the history makes likely, priced by the folds that met one
    their model had not seen, and says so."""
    ds = ageing_skin(sessions=36, session_s=SESSION_S, seed=1)
    ses = np.asarray(ds.session, np.int64)
    spec = TrainSpec.paper(features="generic", targets=("Fz",))
    trained = fit(ds.subset(np.flatnonzero(ses < 28)), spec, progress=False)
    truth = decoder_mae(trained.decoder, ds, np.flatnonzero(ses >= 28))["Fz"]
    low, high = trained.check.expected_range()["Fz"]
    assert low <= truth <= high, (low, truth, high, trained.check.forward)
    fwd = trained.check.forward
    assert fwd is not None and fwd.remounted == [5, 15] and fwd.remounts_ahead >= 1
    assert "re-mounted before session(s) 5, 15" in " ".join(trained.check.expected_text().split())


def test_the_check_trains_on_no_more_rows_than_the_model(skin: Dataset) -> None:
    seen: list[int] = []
    dec = train(skin, RIDGE, progress=False)

    def spy(rows: np.ndarray) -> Decoder:
        seen.append(int(np.asarray(rows).size))
        return dec

    check = held_out_check(dec, skin, None, trainer=spy)
    assert check.forward is not None and len(seen) == 5  # the check model and four folds
    assert sum(seen) <= skin.n


def test_gain_only_recalibration_beats_the_base() -> None:
    """30 s of a later session teach one gain: it beats the base on the rest of that
    session (the fine-tuned layers did worse than the base on the real skin). The skin ages
    without re-mountings here: a re-mounting's offset is no gain (the benchmark has both)."""
    ds = ageing_skin(sessions=12, session_s=50.0, seed=1, remount_every=None)
    ses = np.asarray(ds.session, np.int64)
    t = np.asarray(ds.t_end)
    base = train(ds, RIDGE, rows=np.flatnonzero(ses < 8), progress=False)
    later = np.flatnonzero(ses == 11)
    cal, rest = later[t[later] - t[later[0]] < 30.0], later[t[later] - t[later[0]] >= 30.0]
    tuned = fit(ds.subset(cal), finetune_from=base,
                finetune_options=FinetuneOptions(mode="gain"), progress=False).decoder  # fmt: skip
    assert tuned.meta["finetuned_from"]["kept"] == "gain"
    before, after = decoder_mae(base, ds, rest)["Fz"], decoder_mae(tuned, ds, rest)["Fz"]
    assert after < 0.85 * before, (after, before)


def test_gain_only_needs_a_base(tmp_path, capsys) -> None:
    data = ageing_skin(sessions=2, session_s=3.0).save(tmp_path / "d.npz")
    code = main(["train", str(data), "--gain-only", "-o", str(tmp_path / "m.stac")])
    assert code == 2 and "--finetune BASE.stac" in capsys.readouterr().err


@pytest.mark.train
def test_trains_estimate_counts_the_check(tmp_path, capsys) -> None:
    data = ageing_skin(sessions=9, session_s=3.0).save(tmp_path / "d.npz")
    args = ["train", str(data), "--features", "generic", "--targets", "Fz", "--epochs", "1",
            "-o", str(tmp_path / "m.stac"), "--json", "--no-progress"]  # fmt: skip
    assert main(args) == 0
    rep = json.loads(capsys.readouterr().out)
    parts = rep["estimate"]["parts_s"]
    assert parts["held-out and forward check"] > 0 and rep["forward"] is not None
    # thinned, the check's models together train on no more rows than the model (each
    # model's fixed cost aside): at most one more fit's work, not five
    spec = TrainSpec.paper(features="generic")
    plan = check_rows_for_options(Dataset.load(data), spec, None, None)
    assert len(plan) == 5 and sum(plan) <= rep["n_train"] + len(plan)


def test_train_gain_only_from_the_command_line(tmp_path, capsys) -> None:
    ds = ageing_skin(sessions=10, session_s=40.0, seed=1, remount_every=None)
    ses = np.asarray(ds.session, np.int64)
    t = np.asarray(ds.t_end)
    base = train(ds, RIDGE, rows=np.flatnonzero(ses < 6), progress=False)
    base.save(tmp_path / "base.stac")
    later = np.flatnonzero(ses == 9)
    new = ds.subset(later[t[later] - t[later[0]] < 30.0]).save(tmp_path / "new.npz")
    args = ["train", str(new), "--finetune", str(tmp_path / "base.stac"), "--gain-only",
            "-o", str(tmp_path / "recal.stac"), "--no-progress"]  # fmt: skip
    assert main(args) == 0
    out = capsys.readouterr().out
    assert "recalibrated by one output gain per target: it beat the base" in out, out
    recal = Decoder.load(tmp_path / "recal.stac")
    assert recal.meta["finetuned_from"]["mode"] == "gain"
    assert recal.runtime.y_scale[0] > base.runtime.y_scale[0]  # the later session reads low
