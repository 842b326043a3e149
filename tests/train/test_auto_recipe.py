"""`search` (--recipe auto): grouped CV, the budget (injected clock), the one-SE rule, runners."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from spectratac.decode import Decoder
from spectratac.sim.generic_skin import generic_skin
from spectratac.train import TrainSpec
from spectratac.train.auto_recipe import Candidate, one_se_choice, search
from spectratac.train.auto_recipe.budget import PRIOR_S_PER_WORK, Budget, CostModel

pytestmark = pytest.mark.train


@pytest.fixture(scope="module")
def skin():
    return generic_skin(sessions=6, session_s=4.0, seed=3)


def tiny_space() -> list[Candidate]:
    ridge = TrainSpec(features="generic", model="ridge", targets=("Fz",))
    net = TrainSpec.paper(features="generic", targets=("Fz",), model="mlp", hidden=8,
                          blocks=1, epochs=2, threads=1)  # fmt: skip
    return [
        Candidate("linear", "classical", ridge),
        Candidate("poly2+drift", "classical", replace(ridge, degree=2, drift="baseline")),
        Candidate("mlp8", "network", net),
        Candidate("mlp8+drift", "network", replace(net, drift="baseline")),
    ]


class SteppedClock:
    """Seconds that move only when the test says so."""

    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


def test_everything_runs_when_time_stands_still(skin, tmp_path) -> None:
    clock = SteppedClock()
    res = search(skin, 60.0, space=tiny_space(), workers=1, folds=3, clock=clock)
    rep = res.report
    assert rep["groups"] == {"kind": "session", "n": 6} and rep["folds"] == 3
    assert [c["status"] for c in rep["candidates"]] == ["done"] * 4
    for c in rep["candidates"]:
        assert c["cv_score"] > 0 and c["cv_se"] > 0 and c["flops"] > 0
        assert c["us_per_sample"] > 0 and c["us_single"] > 0 and c["cv_mae"]["Fz"]["mean"] > 0
        assert c["train_mae"]["Fz"] > 0
    assert rep["within_budget"] and rep["elapsed_s"] == 0.0
    # one-SE rule: the chosen model is within one se of the best and no costlier
    by = {c["name"]: c for c in rep["candidates"]}
    best, chosen = by[rep["best"]], by[rep["chosen"]]
    assert best["cv_score"] == min(c["cv_score"] for c in rep["candidates"])
    assert chosen["cv_score"] <= best["cv_score"] + best["cv_se"]
    assert chosen["flops"] <= best["flops"]
    # the chosen model is refitted on all rows and carries the report
    assert res.decoder.meta["auto_recipe"]["chosen"] == rep["chosen"]
    assert res.decoder.meta["n_train"] >= 0.9 * skin.n
    loaded = Decoder.load(res.decoder.save(tmp_path / "auto.stac"))
    assert loaded.meta["auto_recipe"]["candidates"][0]["name"] == "linear"
    assert "<- chosen" in res.text() and "mlp8" in res.text()


def test_nothing_is_launched_past_the_budget_but_linear_baselines_always_run(skin) -> None:
    clock = SteppedClock()

    def after_each_trial(line: str) -> None:
        clock.now += 100.0  # every finished trial "took" 100 s of a 60 s budget

    res = search(skin, 60.0, space=tiny_space(), workers=1, folds=3, clock=clock,
                 progress=after_each_trial)  # fmt: skip
    status = {c["name"]: c["status"] for c in res.report["candidates"]}
    assert status["linear"] == "done"  # the linear baselines always run
    for name in ("poly2+drift", "mlp8", "mlp8+drift"):
        assert status[name] == "skipped: would not fit the budget"
    assert res.report["chosen"] == "linear"
    assert not res.report["within_budget"]


def test_budget_counts_the_refit_and_learns_trial_cost() -> None:
    clock = SteppedClock()
    b = Budget(60.0, clock)
    clock.now = 10.0
    assert b.fits(trial_s=30.0, refit_s=20.0, running_until=0.0)
    assert not b.fits(trial_s=30.0, refit_s=21.0, running_until=0.0)  # the refit counts
    assert not b.fits(trial_s=1.0, refit_s=10.0, running_until=55.0)  # running trials count
    cm = CostModel()
    assert cm.seconds("network", 1e12) == PRIOR_S_PER_WORK["network"] * 1e12
    cm.add("network", 10.0, 1e11)
    cm.add("network", 30.0, 1e11)
    assert cm.seconds("network", 1e12) == pytest.approx(200.0)  # median of measured rates


def test_one_se_rule_prefers_cheap_and_needs_an_eligible_finisher() -> None:
    rows = [
        {"name": "net", "cv_score": 0.30, "cv_se": 0.05, "flops": 9e4, "status": "done",
         "eligible": True},
        {"name": "poly", "cv_score": 0.34, "cv_se": 0.04, "flops": 500, "status": "done",
         "eligible": True},
        {"name": "lin", "cv_score": 0.40, "cv_se": 0.01, "flops": 60, "status": "done",
         "eligible": True},
    ]  # fmt: skip
    assert one_se_choice(rows) == ("poly", "net")
    rows[1]["eligible"] = False  # e.g. classes asked for: ridge cannot decode them
    assert one_se_choice(rows) == ("net", "net")
    with pytest.raises(Exception, match="no candidate finished"):
        one_se_choice([{**r, "status": "skipped"} for r in rows])


def test_a_network_is_chosen_only_when_it_beats_every_classical_baseline() -> None:
    done = {"status": "done", "eligible": True}
    rows = [
        {"name": "net", "family": "network", "cv_score": 0.30, "cv_se": 0.05, "flops": 9e4},
        {"name": "small-net", "family": "network", "cv_score": 0.33, "cv_se": 0.05,
         "flops": 400},
        {"name": "poly", "family": "classical", "cv_score": 0.32, "cv_se": 0.04, "flops": 900},
    ]  # fmt: skip
    rows = [{**r, **done} for r in rows]
    # small-net is within one SE of the best and cheapest, but the ridge scores better
    assert one_se_choice(rows) == ("poly", "net")
    rows[2]["cv_score"] = 0.34  # now small-net beats every classical baseline: it earns it
    assert one_se_choice(rows) == ("small-net", "net")
    rows[2]["eligible"] = False  # classes asked for: the ridge does not set the bar
    rows[1]["cv_score"] = 0.345
    assert one_se_choice(rows) == ("small-net", "net")


def test_given_groups_are_used_as_they_are(skin) -> None:
    units = (np.asarray(skin.session) // 2).astype(np.int64)  # 3 "units" of 2 sessions
    res = search(skin, 60.0, groups=units, space=tiny_space()[:1], workers=1, folds=5,
                 clock=SteppedClock())  # fmt: skip
    assert res.report["groups"] == {"kind": "given", "n": 3} and res.report["folds"] == 3


@pytest.mark.subprocess
def test_local_processes_give_the_same_ranking_inputs(skin) -> None:
    res = search(skin, 120.0, space=tiny_space()[:3], workers=2, folds=3, clock=SteppedClock())
    assert res.report["runner"] == "local" and res.report["workers"] == 2
    inline = search(skin, 120.0, space=tiny_space()[:2], workers=1, folds=3,
                    clock=SteppedClock())  # fmt: skip
    # closed-form trials are deterministic: the same CV error wherever they run
    for a, b in zip(res.report["candidates"][:2], inline.report["candidates"], strict=True):
        assert a["cv_score"] == pytest.approx(b["cv_score"], rel=1e-9)
