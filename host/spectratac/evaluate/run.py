"""Evaluate a trained model on a dataset: which rows are honest to score, on which split,
beside an optional floor column (`Floor`: the twin oracle's, from spectratac.studies) and an
optional baseline model.

A model's `meta["holdout"]` (see `train.holdout`) names the split it was trained under;
only that split's test rows are scored with it. The other split is scored with a companion
model trained under that split (`fit_and_evaluate` writes both), or reported as unavailable.
A model without the record, or one trained on another dataset, is scored on every row; one
trained on every row of this dataset is scored on every row as section "training", whose
title and note say it is training error.
A model trained with sessions left out is scored on those sessions; `sessions=[...]` scores
the named sessions only, refusing (SessionLeakError) sessions the model was trained on. Every
scored section also reports its MAE per session (`Section.per_session`).

>>> import numpy as np
>>> from spectratac.dataset import Dataset
>>> from spectratac.evaluate.predictions import Predictions
>>> class Mean:  # a toy decoder: predicts 1.0 N everywhere
...     meta = {}
...     def predict(self, dataset, rows):
...         return Predictions(["Fz"], np.ones((len(rows), 1)))
>>> ds = Dataset.generic(np.zeros((10, 1)), np.arange(10.0), ["a"], ["Fz"])
>>> ev = evaluate_model(Mean(), ds)
>>> list(ev.sections), ev.sections["all"].decoder.scores["components"]["Fz"]["mae"]
(['all'], 3.7)
>>> ev.sections["all"].per_session
{'0': {'n': 10, 'unit': None, 'mae': {'Fz': 3.7}}}
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from spectratac.dataset.schema import Dataset
from spectratac.evaluate.metrics import regression_scores
from spectratac.evaluate.predictions import Predictions, predict
from spectratac.evaluate.scoring import Scored, score
from spectratac.train.groups import KINDS
from spectratac.train.holdout import check_sessions_unseen, resolve, session_rows

Progress = Callable[[str], None]
#: A floor column beside the decoder: (dataset, test rows, seed) -> (the rows it decoded, their
#: predictions or None, a note for the report). The twin oracle's is
#: `spectratac.studies.oracle_floor.OracleFloor`; this part never imports the twin.
Floor = Callable[
    [Dataset, NDArray[np.int64], int], tuple[NDArray[np.int64], Predictions | None, str]
]


@dataclass
class Section:
    """One evaluated set of rows: a split's test rows, or the whole dataset."""

    name: str  # "random", "blocked" or "all"
    note: str
    rows: NDArray[np.int64] = field(default_factory=lambda: np.zeros(0, np.int64))
    decoder: Scored | None = None
    oracle: Scored | None = None
    oracle_note: str = ""
    baseline: Scored | None = None
    baseline_note: str = ""
    history: list[float] = field(default_factory=list)
    model_info: dict[str, Any] = field(default_factory=dict)
    per_session: dict[str, dict[str, Any]] = field(default_factory=dict)

    @property
    def available(self) -> bool:
        return self.decoder is not None


@dataclass
class Evaluation:
    sections: dict[str, Section]
    notes: list[str]


def model_info(model: Any) -> dict[str, Any]:
    """What the report says about a model (JSON-ready, whatever the decoder API)."""
    meta = getattr(model, "meta", {}) or {}
    info: dict[str, Any] = {}
    keys = ("spec", "unit_id", "train_seconds", "recipe", "config", "n_train", "finetuned_from")
    for key in keys:
        if key in meta:
            info[key] = _jsonable(meta[key])
    for attr in ("n_params", "flops_per_sample"):
        v = getattr(model, attr, None)
        if v is not None:
            info[attr] = int(v)
    return info


def _jsonable(v: Any) -> Any:
    if isinstance(v, dict):
        return {str(k): _jsonable(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_jsonable(x) for x in v]
    if isinstance(v, (str, int, float, bool)) or v is None:
        return v
    if isinstance(v, np.generic):
        return v.item()
    if hasattr(v, "__dataclass_fields__"):
        return _jsonable(v.__dict__)
    return str(v)


def _history(model: Any) -> list[float]:
    h = getattr(model, "history", None)
    if h is None:
        h = (getattr(model, "meta", {}) or {}).get("history")
    try:
        return [float(x) for x in (h or [])]
    except (TypeError, ValueError):
        return []


def evaluate_model(
    model: Any,
    dataset: Dataset,
    *,
    splits: Sequence[str] = KINDS,
    sessions: Sequence[int] | None = None,
    companions: dict[str, Any] | None = None,
    baseline: Any | None = None,
    floor: Floor | None = None,
    seed: int = 0,
    progress: Progress | None = None,
) -> Evaluation:
    """Score `model` (and `baseline`, and the `floor` column) on the honest rows of `dataset`,
    or on `sessions` of it (SessionLeakError if the model was trained on any of them).
    `seed` picks the floor's subsample."""
    tick = progress or (lambda stage: None)
    meta = getattr(model, "meta", {}) or {}
    h = resolve(meta, dataset)
    if sessions is not None:
        note = check_sessions_unseen(meta, dataset, list(sessions))
        rows = session_rows(dataset, list(sessions))
        h = type(h)("sessions", None, note, h.companions, rows)
    notes = [h.note]
    m_unit = (getattr(model, "meta", {}) or {}).get("unit_id")
    d_unit = dataset.meta.get("unit_id")
    if m_unit and d_unit and m_unit != d_unit:
        notes.append(f"the model was trained on unit {m_unit!r}; this data comes from {d_unit!r}")
    plan: list[tuple[str, Any, NDArray[np.int64], str]] = []
    if h.rows is not None:
        plan.append(("training" if h.status == "training" else "sessions", model, h.rows, h.note))
    elif h.split is None:
        plan.append(("all", model, np.arange(dataset.n), h.note))
    else:
        pool = {h.split.kind: (model, h.split)}
        for m in (companions or {}).values():
            hm = resolve(getattr(m, "meta", {}) or {}, dataset)
            if hm.split is not None:
                pool.setdefault(hm.split.kind, (m, hm.split))
        for kind in splits:
            if kind in pool:
                m, sp = pool[kind]
                plan.append((kind, m, sp.test, sp.describe()))
            else:
                plan.append((kind, None, np.zeros(0, np.int64), _missing(kind, h.split.kind)))
    sections: dict[str, Section] = {}
    for name, m, rows, note in plan:
        sec = Section(name, note, rows)
        sections[name] = sec
        if m is None:
            continue
        sec.decoder = score(dataset, rows, predict(m, dataset, rows))
        sec.per_session = per_session(dataset, sec.decoder)
        tick(f"{name}: decoder")
        sec.history = _history(m)
        sec.model_info = model_info(m)
        if baseline is not None:
            sec.baseline, sec.baseline_note = _score_baseline(baseline, dataset, rows)
            tick(f"{name}: baseline")
        if floor is not None:
            o_rows, o_pred, sec.oracle_note = floor(dataset, rows, seed)
            if o_pred is not None:
                sec.oracle = score(dataset, o_rows, o_pred)
            tick(f"{name}: oracle")
    return Evaluation(sections, notes)


def with_model_classes(dataset: Dataset, model: Any) -> tuple[Dataset, str]:
    """`dataset` with its class ids renumbered to the model's labels (a generic file numbers
    its labels 1..K in its own sorted order, which differs from the training file's when the
    label sets differ); labels the model never saw become unlabelled (-1), said in the note.

    >>> ds = Dataset.generic(np.zeros((3, 1)), np.zeros(3), ["a"], ["Fz"],
    ...                      region=np.array([1, 2, -1]))
    >>> ds.meta["region_labels"] = ["right", "up"]
    >>> class M:
    ...     meta = {"class_labels": ["left", "right"]}
    >>> out, note = with_model_classes(ds, M())
    >>> out.region.tolist(), note
    ([2, -1, -1], "class labels ['up'] are not the model's (left, right): scored as unlabelled")
    """
    model_labels = (getattr(model, "meta", {}) or {}).get("class_labels")
    labels = dataset.meta.get("region_labels")
    if not model_labels or not labels or list(labels) == list(model_labels):
        return dataset, ""
    to_model = {i + 1: list(model_labels).index(v) + 1 for i, v in enumerate(labels)
                if v in model_labels}  # fmt: skip
    region = np.asarray(dataset.region, np.int64)
    new = np.array([to_model.get(int(r), -1) for r in region], dtype=region.dtype)
    arrays = {**dataset.arrays, "region": new}
    meta = {**dataset.meta, "region_labels": list(model_labels)}
    unknown = [v for v in labels if v not in model_labels]
    note = (
        f"class labels {unknown} are not the model's ({', '.join(model_labels)}): scored as "
        "unlabelled"
        if unknown
        else ""
    )
    return Dataset(arrays, meta), note


def per_session(dataset: Dataset, scored: Scored) -> dict[str, dict[str, Any]]:
    """Rows, unit (from meta["sessions"]) and MAE per component of each session in `scored`."""
    sess = np.asarray(dataset.session, dtype=np.int64)[scored.rows]
    info = dataset.meta.get("sessions") or []
    valid = np.asarray(dataset.target_valid, bool)[scored.rows]
    out: dict[str, dict[str, Any]] = {}
    for s in np.unique(sess):
        mask = sess == s
        comp = regression_scores(
            scored.y_true[mask], scored.y_pred[mask], scored.names, valid[mask]
        )
        unit = info[s].get("unit") if 0 <= s < len(info) and isinstance(info[s], dict) else None
        out[str(int(s))] = {
            "n": int(mask.sum()),
            "unit": unit,
            "mae": {k: float(v["mae"]) for k, v in comp.items()},
        }
    return out


def _missing(kind: str, have: str) -> str:
    return (
        f"not evaluated: the model was trained on the {have} split's training rows, so the "
        f"{kind} split's test rows include rows it was trained on; train a companion under the "
        f"{kind} split (evaluate.fit_both_splits.fit_and_evaluate writes both) and pass it"
    )


def _score_baseline(
    baseline: Any, dataset: Dataset, rows: NDArray[np.int64]
) -> tuple[Scored | None, str]:
    hb = resolve(getattr(baseline, "meta", {}) or {}, dataset)
    if hb.split is not None:
        overlap = np.intersect1d(hb.split.train, rows).size
        if overlap:
            return None, (
                f"baseline not comparable here: it was trained on {overlap} of these test rows "
                f"({hb.split.describe()})"
            )
    note = "baseline scored on the same rows" + (
        f" (caveat: {hb.note})" if hb.status == "unknown" else ""
    )
    return score(dataset, rows, predict(baseline, dataset, rows)), note
