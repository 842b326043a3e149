"""Which rows a model was trained on: the convention between training and evaluation.

A model trained through `evaluate.fit_both_splits.fit_and_evaluate` (or any trainer that calls
`mark`) carries ``meta["holdout"]``::

    {"dataset": "<fingerprint of the training dataset>", "n_rows": N,
     "split": {"kind": "blocked", "seed": 0, "test_fraction": 0.2, "by": "auto", ...},
     "n_train": ..., "n_test": ..., "companions": {"random": "model.random.stac"}}

Evaluating it on the same dataset (same fingerprint) rebuilds the split deterministically and
scores the test rows only. On another dataset every row is held out. Without the record the
training rows are unknown: the evaluation uses the whole dataset and says so, which is only
honest when that dataset was not used for training (the normal case for a fresh recording).

>>> import numpy as np
>>> from spectratac.dataset import Dataset
>>> ds = Dataset.generic(np.arange(40.0)[:, None], np.zeros(40), ["a"], ["Fz"])
>>> len(fingerprint(ds))
16
>>> class M:
...     meta = {}
>>> m = M()
>>> mark(m, ds, split_dataset(ds, SplitSpec("random", seed=3)))
>>> h = resolve(m.meta, ds)
>>> h.status, h.split.n_test
('split', 8)
>>> resolve({}, ds).status
'unknown'
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass
from typing import Any

import numpy as np

from spectratac.dataset.schema import Dataset
from spectratac.evaluate.splits import Split, SplitSpec, split_dataset

KEY = "holdout"


def fingerprint(dataset: Dataset) -> str:
    """Short content hash of what defines the rows: inputs, targets, times, sessions."""
    h = hashlib.sha256()
    for key in ("inputs", "targets", "t_start", "session", "press"):
        arr = np.ascontiguousarray(dataset.arrays[key])
        h.update(key.encode())
        h.update(str(arr.shape).encode())
        h.update(arr.tobytes())
    return h.hexdigest()[:16]


def mark(
    model: Any, dataset: Dataset, split: Split, companions: dict[str, str] | None = None
) -> None:
    """Record in `model.meta` that it was trained on `split.train` of `dataset`."""
    record: dict[str, Any] = {
        "dataset": fingerprint(dataset),
        "n_rows": int(dataset.n),
        "split": split.spec.to_dict(),
        "n_train": split.n_train,
        "n_test": split.n_test,
    }
    if companions:
        record["companions"] = dict(companions)
    model.meta[KEY] = record


@dataclass(frozen=True)
class Holdout:
    """`status`: "split" (test rows of the model's split), "other" (the dataset is not the
    training one: all rows held out) or "unknown" (no record: all rows, caveat)."""

    status: str
    split: Split | None
    note: str
    companions: dict[str, str]


def resolve(meta: dict[str, Any], dataset: Dataset) -> Holdout:
    rec = meta.get(KEY)
    if not isinstance(rec, dict) or "dataset" not in rec or "split" not in rec:
        return Holdout(
            "unknown",
            None,
            "the model does not record its training rows: every row of this dataset is "
            "scored, which is only meaningful if the model never saw this dataset",
            {},
        )
    comp = dict(rec.get("companions") or {})
    if rec["dataset"] != fingerprint(dataset):
        return Holdout(
            "other",
            None,
            f"the model was trained on another dataset ({rec['dataset']}): every row of this "
            "one is held out",
            comp,
        )
    split = split_dataset(dataset, SplitSpec.from_dict(rec["split"]))
    if split.n_train != rec.get("n_train", split.n_train):
        return Holdout(
            "unknown",
            None,
            "the model's recorded split no longer reproduces (library change?): every row is "
            "scored, including training rows",
            comp,
        )
    return Holdout("split", split, split.describe(), comp)
