"""`spectratac train` reports training against held-out-group error and warns on a gap."""

from __future__ import annotations

import json

import pytest
from spectratac.cli import main
from spectratac.decode import Decoder
from spectratac.sim.generic_skin import generic_skin

pytestmark = pytest.mark.train


def train_json(tmp_path, drift: bool, *extra: str) -> tuple[dict, str]:
    data = generic_skin(sessions=8, session_s=8.0, seed=0, drift=drift).save(tmp_path / "d.npz")
    out = tmp_path / "m.stac"
    argv = ["train", str(data), "-o", str(out), "--json", "--no-progress", *extra]
    assert main(argv) == 0
    return out, argv


@pytest.mark.parametrize("drift", [True, False], ids=["drifting", "stationary"])
def test_paper_recipe_gap_warns_on_the_drifting_skin_only(tmp_path, capsys, drift) -> None:
    out, _ = train_json(tmp_path, drift, "--epochs", "10", "--threads", "1")
    cap = capsys.readouterr()
    s = json.loads(cap.out)
    assert s["heldout_groups"] == "session" and s["n_heldout"] > 0
    assert set(s["train_mae"]) == set(s["heldout_mae"]) == {"Fz"}
    assert s["gap"] == pytest.approx(s["heldout_mae"]["Fz"] / s["train_mae"]["Fz"], rel=0.01)
    # the model itself still trains on every row (the check model holds sessions out)
    assert s["n_train"] == 6400 and Decoder.load(out).meta["n_val"] == 0
    if drift:
        assert s["gap"] > 2 and "held-out error is" in s["warning"]
        assert "warning: held-out error is" in cap.err
    else:
        assert s["gap"] < 2 and s["warning"] is None and "warning" not in cap.err


def test_validation_groups_of_the_model_itself_are_used_when_it_has_them(tmp_path, capsys):
    train_json(tmp_path, True, "--epochs", "2", "--hidden", "8", "--blocks", "1",
               "--val-fraction", "0.25")  # fmt: skip
    s = json.loads(capsys.readouterr().out)
    assert s["heldout_source"] == "the model's validation groups"
    assert s["n_train"] + s["n_heldout"] == 6400 and s["n_heldout"] == 1600  # 2 sessions


def test_recipe_auto_within_a_budget_writes_the_chosen_model(tmp_path, capsys) -> None:
    out, _ = train_json(tmp_path, True, "--recipe", "auto", "--budget", "2s", "--workers", "1")
    s = json.loads(capsys.readouterr().out)
    rep = s["auto_recipe"]
    status = {c["name"]: c["status"] for c in rep["candidates"]}
    assert status["linear"] == status["linear+drift"] == "done"
    assert all(v == "done" or v.startswith("skipped") for v in status.values())
    assert rep["chosen"] in status and status[rep["chosen"]] == "done"
    dec = Decoder.load(out)
    assert dec.meta["auto_recipe"]["chosen"] == rep["chosen"]
    # eight sessions in time order: ranked on forward-in-time folds, whose trend is printed
    fwd = f"{rep['folds']}-fold forward-in-time folds of the chosen candidate"
    assert s["heldout_source"] == fwd
    assert rep["fold_kind"] == "forward" and s["forward"] is not None
    assert s["expected_text"].startswith("expect on your next session and the")
    assert s["heldout_mae"]["Fz"] > 0 and s["train_mae"]["Fz"] > 0
