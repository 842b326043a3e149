"""What one optimiser step of the training loop costs, pinned by counting work (never by the
clock): the features, the gain augmentation's parts and the NumPy -> torch conversions are
done once per fit (or once per epoch), not once per batch."""

from __future__ import annotations

from collections import Counter
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest
import torch
from spectratac.dataset import Dataset
from spectratac.decode.feature_matrices import FeatureSet
from spectratac.decode.runtime import Runtime
from spectratac.train import TrainSpec, train
from spectratac.train.gain import GainView

pytestmark = pytest.mark.train

# the best recipe's per-batch work: context, drift baseline, symmetry copies, gain jitter
SPEC = TrainSpec.best(epochs=2, hidden=16, blocks=1, threads=1, weight_average=0.0)


def counted(monkeypatch: pytest.MonkeyPatch, calls: Counter[str]) -> None:
    """Count the calls of every function that computes features or converts arrays."""

    def spy(owner: Any, name: str) -> None:
        if not hasattr(owner, name):
            return
        inner: Callable[..., Any] = getattr(owner, name)

        def wrapper(*args: Any, **kwargs: Any) -> Any:
            calls[name] += 1
            return inner(*args, **kwargs)

        monkeypatch.setattr(owner, name, wrapper)

    spy(FeatureSet, "apply")
    spy(Runtime, "normalised")
    spy(GainView, "z")
    spy(GainView, "parts")
    for name in ("from_numpy", "as_tensor", "tensor"):
        spy(torch, name)


def work(ds: Dataset, monkeypatch: pytest.MonkeyPatch, batch_size: int) -> tuple[Counter, int]:
    calls: Counter[str] = Counter()
    with monkeypatch.context() as m:
        counted(m, calls)
        dec = train(
            ds, TrainSpec.best(**{**SPEC.to_dict(), "batch_size": batch_size}), progress=False
        )
    steps = len(dec.meta["history"]) * -(
        -(dec.meta["n_train"] + dec.meta["n_augmented"]) // batch_size
    )
    return calls, steps


def test_no_step_recomputes_features_or_converts_arrays(twin_ds: Dataset, monkeypatch) -> None:
    """The same fit in 8x more, smaller batches does exactly the same feature computations
    and NumPy -> torch conversions: none of them happens per batch (before: every batch of
    a gain-jittered fit recomputed its rows' features from NumPy and copied them to torch)."""
    few, few_steps = work(twin_ds, monkeypatch, 1024)
    many, many_steps = work(twin_ds, monkeypatch, 128)
    assert many_steps >= 4 * few_steps  # the fits really differ in their number of steps
    assert many == few, f"per-batch work: {dict(many - few)} more calls with more batches"
    assert few["apply"] > 0 and few["parts"] == 1  # the counters see the loop's work
    assert few["z"] == 0  # the loop applies the gains to the parts itself


def test_an_epoch_of_batches_is_a_permutation_of_the_rows(twin_ds: Dataset) -> None:
    """Shuffling once per epoch and slicing keeps the fit what it was: the same seed gives the
    same weights, another seed others, and the loss falls."""
    spec = TrainSpec.paper(epochs=3, hidden=16, blocks=1, threads=1, batch_size=256)
    a, b = (train(twin_ds, spec, progress=False) for _ in range(2))
    c = train(twin_ds, TrainSpec.paper(**{**spec.to_dict(), "seed": 1}), progress=False)
    for k, v in a.runtime.weights.items():
        np.testing.assert_array_equal(v, b.runtime.weights[k])
    assert any(not np.array_equal(v, c.runtime.weights[k]) for k, v in a.runtime.weights.items())
    assert a.meta["history"][-1] < a.meta["history"][0]
