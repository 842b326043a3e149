"""The twin verbs' estimates: the demo's follows how the demo runs (its four fits side by
side on the workers that split the CPUs, train/parallel.py, each probed with the threads it
will have); `evaluate` adds the twin's inverse only on twin data."""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np
import pytest
from spectratac import threads
from spectratac.apps.estimates import Estimate, TrainingCost
from spectratac.dataset import Dataset
from spectratac.studies import cost_model
from spectratac.train.parallel import fit_threads

#: seconds of one fit, as the stubbed probes measure them
FIT_S = {"paper": 10.0, "best": 40.0}


@pytest.fixture
def probed(monkeypatch: pytest.MonkeyPatch) -> list[Any]:
    """Probes stubbed to fixed costs; the specs the training probe was given."""
    specs: list[Any] = []

    def measure(cls: type, dataset: Any, spec: Any, batches: int = 2) -> TrainingCost:
        specs.append(spec)
        return TrainingCost(FIT_S["best" if spec.augment != "none" else "paper"], 0.0)

    class Probe:
        dataset = None

    monkeypatch.setattr(cost_model, "twin_probe", lambda *a, **k: Probe())
    monkeypatch.setattr(cost_model, "twin_build_rate", lambda probe: 1e-4)
    monkeypatch.setattr(cost_model, "oracle_rate", lambda dataset: 0.0)
    monkeypatch.setattr(TrainingCost, "measure", classmethod(measure))
    return specs


@pytest.mark.parametrize(("cpus", "train_s"), [(1, 100.0), (2, 75.0), (4, 90.0)])
def test_the_demo_estimate_is_its_fits_on_the_workers_that_run_them(
    probed: list[Any], monkeypatch: pytest.MonkeyPatch, cpus: int, train_s: float
) -> None:
    monkeypatch.delenv(threads.ENV, raising=False)
    monkeypatch.setattr(threads, "usable_cpus", lambda: cpus)
    e = cost_model.demo_estimate(600.0, 60.0, 40, 300)
    # two paper fits, then two best fits, each with the threads it has alone (cpus): one
    # after another on one CPU (100 s); two at a time on two CPUs, each on one core, 1.5x
    # slower than alone ((10 + 40) x 1.5 s); all four at once on four (40 x 4 ** 0.585 s)
    assert e.parts_s["train + evaluate"] == pytest.approx(train_s, rel=1e-3)
    assert e.parts_s["record"] == 10.0 and e.parts_s["dataset"] == pytest.approx(1.2)
    assert [s.threads for s in probed] == [0, 0]  # probed as they will run: the alone share
    assert fit_threads(cpus) == cpus


def test_makespan_hands_jobs_to_the_first_free_worker() -> None:
    assert cost_model.makespan([10.0, 10.0, 40.0, 40.0], 2) == 50.0
    assert cost_model.makespan([40.0, 10.0, 10.0, 10.0], 2) == 40.0
    assert cost_model.makespan([], 2) == 0.0


def test_the_oracle_is_added_to_evaluate_only_where_it_runs(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """`evaluate` on twin data also runs the twin's inverse: its part is probed on the
    dataset's rows; on any other data there is no oracle, no probe and no part."""
    probed: list[int] = []

    def oracle_rate(dataset: Any, rows: int) -> float:
        probed.append(rows)
        return 0.5

    monkeypatch.setattr(cost_model, "oracle_rate", oracle_rate)
    base = Estimate({"predict": 2.0}, {"predict s/row": 1e-4}, 0.1)
    real = Dataset.generic(np.zeros((50, 1)), np.ones(50), ["a"], ["Fz"])
    assert cost_model.with_oracle(base, real, 1000) is base and probed == []
    twin = dataclasses.replace(real, meta={**real.meta, "sessions": [{"source": "twin"}]})
    assert cost_model.with_oracle(base, twin, 0) is base and probed == []
    e = cost_model.with_oracle(base, twin, 1000)
    assert probed == [cost_model.PROBE_ORACLE_ROWS]
    assert e.parts_s == {"predict": 2.0, "oracle": 500.0}
    assert e.rates["oracle s/row"] == 0.5 and e.calibration_s > 0.1
