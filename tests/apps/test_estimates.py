"""The product verbs' time estimates probe the user's own data: `dataset build` builds the
first chunks of the very recording it is given, `train` fits the dataset's first rows,
`evaluate` runs the model on the dataset. Timed on a fake clock: each fake piece of work
advances it by a known cost, so the estimates' arithmetic is checked exactly."""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from spectratac.apps import estimates
from spectratac.dataset import Dataset, DatasetError

#: what the fake build costs: a fixed part per recording plus a part per byte
FIXED_S, BYTE_S = 0.01, 1e-7


@dataclasses.dataclass(frozen=True)
class ProbeSpec:
    """The recipe fields the training probe sets or reads; the fake trainers read the rest."""

    epochs: int = 30
    val_fraction: float = 0.0
    best_val: bool = False
    uncertainty: bool = False
    batch_size: int = 256


@pytest.fixture
def clock(monkeypatch: pytest.MonkeyPatch) -> list[float]:
    """A fake perf_counter the probes read; the fakes below advance it."""
    now = [0.0]
    monkeypatch.setattr(estimates.time, "perf_counter", lambda: now[0])
    return now


@pytest.fixture
def builds(monkeypatch: pytest.MonkeyPatch, clock: list[float]) -> list[bytes]:
    """`build_datasets` replaced by a fake on the fake clock; the bytes of every file it built.
    Prefixes shorter than 300 kB hold too little to build, as a recording's first seconds
    may (no clock fit yet)."""
    import spectratac.dataset.build as build

    seen: list[bytes] = []

    def fake_build(paths: list[Path], options: Any = None) -> list[Any]:
        (path,) = paths
        data = Path(path).read_bytes()
        seen.append(data)
        if len(data) < 300_000:
            raise DatasetError("no rows")
        clock[0] += FIXED_S + BYTE_S * len(data)
        return []

    monkeypatch.setattr(build, "build_datasets", fake_build)
    return seen


def test_dataset_build_is_estimated_from_the_head_of_the_users_largest_recording(
    tmp_path: Path, builds: list[bytes], monkeypatch: pytest.MonkeyPatch
) -> None:
    from spectratac.studies import cost_model

    def no_twin(*args: Any, **kwargs: Any) -> None:
        raise AssertionError("a twin session was simulated to estimate a user's build")

    monkeypatch.setattr(cost_model, "twin_probe", no_twin)
    rng = np.random.default_rng(0)
    small, large = tmp_path / "a.mcap", tmp_path / "b.mcap"
    small.write_bytes(rng.bytes(3_000_000))
    large.write_bytes(rng.bytes(5_000_000))
    e = estimates.build_estimate([small, large])
    # the first MiB of the largest file and its first half, each built three times
    probe = estimates.BUILD_PROBE_BYTES
    head = large.read_bytes()[:probe]
    assert builds == [head[: probe // 2]] * 3 + [head] * 3
    assert e.parts_s["build"] == pytest.approx(2 * FIXED_S + BYTE_S * 8_000_000, rel=1e-6)
    assert e.rates["s/MB"] == pytest.approx(BYTE_S * 1e6, rel=1e-6)
    assert e.rates["fixed s"] == pytest.approx(FIXED_S, rel=1e-6)


def test_a_probe_too_short_to_build_is_retried_on_four_times_the_bytes(
    tmp_path: Path, builds: list[bytes], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(estimates, "BUILD_PROBE_BYTES", 200_000)
    path = tmp_path / "s.mcap"
    path.write_bytes(np.random.default_rng(1).bytes(2_000_000))
    e = estimates.build_estimate([path])
    assert [len(b) for b in builds] == [100_000] + [400_000] * 3 + [800_000] * 3
    assert e.parts_s["build"] == pytest.approx(FIXED_S + BYTE_S * 2_000_000, rel=1e-6)
    monkeypatch.setattr(estimates, "BUILD_PROBE_BYTES", 50_000)  # 200 kB: still too short
    with pytest.raises(DatasetError):
        estimates.build_estimate([path])


def test_evaluate_is_estimated_from_the_users_model_on_the_users_rows(
    clock: list[float],
) -> None:
    calls: list[int] = []

    class Model:
        def predict(self, dataset: Dataset, rows: np.ndarray) -> None:
            calls.append(rows.size)
            clock[0] += 1e-4 * rows.size

    ds = Dataset.generic(np.zeros((5000, 1)), np.ones(5000), ["a"], ["Fz"])
    e = estimates.evaluation_estimate(Model(), ds, models=4)
    assert calls == [2000]  # the dataset's first rows
    assert e.parts_s == {"predict": pytest.approx(4 * 1e-4 * 5000, rel=1e-6)}
    assert e.calibration_s == pytest.approx(0.2, rel=1e-6)


def test_a_stall_in_one_training_probe_does_not_become_the_estimate(
    monkeypatch: pytest.MonkeyPatch, clock: list[float]
) -> None:
    """Fault injection on a fake clock: every probe fit costs 10 ms + 10 us per row and
    epoch, and the scheduler stalls one of them for 0.3 s (a busy machine). The per-row rate
    is multiplied by rows x epochs (~400k in the demo), so the stalled probe alone made a
    3-minute demo an estimate of over an hour; the median of the repeats leaves the stall
    out."""
    import spectratac.train as train_pkg

    spec = ProbeSpec(val_fraction=0.1, best_val=True, uncertainty=True)  # the probe resets them
    stalled = [False]
    trained: list[Any] = []

    def fake_train(dataset: Any, spec: Any, rows: Any, progress: bool = False) -> None:
        trained.append(dataset)
        stall = len(rows) > 64 and not stalled[0]  # the first probe of many rows
        stalled[0] |= stall
        clock[0] += 0.01 + 1e-5 * len(rows) * spec.epochs + (0.3 if stall else 0.0)

    monkeypatch.setattr(train_pkg, "train", fake_train)
    ds = Dataset.generic(np.zeros((5000, 1)), np.ones(5000), ["a"], ["Fz"])
    cost = estimates.TrainingCost.measure(ds, spec)
    assert cost.row_epoch_s == pytest.approx(1e-5, rel=1e-6)
    assert cost.fixed_s == pytest.approx(0.01 + 64e-5, rel=1e-6)
    # the demo's best fit: 9,600 rows x 40 epochs
    assert cost.seconds(9600, 40) == pytest.approx(0.01064 + 3.84, rel=1e-3)
    assert all(d is ds for d in trained)  # every probe fit the user's own dataset
    e = estimates.training_estimate(ds, spec, fits=2)
    assert e.parts_s["train"] == pytest.approx(2 * (0.01064 + 1e-5 * 5000 * 30), rel=1e-3)


def test_a_fits_once_per_row_work_is_counted_once_not_once_per_epoch(
    monkeypatch: pytest.MonkeyPatch, clock: list[float]
) -> None:
    """A fit assembles its rows' inputs (temporal context, the drift baseline), solves the
    skip's least squares and builds the gain view once, then runs its epochs. A fake
    trainer on the fake clock costs 0.1 s + 100 us per row once + 20 us per row and epoch:
    a one-epoch probe read 120 us per row-epoch, which the demo's 40 epochs multiplied (a
    best fit of 9,600 rows estimated at 46 s for 8.6 s of work). The probe parts the two."""
    import spectratac.train as train_pkg

    spec = ProbeSpec(epochs=40)
    epochs_probed: list[int] = []

    def fake_train(dataset: Any, spec: Any, rows: Any, progress: bool = False) -> None:
        epochs_probed.append(spec.epochs)
        clock[0] += 0.1 + 1e-4 * len(rows) + 2e-5 * len(rows) * spec.epochs

    monkeypatch.setattr(train_pkg, "train", fake_train)
    ds = Dataset.generic(np.zeros((5000, 1)), np.ones(5000), ["a"], ["Fz"])
    cost = estimates.TrainingCost.measure(ds, spec)
    assert max(epochs_probed) < spec.epochs  # probes, not the run
    assert cost.row_epoch_s == pytest.approx(2e-5, rel=1e-6)
    assert cost.row_s == pytest.approx(1e-4, rel=1e-6)
    # the demo's best fit: 9,600 rows x 40 epochs, its inputs assembled once
    assert cost.seconds(9600, 40) == pytest.approx(0.1 + 0.96 + 7.68, rel=1e-2)


def test_the_check_models_smaller_batch_is_probed_at_its_own_rate(
    monkeypatch: pytest.MonkeyPatch, clock: list[float]
) -> None:
    """The check's models train on every third row at a third of the batch
    (`check_recipe`), so they take as many optimiser steps per epoch as the real fit on
    three times the rows. A fake trainer costs 2 ms per step plus 1 us per row and epoch:
    priced at the real fit's per-row rate, the paper recipe's check was counted at a third
    of its steps (estimate 0.59x the wall time on the ageing skin). The check's own recipe
    is probed and its rows priced at that rate."""
    import spectratac.train as train_pkg

    def cost(rows: int, spec: Any) -> float:
        return (2e-3 * -(-rows // spec.batch_size) + 1e-6 * rows) * spec.epochs

    def fake_train(dataset: Any, spec: Any, rows: Any, progress: bool = False) -> None:
        clock[0] += cost(len(rows), spec)

    monkeypatch.setattr(train_pkg, "train", fake_train)
    monkeypatch.setattr(estimates.PredictCost, "measure", classmethod(lambda c, d, s: None))
    ds = Dataset.generic(np.zeros((30_000, 1)), np.ones(30_000), ["a"], ["Fz"])
    spec, checking = ProbeSpec(batch_size=1024), ProbeSpec(batch_size=341)
    check_rows = [8_000, 4_000, 6_000]
    e = estimates.training_estimate(ds, spec, check_rows=check_rows, check_spec=checking)
    wall = sum(cost(r, checking) for r in check_rows)
    assert e.parts_s["held-out and forward check"] == pytest.approx(wall, rel=0.1)
    assert e.parts_s["train"] == pytest.approx(cost(ds.n, spec), rel=0.1)
    alike = estimates.training_estimate(ds, spec, check_rows=check_rows)  # the old pricing
    assert alike.parts_s["held-out and forward check"] < 0.5 * wall
