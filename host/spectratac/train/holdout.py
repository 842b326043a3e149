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
>>> parse_sessions("3,4,7"), parse_sessions("30-33,5")
([3, 4, 7], [5, 30, 31, 32, 33])
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from spectratac.dataset.schema import Dataset
from spectratac.errors import SpectraTacError
from spectratac.train.groups import Split, SplitSpec, split_dataset

KEY = "holdout"


class SessionSelectionError(SpectraTacError):
    """A session list that cannot be parsed, or names sessions the dataset does not have."""


class SessionLeakError(SpectraTacError):
    """Sessions asked to be scored as held out were used to train the model."""


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


def mark_all(model: Any, dataset: Dataset) -> None:
    """Record in `model.meta` that it was trained on every row of `dataset` (so that scoring
    it on that dataset is reported as training error, never as held out)."""
    model.meta[KEY] = {
        "dataset": fingerprint(dataset),
        "n_rows": int(dataset.n),
        "all": True,
        "n_train": int(dataset.n),
    }


def parse_sessions(text: str) -> list[int]:
    """Sorted unique session ids from "3,4,7" or ranges "30-35" (inclusive), or a mix."""
    out: set[int] = set()
    for part in (p.strip() for p in text.split(",")):
        if not part:
            continue
        lo, sep, hi = part.partition("-")
        try:
            a = int(lo)
            b = int(hi) if sep else a
        except ValueError:
            raise SessionSelectionError(
                f"session list {text!r}: {part!r} is neither a session id nor a range like "
                "30-35; give non-negative integers separated by commas"
            ) from None
        if a < 0 or b < a:
            raise SessionSelectionError(
                f"session list {text!r}: {part!r} is not a range low-high with 0 <= low <= high"
            )
        out.update(range(a, b + 1))
    if not out:
        raise SessionSelectionError(f"session list {text!r} names no session")
    return sorted(out)


def session_ids(dataset: Dataset) -> list[int]:
    """The session ids present in `dataset`'s rows."""
    return [int(v) for v in np.unique(np.asarray(dataset.session, dtype=np.int64))]


def session_rows(dataset: Dataset, sessions: list[int]) -> NDArray[np.int64]:
    """Row indices of `sessions`; SessionSelectionError naming any session the data lacks."""
    have = session_ids(dataset)
    missing = sorted(set(sessions) - set(have))
    if missing:
        raise SessionSelectionError(
            f"sessions {_ids(missing)} are not in this dataset; it has sessions {_ids(have)}"
        )
    return np.flatnonzero(np.isin(np.asarray(dataset.session, dtype=np.int64), sessions))


def _ids(ids: list[int]) -> str:
    """Compact "0-4, 7" form of sorted ids."""
    runs: list[list[int]] = []
    for i in ids:
        if runs and i == runs[-1][1] + 1:
            runs[-1][1] = i
        else:
            runs.append([i, i])
    return ", ".join(str(a) if a == b else f"{a}-{b}" for a, b in runs)


def mark_sessions(model: Any, dataset: Dataset, held_out: list[int]) -> None:
    """Record in `model.meta` that it was trained on every session of `dataset` but
    `held_out`."""
    trained = [s for s in session_ids(dataset) if s not in set(held_out)]
    model.meta[KEY] = {
        "dataset": fingerprint(dataset),
        "n_rows": int(dataset.n),
        "sessions": {"held_out": sorted(held_out), "trained": trained},
        "n_train": int(np.isin(np.asarray(dataset.session, np.int64), trained).sum()),
    }


def check_sessions_unseen(meta: dict[str, Any], dataset: Dataset, sessions: list[int]) -> str:
    """Refuse (SessionLeakError) when the model was trained on any row of `sessions` of
    `dataset`, per its holdout record; return a note saying how that was established."""
    rec = meta.get(KEY)
    if not isinstance(rec, dict) or "dataset" not in rec:
        return (
            "the model does not record its training rows: the chosen sessions are scored as "
            "held out, which is only meaningful if the model never saw them"
        )
    if rec["dataset"] != fingerprint(dataset):
        return (
            f"the model was trained on another dataset ({rec['dataset']}): these sessions "
            "are held out"
        )
    rows = session_rows(dataset, sessions)
    if rec.get("all") is True:
        used = sorted(set(sessions))
    elif "sessions" in rec:
        used = sorted(set(sessions) & set(rec["sessions"].get("trained", [])))
    else:
        split = split_dataset(dataset, SplitSpec.from_dict(rec["split"]))
        seen = np.asarray(dataset.session, np.int64)[np.intersect1d(split.train, rows)]
        used = sorted({int(v) for v in seen})
    if used:
        raise SessionLeakError(
            f"the model was trained on sessions {_ids(used)} of this dataset (its metadata "
            "says so): scoring them would report training error; choose sessions it held out "
            "(train with --holdout-sessions) or evaluate on another recording"
        )
    return f"sessions {_ids(sessions)} were held out of the model's training"


@dataclass(frozen=True)
class Holdout:
    """`status`: "split" (test rows of the model's split), "sessions" (the sessions the model
    left out of its training dataset: `rows`), "training" (the model was trained on every row
    of this dataset: `rows` are all of them, training error), "other" (the dataset is not
    the training one: all rows held out) or "unknown" (no record: all rows, caveat)."""

    status: str
    split: Split | None
    note: str
    companions: dict[str, str]
    rows: NDArray[np.int64] | None = None


def resolve(meta: dict[str, Any], dataset: Dataset) -> Holdout:
    rec = meta.get(KEY)
    known = (
        isinstance(rec, dict)
        and "dataset" in rec
        and ("split" in rec or "sessions" in rec or rec.get("all") is True)
    )
    if not known:
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
    if rec.get("all") is True:
        return Holdout(
            "training",
            None,
            f"not held out: the model was trained on all {rec['n_rows']} rows of this dataset, "
            "so these figures are its training error; evaluate on another recording (or train "
            "with --holdout blocked) for held-out figures",
            comp,
            np.arange(dataset.n, dtype=np.int64),
        )
    if "sessions" in rec:
        held = [int(v) for v in rec["sessions"].get("held_out", [])]
        rows = session_rows(dataset, held)
        note = f"sessions {_ids(held)} (held out of the model's training; {rows.size} rows)"
        return Holdout("sessions", None, note, comp, rows)
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
