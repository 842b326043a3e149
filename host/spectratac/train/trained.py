"""`fit`: the one entry point of training. It returns the decoder together with its held-out
check and a summary, so that a Python user gets the honest check the command line prints.

One recipe per call: a `TrainSpec` (default: the paper's recipe on the data's targets), a
fine-tuning of a trained decoder (`finetune_from=`), or the auto recipe's search within
`budget=` seconds. The rows it trains on are all of them, the training rows of a `holdout`
split, or all but the `holdout_sessions`; the choice is recorded in the model
(train/holdout.py) so that `spectratac evaluate` scores exactly the rows it never saw.

>>> import numpy as np
>>> from spectratac.dataset import Dataset
>>> rng = np.random.default_rng(0)
>>> x = rng.normal(size=(400, 2))
>>> y = (x @ [1.0, -2.0] + 0.1 * rng.normal(size=400))[:, None]
>>> ds = Dataset.generic(x, y, ["a", "b"], ["Fz"])
>>> ds.arrays["session"][:] = np.repeat(np.arange(4), 100)
>>> trained = fit(ds, TrainSpec(features="generic", model="ridge", targets=("Fz",)))
>>> trained.check.heldout_groups, trained.check.heldout_source, trained.check.n_heldout
('session', 'a check model trained on the other groups', 100)
>>> trained.check.warning is None, trained.summary["n_train"]
(True, 400)
>>> round(trained.check.heldout_mae["Fz"], 2), round(trained.check.train_mae["Fz"], 2)
(0.09, 0.07)
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from spectratac.dataset.schema import Dataset
from spectratac.decode.decoder import Decoder
from spectratac.decode.errors import DecoderConfigError, DecoderError
from spectratac.train.auto_recipe import SearchResult, search
from spectratac.train.check import (
    HeldOutCheck,
    check_recipe,
    check_stride,
    cv_check,
    held_out_check,
    needs_check_model,
)
from spectratac.train.finetune import FinetuneOptions, finetune
from spectratac.train.fitting import train
from spectratac.train.groups import Split, SplitSpec, split_dataset
from spectratac.train.holdout import (
    mark,
    mark_all,
    mark_sessions,
    parse_sessions,
    session_rows,
)
from spectratac.train.metrics import region_accuracy, target_mae
from spectratac.train.plan import default_features, default_targets
from spectratac.train.spec import TrainSpec
from spectratac.train.torch_loop import Progress

Rows = NDArray[np.intp]


@dataclass(frozen=True)
class Trained:
    """The decoder, its held-out check, a summary (the decoder's error on the rows it did not
    train on, or on every row when it held none out; sizes, cost, recipe) and, for the auto
    recipe, the search (its report: every candidate's CV error and cost)."""

    decoder: Decoder
    check: HeldOutCheck
    summary: dict[str, Any]
    search: SearchResult | None = None

    def report(self, written: dict[str, str] | None = None) -> dict[str, Any]:
        """One JSON-able object: the summary, the files `written`, the check and the search
        report (what `spectratac train --json` prints)."""
        out: dict[str, Any] = {}
        for key, value in self.summary.items():
            out[key] = value
            if key == "n_test":
                out["written"] = dict(written or {})
        out.update(self.check.as_dict())
        if self.search is not None:
            out["auto_recipe"] = self.search.report
        return out


def default_spec(dataset: Dataset) -> TrainSpec:
    """The paper's recipe decoding every target (and the classes) of `dataset`."""
    return TrainSpec.paper(features=default_features(dataset), targets=default_targets(dataset))


def fit(
    dataset: Dataset,
    spec: TrainSpec | None = None,
    *,
    holdout: SplitSpec | None = None,
    holdout_sessions: Sequence[int] | str | None = None,
    finetune_from: Decoder | str | os.PathLike[str] | None = None,
    finetune_options: FinetuneOptions | None = None,
    budget: float | None = None,
    workers: int | None = None,
    ray_address: str | None = None,
    progress: Progress = True,
    log: Callable[[str], None] | None = None,
) -> Trained:
    """Train a decoder on `dataset` and check it on whole groups it did not see.

    spec: the recipe (default `default_spec`); with `budget`, only its targets and features
    count and the recipe is searched (train/auto_recipe) on `workers` local processes or the
    Ray cluster at `ray_address`, `log` receiving a line per finished candidate.
    finetune_from: a decoder, or its .stac file (the path is recorded in
    meta["finetuned_from"]), recalibrated on this data with `finetune_options` (its recipe
    is the base's: give no spec). holdout: train on this split's training rows only;
    holdout_sessions: ids, or text such as "3,4" or "30-35", of sessions left out; either
    is recorded in the model. progress: as `train`'s.
    """
    if holdout is not None and holdout_sessions is not None:
        raise DecoderConfigError("give holdout or holdout_sessions, not both")
    if finetune_from is not None and (spec is not None or budget is not None):
        raise DecoderConfigError(
            "a fine-tuned decoder keeps its base's recipe: give finetune_from without a spec "
            "or a budget"
        )
    rows: Rows | None = None
    split: Split | None = None
    held: list[int] | None = None
    test: Rows | None = None  # the rows held out of training, if any
    if holdout_sessions is not None:
        text = (
            holdout_sessions
            if isinstance(holdout_sessions, str)
            else ",".join(str(int(s)) for s in holdout_sessions)
        )
        held = parse_sessions(text)
        test = session_rows(dataset, held)
        rows = np.setdiff1d(np.arange(dataset.n), test)
        if rows.size == 0:
            raise DecoderError(f"holding out sessions {text} leaves no training row")
    if holdout is not None:
        split = split_dataset(dataset, holdout)
        rows = split.train
    found: SearchResult | None = None
    if finetune_from is not None:
        tune = _tuner(dataset, finetune_from, finetune_options or FinetuneOptions())
        dec = tune(rows, progress)

        def again(fit_rows: Rows) -> Decoder:
            return tune(fit_rows, False)

    elif budget is not None:
        spec = spec or default_spec(dataset)
        found = search(
            dataset,
            budget,
            rows=rows,
            targets=spec.targets,
            features=spec.features,
            workers=workers,
            ray_address=ray_address,
            progress=log,
        )
        dec = found.decoder
    else:
        recipe = spec or default_spec(dataset)
        dec = train(dataset, recipe, rows=rows, progress=progress)
        # the check's models train on every stride-th row, with as many steps as the real one
        own = needs_check_model(dec, split, held is not None)
        checking = check_recipe(recipe, check_stride(dataset, rows, check_model=own))

        def again(fit_rows: Rows) -> Decoder:  # the check model, trained like the real one
            return train(dataset, checking, rows=fit_rows, progress=progress)

    if found is not None:
        check = cv_check(found.report)
    else:
        check = held_out_check(
            dec, dataset, rows, split=split, held_sessions=held is not None, trainer=again
        )
    if split is not None:
        mark(dec, dataset, split)
        test = split.test
    if held is not None:
        mark_sessions(dec, dataset, held)
    if split is None and held is None:
        mark_all(dec, dataset)  # so evaluating on this data is reported as training error
    return Trained(dec, check, summarise(dec, dataset, test), found)


def _tuner(
    dataset: Dataset, base: Decoder | str | os.PathLike[str], options: FinetuneOptions
) -> Callable[[Rows | None, Progress], Decoder]:
    """Fine-tunes the base (loaded afresh from its file for every call) on given rows."""
    path = None if isinstance(base, Decoder) else str(base)

    def tune(rows: Rows | None, bar: Progress) -> Decoder:
        dec = finetune(
            base if isinstance(base, Decoder) else Decoder.load(Path(base)),
            dataset,
            rows,
            mode=options.mode,
            refit_scaler=options.refit_scaler,
            epochs=options.epochs,
            lr=options.lr,
            seed=options.seed,
            targets=options.targets,
            progress=bar,
        )
        if path is not None:
            dec.meta["finetuned_from"]["path"] = path
        return dec

    return tune


def summarise(dec: Decoder, dataset: Dataset, test: Rows | None = None) -> dict[str, Any]:
    """The training summary: MAE per target and class accuracy on the held-out rows `test`,
    or on every row (training rows included: optimistic) when there are none; the recipe,
    sizes, cost and where the model came from."""
    rows = np.arange(dataset.n) if test is None else np.asarray(test)
    est = dec.predict(dataset, rows)
    labels = np.asarray(dataset.region)[rows]
    m = dec.meta
    held = m.get("holdout")
    return {
        "mae_rows": "held-out" if test is not None else "all (training rows included)",
        "holdout": (held.get("split") or {"kind": "sessions", **held["sessions"]})
        if held and ("split" in held or "sessions" in held)
        else None,
        "n_test": int(rows.size) if test is not None else 0,
        "spec": m["spec"],
        "n_train": m["n_train"],
        "train_seconds": round(m["train_seconds"], 2),
        "final_loss": m["history"][-1] if m["history"] else float("nan"),
        "params": dec.n_params,
        "flops_per_sample": dec.flops_per_sample,
        "mae": target_mae(est, dataset, rows, dec.target_names),
        "class_accuracy": region_accuracy(labels, est.region) if dec.heads.n_classes else None,
        "unit_id": dec.unit_id,
        "finetuned_from": m.get("finetuned_from"),
    }
