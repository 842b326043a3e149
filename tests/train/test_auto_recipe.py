"""`search` (--recipe auto): grouped CV, the work budget (independent of the clock), cost
order, the paired one-SE rule, the refit, runners."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from spectratac.decode import Decoder
from spectratac.sim.generic_skin import generic_skin
from spectratac.train import TrainSpec
from spectratac.train.auto_recipe import Candidate, one_se_choice, search
from spectratac.train.auto_recipe.budget import WorkBudget
from spectratac.train.auto_recipe.search import refit_units, trial_units

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
    assert loaded.meta["auto_recipe"]["candidates"][0]["name"] == "mlp8"  # cheapest first
    assert "<- chosen" in res.text() and "mlp8" in res.text()


def test_nothing_is_launched_past_the_work_budget_but_linear_baselines_always_run(skin) -> None:
    # a budget of 1e-6 nominal seconds: only the linear baseline (which always runs) fits
    res = search(skin, 1e-6, space=tiny_space(), workers=1, folds=3, clock=SteppedClock())
    status = {c["name"]: c["status"] for c in res.report["candidates"]}
    assert status["linear"] == "done"  # the linear baselines always run
    for name in ("poly2+drift", "mlp8", "mlp8+drift"):
        assert status[name] == "skipped: would not fit the budget"
    assert res.report["chosen"] == "linear"
    assert not res.report["within_budget"]


class SlowClock:
    """A clock on a far busier machine: every reading is 10^6 s after the last."""

    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        self.now += 1e6
        return self.now


def test_the_choice_depends_on_data_and_seed_not_on_the_clock(skin) -> None:
    """The issue: under load the wall-clock budget skipped every network; in units of work
    the same data gives the same trials and the same choice on a machine that is far slower."""
    for budget in (1e-3, 60.0):  # networks, not the quadratic ridge; every trial
        quiet = search(skin, budget, space=tiny_space(), workers=1, folds=3, clock=SteppedClock())
        busy = search(skin, budget, space=tiny_space(), workers=1, folds=3, clock=SlowClock())
        assert busy.report["elapsed_s"] > 1000 * budget  # the wall time ran far over
        status = [(c["name"], c["status"]) for c in quiet.report["candidates"]]
        assert status == [(c["name"], c["status"]) for c in busy.report["candidates"]]
        assert quiet.report["chosen"] == busy.report["chosen"]
        assert busy.report["within_budget"] == quiet.report["within_budget"]
        for a, b in zip(quiet.report["candidates"], busy.report["candidates"], strict=True):
            assert a.get("cv_score") == b.get("cv_score")  # same folds, same seeds
    assert {c["status"] for c in busy.report["candidates"]} == {"done"}  # 60 s: every trial


def test_trials_run_cheapest_first_and_the_refit_counts(skin) -> None:
    space = list(reversed(tiny_space()))  # given costliest first
    order: list[str] = []
    res = search(skin, 60.0, space=space, workers=1, folds=3, clock=SteppedClock(),
                 progress=lambda line: order.append(line.split(":")[0]))  # fmt: skip
    work = {c["name"]: c["work_s"] for c in res.report["candidates"]}
    assert order == sorted(work, key=lambda n: work[n])  # launched in order of predicted cost
    assert [c["name"] for c in res.report["candidates"]] == order
    # a budget that holds every trial but not the refit of the costliest: it is skipped
    costliest = max(work, key=lambda n: work[n])
    total = sum(work.values())
    res2 = search(skin, total + 1e-9, space=space, workers=1, folds=3, clock=SteppedClock())
    st = {c["name"]: c["status"] for c in res2.report["candidates"]}
    assert st[costliest] == "skipped: would not fit the budget"


def test_work_budget_counts_the_refit() -> None:
    b = WorkBudget(60.0, workers=2)  # 120 nominal core-seconds
    assert b.fits(trial_s=100.0, refit_s=20.0)
    assert not b.fits(trial_s=100.0, refit_s=20.5)  # the refit counts
    b.spend(100.0)
    assert b.fits(10.0, 10.0) and not b.fits(10.0, 10.5)  # spent trials count


def test_winner_is_refitted_on_all_rows_with_the_fold_sample_count(skin) -> None:
    res = search(skin, 60.0, space=tiny_space()[2:3], workers=1, folds=3, clock=SteppedClock(),
                 max_fit_rows=500)  # fmt: skip
    rep = res.report
    assert rep["fit_rows"] == 500 and rep["rows"] > 1500
    assert res.decoder.meta["n_train"] >= 0.9 * rep["rows"]  # every row, not the subsample
    curve = rep["candidates"][0]["learning_curve"]
    (half, _), (full, _) = curve
    assert full <= 500 and half == -(-full // 2) and all(s > 0 for _, s in curve)
    net = tiny_space()[2]
    assert refit_units(skin, net, 500, rep["rows"]) == pytest.approx(trial_units(
        skin, net, 500, 3) / 3.5)  # fmt: skip


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
    local = {c["name"]: c for c in res.report["candidates"]}
    for b in inline.report["candidates"]:
        assert local[b["name"]]["cv_score"] == pytest.approx(b["cv_score"], rel=1e-9)


def test_one_se_rule_keeps_the_best_when_it_wins_on_every_fold() -> None:
    """The issue: over 4 folds the unpaired rule discarded the context models that were
    best. Folds differ in difficulty for every candidate alike; the paired error is of the
    per-fold differences, so a model better on every fold is kept."""
    done = {"status": "done", "eligible": True}
    hard = np.array([0.10, 0.30, 0.15, 0.40])  # the folds' difficulty, common to both
    ctx, plain = hard - 0.02, hard.copy()

    def row(name: str, family: str, s: np.ndarray, fl: float) -> dict:
        se = float(s.std(ddof=1) / 2)
        return {"name": name, "family": family, "cv_score": float(s.mean()), "cv_se": se,
                "fold_score": s.tolist(), "flops": fl, **done}  # fmt: skip

    rows = [row("context", "network", ctx, 9e4), row("mlp", "network", plain, 1e4)]
    assert rows[1]["cv_score"] - rows[0]["cv_score"] < rows[0]["cv_se"]  # unpaired: "noise"
    assert one_se_choice(rows) == ("context", "context")
    noisy = plain + np.array([-0.05, 0.04, -0.03, 0.06]) - 0.02  # no better on some folds
    rows[1] = row("mlp", "network", noisy, 1e4)
    assert one_se_choice(rows)[0] == "mlp"


def test_the_linear_baselines_cost_is_set_aside_before_cheaper_trials(skin) -> None:
    """On 250k rows the always-run linear baselines came after the cheaper networks in cost
    order and took the search over its budget: their cost is reserved first."""
    full = search(skin, 60.0, space=tiny_space(), workers=1, folds=3, clock=SteppedClock())
    work = {c["name"]: c["work_s"] for c in full.report["candidates"]}
    nets = work["mlp8"] + work["mlp8+drift"]
    assert nets < work["linear"]  # the networks come first in cost order
    res = search(skin, work["linear"] + nets / 4, space=tiny_space(), workers=1, folds=3,
                 clock=SteppedClock())  # fmt: skip
    status = {c["name"]: c["status"] for c in res.report["candidates"]}
    assert status["linear"] == "done"
    assert status["mlp8+drift"] == "skipped: would not fit the budget"
