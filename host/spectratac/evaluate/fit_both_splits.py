"""Train and evaluate under both splits: the protocol every reported number goes through.

`fit_and_evaluate(dataset, spec)` trains one decoder per split kind on that split's training
rows only, records the split in the decoder's metadata (`train.holdout.mark`), and scores
it on the split's test rows. `save_models` writes them as ``model.stac`` (blocked: the honest
one) and ``model.random.stac`` (its companion), each naming the other, so that
``spectratac evaluate model.stac data.npz`` later rebuilds both test sets without training.

With the real trainer: ``fit_and_evaluate(ds, TrainSpec.paper(epochs=5))``. Any trainer
with the same signature works, e.g. a stand-in:

>>> import numpy as np
>>> from spectratac.dataset import Dataset
>>> from spectratac.evaluate.predictions import Predictions
>>> class Zero:
...     def __init__(self):
...         self.meta = {}
...     def predict(self, dataset, rows):
...         return Predictions(["Fz"], np.zeros((len(rows), 1)))
>>> ds = Dataset.generic(np.zeros((100, 1)), np.ones(100), ["a"], ["Fz"])
>>> res = fit_and_evaluate(ds, None, trainer=lambda *a, **k: Zero())
>>> sorted(res.sections), res.sections["blocked"].decoder.scores["components"]["Fz"]["mae"]
(['blocked', 'random'], 1.0)
"""

from __future__ import annotations

import contextlib
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from spectratac.dataset.schema import Dataset
from spectratac.evaluate.run import Evaluation, Floor, Section, evaluate_model
from spectratac.train.groups import KINDS, Split, SplitSpec, split_dataset
from spectratac.train.holdout import mark
from spectratac.train.parallel import EpochTick, FitJob, FitPool

Trainer = Callable[..., Any]  # (dataset, spec, rows=..., progress=...) -> decoder


@dataclass
class FitResult:
    """Decoders and splits per kind, the evaluation, and training wall times (s)."""

    models: dict[str, Any]
    splits: dict[str, Split]
    evaluation: Evaluation
    train_seconds: dict[str, float] = field(default_factory=dict)

    @property
    def sections(self) -> dict[str, Section]:
        return self.evaluation.sections


def default_trainer() -> Trainer:
    from spectratac.train import train

    return train


def fit_and_evaluate(
    dataset: Dataset,
    spec: Any,
    kinds: Sequence[str] = KINDS,
    *,
    seed: int = 0,
    split_options: dict[str, Any] | None = None,
    trainer: Trainer | None = None,
    floor: Floor | None = None,
    progress: bool = False,
) -> FitResult:
    """Train `spec` on each split's training rows and score it on the split's test rows
    (beside `floor`, e.g. the twin oracle's: `evaluate_model`)."""
    fit = trainer or default_trainer()
    models: dict[str, Any] = {}
    splits: dict[str, Split] = {}
    seconds: dict[str, float] = {}
    for kind in kinds:
        split = split_dataset(dataset, SplitSpec(kind, seed=seed, **(split_options or {})))
        t0 = time.perf_counter()
        model = fit(dataset, spec, rows=split.train, progress=progress)
        seconds[kind] = time.perf_counter() - t0
        mark(model, dataset, split)
        models[kind], splits[kind] = model, split
    ev = _evaluate(dataset, models, kinds, floor, seed)
    return FitResult(models, splits, ev, seconds)


def _evaluate(
    dataset: Dataset,
    models: Mapping[str, Any],
    kinds: Sequence[str],
    floor: Floor | None,
    seed: int,
) -> Evaluation:
    """Score the first kind's model with the others as its companions."""
    first, *rest = kinds
    return evaluate_model(
        models[first],
        dataset,
        splits=kinds,
        companions={k: models[k] for k in rest},
        floor=floor,
        seed=seed,
    )


def fit_and_evaluate_each(
    dataset: Dataset,
    specs: Mapping[str, Any],
    kinds: Sequence[str] = KINDS,
    *,
    seed: int = 0,
    floors: Mapping[str, Floor | None] | None = None,
    pool: FitPool | None = None,
    tick: EpochTick | None = None,
) -> Iterator[tuple[str, FitResult]]:
    """`fit_and_evaluate` for every spec of `specs`, all fits at once in worker processes
    (train/parallel.py: every fit with the same torch threads however many run at once, so
    the models do not depend on the spread). Yields (name, result) in the order of `specs`,
    each as soon as its fits are done, while later fits go on; `floors[name]` is its floor.
    `pool`: a started FitPool to use (the caller closes it), else one made here.
    `tick(job, epochs done)` hears of every fit's epochs (job = spec index x kinds + kind)."""
    splits = {k: split_dataset(dataset, SplitSpec(k, seed=seed)) for k in kinds}
    with contextlib.ExitStack() as stack:
        if pool is None:
            pool = stack.enter_context(FitPool(len(specs) * len(kinds)))
        index = {
            (name, k): pool.submit(dataset, FitJob(spec, splits[k].train))
            for name, spec in specs.items()
            for k in kinds
        }
        for name in specs:
            fitted = {k: pool.result(index[name, k], tick) for k in kinds}
            models = {k: f.decoder for k, f in fitted.items()}
            for k in kinds:
                mark(models[k], dataset, splits[k])
            ev = _evaluate(dataset, models, kinds, (floors or {}).get(name), seed)
            seconds = {k: f.seconds for k, f in fitted.items()}
            yield name, FitResult(models, dict(splits), ev, seconds)


def save_models(result: FitResult, path: str | Path) -> dict[str, Path]:
    """Write the blocked model to `path` and each other kind to ``<stem>.<kind><suffix>``,
    each recording the others as companions (file names relative to its folder)."""
    path = Path(path)
    main = "blocked" if "blocked" in result.models else next(iter(result.models))
    files = {
        k: path if k == main else path.with_name(f"{path.stem}.{k}{path.suffix or '.stac'}")
        for k in result.models
    }
    for kind, model in result.models.items():
        model.meta["holdout"]["companions"] = {k: f.name for k, f in files.items() if k != kind}
        model.save(files[kind])
    return files


def load_companions(model: Any, model_path: str | Path, loader: Callable[[Path], Any]) -> dict:
    """The companion models a model file names, loaded from its folder (missing ones skipped)."""
    rec = (getattr(model, "meta", {}) or {}).get("holdout") or {}
    folder = Path(model_path).parent
    out: dict[str, Any] = {}
    for kind, name in (rec.get("companions") or {}).items():
        f = folder / name
        if f.exists():
            out[kind] = loader(f)
    return out
