"""What a TrainSpec means for one dataset, and which of its rows can train.

`default_targets` / `default_features`: what a recipe decodes from a dataset unless told.

`plan` resolves the spec's targets, LED steps, features and heads against the dataset
(DecoderConfigError when it asks for what the data lacks); `check_rows` refuses unusable
training rows, naming them; `ranges` / `rows_of` record row sets compactly in a model's
metadata (which rows fitted and which validated).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from spectratac.dataset.schema import Dataset
from spectratac.decode import sensor_config
from spectratac.decode.assemble import assemble
from spectratac.decode.errors import DecoderConfigError, DecoderDataError
from spectratac.decode.feature_matrices import FeatureSet, build_features
from spectratac.decode.heads import Heads
from spectratac.decode.layout import Layout
from spectratac.decode.rest_signature import rest_signature
from spectratac.hardware.generated import vocabulary as vocab
from spectratac.train.spec import TrainSpec


@dataclass(frozen=True)
class Plan:
    """What `spec` means for this dataset."""

    spec: TrainSpec
    layout: Layout
    features: FeatureSet
    heads: Heads
    reg_cols: list[int]  # dataset target columns of the regression targets
    class_name: str | None
    class_labels: list[str] | None


def default_targets(dataset: Dataset) -> tuple[str, ...]:
    """Every target of `dataset`, and its classes when any row is labelled."""
    t = list(dataset.target_names)
    if np.any(np.asarray(dataset.region) > 0):
        t.append(dataset.meta.get("region_name", "region"))
    return tuple(t)


def default_features(dataset: Dataset) -> str:
    """The paper's 33 features for SpectraTac data, else the generic set."""
    return "paper33" if dataset.meta.get("kind") == "spectratac" else "generic"


def plan(dataset: Dataset, spec: TrainSpec) -> Plan:
    """Resolve targets, LED steps and features against `dataset`; DecoderConfigError if the
    spec asks for something the dataset lacks."""
    names = list(dataset.target_names)
    class_name = dataset.meta.get("region_name", "region")
    labels = dataset.meta.get("region_labels")
    reg, cols = [], []
    want_class = want_contact = False
    for t in spec.targets:
        if t in ("region", class_name):
            want_class = True
        elif t == "contact":
            want_contact = True
        elif t in names:
            reg.append(t)
            cols.append(names.index(t))
        else:
            raise DecoderConfigError(
                f"target {t!r} is not in this dataset: it has {', '.join(names)}"
                f", {class_name!r} (classes) and 'contact'"
            )
    region = np.asarray(dataset.region)
    if want_class and not np.any(region > 0):
        raise DecoderConfigError(
            f"target {class_name!r} asked for, but no row of the dataset has a class label"
        )
    spectratac = tuple(dataset.input_names) == vocab.DECODED_INPUTS
    if dataset.meta.get("kind") == "spectratac" and spectratac:
        n_classes = vocab.N_REGIONS
    else:
        n_classes = len(labels) if labels else int(region.max(initial=0))
    steps = sensor_config.n_steps(sensor_config.normalise(dataset.meta.get("config")))
    if steps > 1 and int(np.max(dataset.step, initial=0)) >= steps:
        raise DecoderConfigError(f"rows have LED step >= {steps}, the configuration's steps")
    layout = Layout(
        tuple(dataset.input_names),
        steps,
        spec.lags,
        spec.drift == "baseline",
        spec.context_ema,
    )
    if layout.drift:
        layout = with_rest_signature(layout, dataset)
    heads = Heads(
        tuple(reg),
        uncertainty=spec.uncertainty and bool(reg),
        n_classes=n_classes if want_class else 0,
        contact=want_contact,
    )
    return Plan(
        spec,
        layout,
        build_features(spec.features, layout, spec.degree),
        heads,
        cols,
        class_name if want_class else None,
        labels,
    )


def with_rest_signature(layout: Layout, dataset: Dataset) -> Layout:
    """`layout` with the skin's rest and press direction (decode.rest_signature) from the
    dataset's contact labels, so that a live baseline can tell a pressed start from rest."""
    bare = Layout(layout.channels, layout.steps)
    cur, valid = assemble(bare, dataset.inputs, dataset.step, dataset.session, dataset.t_end)
    rest, press = rest_signature(cur[valid], np.asarray(dataset.in_contact, bool)[valid])
    return replace(layout, rest=tuple(map(float, rest)), press=tuple(map(float, press)))


def select_rows(n: int, rows: ArrayLike | None) -> NDArray[np.intp]:
    if rows is None:
        return np.arange(n)
    r = np.asarray(rows)
    if r.dtype == bool:
        if r.shape != (n,):
            raise DecoderDataError(f"row mask has shape {r.shape}; the dataset has {n} rows")
        return np.flatnonzero(r)
    if r.size and (r.min() < 0 or r.max() >= n):
        raise DecoderDataError(f"row indices must lie in 0..{n - 1}")
    return np.unique(r.astype(np.intp))


def _name_rows(bad: NDArray[np.intp], what: str, fix: str) -> DecoderDataError:
    first = ", ".join(str(int(i)) for i in bad[:5])
    return DecoderDataError(
        f"{bad.size} training row(s) have {what} (rows {first}{', …' if bad.size > 5 else ''})"
        f": {fix}"
    )


def check_rows(dataset: Dataset, p: Plan, rows: NDArray[np.intp]) -> None:
    """Refuse training rows that cannot be used, naming them."""
    x = np.asarray(dataset.inputs, dtype=np.float64)[rows]
    bad = rows[~np.all(np.isfinite(x), axis=1)]
    if bad.size:
        raise _name_rows(
            bad,
            "NaN or inf inputs",
            "drop those rows (rows=…) or repair the recording; `spectratac dataset build` "
            "keeps dropouts out of the inputs",
        )
    if p.reg_cols:
        y = np.asarray(dataset.targets, dtype=np.float64)[rows][:, p.reg_cols]
        tv = np.asarray(dataset.target_valid, bool)[rows]
        bad = rows[tv & ~np.all(np.isfinite(y), axis=1)]
        if bad.size:
            raise _name_rows(
                bad,
                "NaN or inf targets while target_valid is True",
                "set target_valid False on reference dropouts (they are then left out of the "
                "regression loss)",
            )
        if not np.any(tv):
            raise DecoderDataError("no training row has a valid target (target_valid all False)")
    if p.heads.n_classes:
        lab = np.asarray(dataset.region)[rows].astype(np.int64)
        bad = rows[~((lab == -1) | ((lab >= 1) & (lab <= p.heads.n_classes)))]
        if bad.size:
            raise _name_rows(
                bad, f"class labels outside 1..{p.heads.n_classes} and -1", "use -1 for 'no label'"
            )


def ranges(rows: NDArray[np.intp]) -> list[list[int]]:
    """Sorted rows as [start, stop) runs: which rows fitted and which validated, compactly
    (the train command scores both).

    >>> ranges(np.array([5, 1, 2, 3]))
    [[1, 4], [5, 6]]
    """
    r = np.unique(rows)
    if not r.size:
        return []
    cut = np.flatnonzero(np.diff(r) != 1) + 1
    return [[int(b[0]), int(b[-1]) + 1] for b in np.split(r, cut)]


def rows_of(ranges: list[list[int]]) -> NDArray[np.intp]:
    """The rows of `ranges` output."""
    parts = [np.arange(a, b) for a, b in ranges]
    return np.concatenate(parts).astype(np.intp) if parts else np.zeros(0, np.intp)
