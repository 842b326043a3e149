"""The demo's estimate follows how the demo runs: its four fits side by side on the workers
that split the CPUs (train/parallel.py), each probed with the threads it will have."""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np
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


def test_a_stall_in_one_training_probe_does_not_become_the_estimate(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Fault injection on a fake clock: every probe fit costs 10 ms + 10 us per row, and the
    scheduler stalls one of them for 0.3 s (a busy machine). The per-row rate is multiplied
    by rows x epochs (~400k in the demo), so the stalled probe alone made a 3-minute demo
    an estimate of over an hour; the median of the repeats leaves the stall out."""
    import spectratac.train as train_pkg
    from spectratac.dataset import Dataset

    @dataclasses.dataclass(frozen=True)
    class Spec:  # the fields the probe sets; the fake trainer below reads none of them
        epochs: int = 30
        val_fraction: float = 0.1
        best_val: bool = True
        uncertainty: bool = True
        batch_size: int = 256

    now = [0.0]
    stalled = [False]

    def fake_train(dataset: Any, spec: Any, rows: Any, progress: bool = False) -> None:
        stall = len(rows) > 64 and not stalled[0]  # the first probe of many rows
        stalled[0] |= stall
        now[0] += 0.01 + 1e-5 * len(rows) + (0.3 if stall else 0.0)

    monkeypatch.setattr(train_pkg, "train", fake_train)
    monkeypatch.setattr(cost_model.time, "perf_counter", lambda: now[0])
    ds = Dataset.generic(np.zeros((5000, 1)), np.ones(5000), ["a"], ["Fz"])
    cost = cost_model.TrainingCost.measure(ds, Spec())
    assert cost.row_epoch_s == pytest.approx(1e-5, rel=1e-6)
    assert cost.fixed_s == pytest.approx(0.01 + 64e-5, rel=1e-6)
    # the demo's best fit: 9,600 rows x 40 epochs
    assert cost.seconds(9600, 40) == pytest.approx(0.01064 + 3.84, rel=1e-3)
