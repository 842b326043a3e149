"""The demo's estimate follows how the demo runs: its four fits side by side on the workers
that split the CPUs (train/parallel.py), each probed with the threads it will have."""

from __future__ import annotations

from typing import Any

import pytest
from spectratac import threads
from spectratac.studies import cost_model
from spectratac.train.parallel import fit_threads

#: seconds of one fit, as the stubbed probes measure them
FIT_S = {"paper": 10.0, "best": 40.0}


@pytest.fixture
def probed(monkeypatch: pytest.MonkeyPatch) -> list[Any]:
    """Probes stubbed to fixed costs; the specs the training probe was given."""
    specs: list[Any] = []

    def measure(cls: type, dataset: Any, spec: Any, batches: int = 2) -> cost_model.TrainingCost:
        specs.append(spec)
        return cost_model.TrainingCost(FIT_S["best" if spec.augment != "none" else "paper"], 0.0)

    class Probe:
        dataset = None

    monkeypatch.setattr(cost_model, "twin_probe", lambda *a, **k: Probe())
    monkeypatch.setattr(cost_model, "build_rate", lambda probe: 1e-4)
    monkeypatch.setattr(cost_model, "oracle_rate", lambda dataset: 0.0)
    monkeypatch.setattr(cost_model.TrainingCost, "measure", classmethod(measure))
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
