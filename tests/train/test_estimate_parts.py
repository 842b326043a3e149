"""What `train`'s time estimate counts is the work `train` then does (issue 35 item 4): the
prediction passes of the check and the summary (each assembles the whole dataset: with the
drift baseline most of a small fit's time, which the estimate left out), and for
`--recipe auto` the trials its search launches within the budget, beside the fixed cost
of each fit and pass. Asserted on counts of the real work, never on the clock."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from spectratac.apps import estimates
from spectratac.decode import Decoder
from spectratac.sim.ageing_skin import ageing_skin
from spectratac.train import TrainSpec, fit
from spectratac.train.auto_recipe.search import planned_work, search
from spectratac.train.check import check_predictions

pytestmark = pytest.mark.train


def small() -> Any:
    return ageing_skin(12, 2.0, 0)


def test_the_estimate_counts_every_prediction_pass_the_check_and_summary_make(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    ds = small()
    passes: list[int] = []
    real = Decoder.predict

    def counted(self: Decoder, dataset: Any, rows: Any = None) -> Any:
        passes.append(dataset.n if rows is None else int(np.asarray(rows).size))
        return real(self, dataset, rows)

    monkeypatch.setattr(Decoder, "predict", counted)
    fit(ds, TrainSpec.paper(features="generic", targets=("Fz",), epochs=1), progress=False)
    assert sorted(check_predictions(ds, None)) == sorted(passes)


def test_the_training_estimate_has_a_part_for_the_prediction_passes(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """A pass costs 0.2 s plus 1 ms a row (a fake PredictCost): the estimate's scoring part
    is exactly that over the passes it is given, probed with the recipe's own spec."""
    ds = small()
    spec = TrainSpec.best(augment="none", features="generic", targets=("Fz",), epochs=1)
    seen: list[Any] = []

    def fake(cls: type, dataset: Any, s: Any, **_: Any) -> estimates.PredictCost:
        seen.append(s)
        return estimates.PredictCost(0.2, 1e-3)

    monkeypatch.setattr(estimates.PredictCost, "measure", classmethod(fake))
    free = classmethod(lambda cls, d, s: estimates.TrainingCost(0.0, 0.0))
    monkeypatch.setattr(estimates.TrainingCost, "measure", free)
    e = estimates.training_estimate(ds, spec, predictions=[100, 300])
    assert e.parts_s["scoring (check and summary)"] == pytest.approx(0.4 + 0.4)
    assert seen == [spec]  # the recipe's own architecture, context and drift baseline


def test_auto_plans_the_trials_its_search_launches() -> None:
    ds = small()
    plan = planned_work(ds, 3.0, workers=1)
    report = search(ds, 3.0, workers=1, targets=("Fz",)).report
    launched = [c["name"] for c in report["candidates"] if c.get("status") == "done"]
    assert sorted(plan["trials"]) == sorted(launched)
    assert plan["work_s"] == pytest.approx(report["work_s"], rel=0.35)


def test_auto_estimate_is_the_planned_work_at_the_rate_plus_counted_fixed_parts(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The budget is no longer the estimate: the work the search plans, each family's at
    its own probed rate (nominal ridge work bought a fortieth of its seconds on the ageing
    skin, and the estimate was 2x the wall), plus each fit's and pass's fixed cost shared
    among the workers, plus the workers' start."""
    ds = small()
    fixed = estimates.FixedCosts(0.05, 0.01, 0.3)
    factors = {"network": 2.0, "classical": 0.1}
    monkeypatch.setattr(estimates, "machine_factors", lambda d, w=None: (factors, fixed))
    monkeypatch.setattr(estimates, "worker_start_s", lambda: 3.0)
    plan = planned_work(ds, 4.0, workers=2)
    e = estimates.auto_estimate(4.0, ds, workers=2)
    drift = (plan["fits_drift"] + plan["passes_drift"]) * 0.3
    by = plan["work_by_family"]
    assert by["network"] + by["classical"] == pytest.approx(plan["work_s"])
    assert min(by.values()) > 0  # both families are launched: each at its own rate
    want = 2.0 * by["network"] + 0.1 * by["classical"]
    want += (plan["fits"] * 0.05 + plan["passes"] * 0.01 + drift) / 2
    assert e.total_s == pytest.approx(want + 3.0)
    assert plan["fits_drift"] > 0  # the drift and context candidates' assembly is counted
    assert plan["work_s"] < 4.0  # the budget is not all spent: trials that do not fit skip


def test_the_estimate_probes_the_recipe_the_checks_models_train_with(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """`spectratac train` prices the check's models with `check_recipe_for_options`: it is
    the recipe `fit` then trains every check model with (a smaller batch than the real
    model's, which costs more per row)."""
    import spectratac.train.trained as trained_mod
    from spectratac.train.check import check_recipe_for_options

    ds = ageing_skin(12, 4.0, 0)
    spec = TrainSpec.paper(features="generic", targets=("Fz",), epochs=1)
    specs: list[TrainSpec] = []
    real = trained_mod.train

    def recorded(dataset: Any, s: TrainSpec, **kw: Any) -> Decoder:
        specs.append(s)
        return real(dataset, s, **kw)

    monkeypatch.setattr(trained_mod, "train", recorded)
    fit(ds, spec, progress=False)
    final, *checks = specs
    assert final == spec and checks
    want = check_recipe_for_options(ds, spec, None, None)
    assert want.batch_size < spec.batch_size
    assert all(c == want for c in checks)


def test_ridges_rate_is_probed_on_the_users_rows(monkeypatch: pytest.MonkeyPatch) -> None:
    """A ridge fit costs what its rows cost on this dataset: the probe fits the dataset's
    first rows and half of them, and the difference over their nominal work is the rate
    (here a fake trainer whose fits cost 0.5 s plus 1 us per row: the fixed part drops out)."""
    from spectratac.train.auto_recipe.budget import NOMINAL_S_PER_WORK, work

    ds = small()
    now = [0.0]
    monkeypatch.setattr(estimates.time, "perf_counter", lambda: now[0])
    seen: list[Any] = []

    def fake_train(dataset: Any, spec: Any, rows: Any, progress: bool = False) -> None:
        seen.append(spec.model)
        now[0] += 0.5 + 1e-6 * len(rows)

    import spectratac.train as train_pkg

    monkeypatch.setattr(train_pkg, "train", fake_train)
    like = TrainSpec(features="generic", targets=("Fz",))
    f = estimates.ridge_factor(ds, like, fallback=7.0)
    rows = min(estimates.PROBE_ROWS, ds.n)
    nf = estimates_n_features(ds, like)
    units = work("classical", rows, nf, 1, 0) - work("classical", rows // 2, nf, 1, 0)
    want = 1e-6 * (rows - rows // 2) / (units * NOMINAL_S_PER_WORK["classical"])
    assert set(seen) == {"ridge"} and f == pytest.approx(max(want, 0.005), rel=1e-6)


def estimates_n_features(ds: Any, like: TrainSpec) -> int:
    import dataclasses

    from spectratac.train.plan import plan

    return plan(ds, dataclasses.replace(like, model="ridge", degree=2)).features.n_features


def test_the_ridge_probe_leaves_the_region_out_on_spectratacs_own_data() -> None:
    """A SpectraTac dataset's targets hold the contact region, which ridge does not decode:
    the probe fits the forces (`train --recipe auto` failed with exit 3 before any search)."""
    from spectratac.sim.twin_dataset import from_twin_session
    from spectratac.twin import builtin_scenes as scenes
    from spectratac.twin import generate_session

    sc = scenes.calibration_session(seed=7, duration_s=60.0)
    ds = from_twin_session(generate_session(sc, seed=7), sc)
    like = TrainSpec(targets=("Fz", "region"))
    assert estimates.ridge_factor(ds, like, fallback=-1.0) > 0
