"""Few-shot recalibration: adapt a trained decoder to a new unit from minutes of its data.

`finetune(base, dataset)` keeps the base decoder's layout, features, heads and target
scales, starts from its weights and trains briefly with a small learning rate on the new
unit's rows. What adapts is `mode`:

- "scaler": only the input normalisation (feature centre and z-scaling) is re-fitted on the
  new rows; no gradient step. Units differ mostly in optical gains and offsets, which shift
  and stretch the features; the network downstream is kept as is.
- "head": the output layer only.
- "first": the first layer and the output layer (input-side and output-side recalibration;
  the default).
- "full": every weight.
- "gain": no weight; one output gain per target, fitted by least squares through zero on
  every row given (`spectratac train --finetune BASE --gain-only`): the one-parameter
  recalibration of a response that drifted by a factor, which 30 s of a new session fit
  without over-fitting what those presses happen to hold. It is still checked against the
  base on held-out presses (gain fitted without them) and the base is kept when it does
  better.

A few minutes are one session: their feature statistics are that session's (mounting,
temperature) as much as the unit's, which held-out presses of the same session cannot tell
apart; a unit whose gains differ much (the tests' synthetic one) needs the refit. How each
mode does with 1, 2 and 5 minutes of a new twin unit is measured by
`tools/bench/generalisation.py --sections c` (figures in tools/bench/MEASUREMENTS.md).

`refit_scaler`: whether the input normalisation is re-fitted on the new rows before the
gradient steps. None (the default) tries both and keeps the one the held-out presses prefer;
without held-out presses (too little data) it is not refitted, as the benchmark's figures chose.

Validation is grouped: whole presses (a press and the idle rows after it) are held out, never
single rows, whose near-duplicate neighbours would sit in training. The weights of the epoch
with the lowest validation loss are kept (early stopping). With fewer than MIN_VAL_GROUPS
sessions or presses in the data (a validation loss would be decided by which one or two
landed in it), N_BLOCKS guarded time blocks are held out instead; data too short even for
those raises FinetuneCheckError: the check is never skipped. Last, on the same
held-out groups, a fine-tuned decoder is kept only if its error beats both the base's as it
was and the gain-only recalibration (one output gain per target fitted on the fit rows,
`gain_calibrated`: the first step, a unit's or a session's gain drift); otherwise the best of
those is returned (`meta["finetuned_from"]["kept"]`: "finetuned", "finetuned+refit", "gain"
or "base", with each one's validation score), so a few minutes of data
never make a good base worse by what they happen to hold.

>>> import numpy as np
>>> from spectratac.dataset import Dataset
>>> from spectratac.train import TrainSpec, train
>>> rng = np.random.default_rng(0)
>>> x = rng.normal(size=(200, 2)); y = (x @ [1.0, -2.0])[:, None]
>>> base = train(Dataset.generic(x, y, ["a", "b"], ["Fz"]),
...              TrainSpec.paper(features="generic", targets=("Fz",), epochs=3), progress=False)
>>> new = Dataset.generic(1.1 * x[:60] + 0.2, y[:60], ["a", "b"], ["Fz"])
>>> dec = finetune(base, new, epochs=2, progress=False)
>>> dec.meta["finetuned_from"]["id"] == model_id(base), dec.meta["finetuned_from"]["mode"]
(True, 'first')
>>> finetune(base, Dataset.generic(x, y, ["a", "c"], ["Fz"]), progress=False)
Traceback (most recent call last):
...
spectratac.train.finetune.FinetuneMismatchError: the new data does not match ... ['a', 'c'] ...
"""

from __future__ import annotations

import hashlib
import time
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from spectratac.dataset.schema import Dataset
from spectratac.decode import sensor_config
from spectratac.decode.assemble import assemble, session_order
from spectratac.decode.decoder import Decoder
from spectratac.decode.errors import DecoderConfigError, DecoderDataError
from spectratac.decode.guard import Guard
from spectratac.decode.runtime import Runtime
from spectratac.train.fitting import augmented, gain_view, with_gain_inputs
from spectratac.train.groups import (
    GUARD_ROWS,
    N_BLOCKS,
    Groups,
    row_groups,
    val_split,
)
from spectratac.train.plan import Plan, check_rows, plan, ranges, select_rows
from spectratac.train.spec import TrainSpec
from spectratac.train.torch_loop import Progress, fit_network

MODES = ("scaler", "head", "first", "full", "gain")
DEFAULT_MODE = "first"
DEFAULT_EPOCHS = 40
LR_FRACTION = 0.1  # fine-tuning learning rate as a fraction of the base recipe's
VAL_FRACTION = 0.2  # share of presses held out for early stopping
MIN_VAL_GROUPS = 10  # fewer sessions or presses than this: time blocks are held out
MIN_BLOCK_ROWS = 2  # rows per time block at least, else too little data to check


@dataclass(frozen=True)
class FinetuneOptions:
    """How `spectratac.train.fit(..., finetune_from=base)` recalibrates: `finetune`'s keyword
    arguments (None: its defaults)."""

    mode: str = DEFAULT_MODE
    refit_scaler: bool | None = None
    epochs: int | None = None
    lr: float | None = None
    seed: int = 0
    targets: tuple[str, ...] | None = None


class FinetuneCheckError(DecoderDataError):
    """Too little data to hold some out: the fine-tuned decoder could not be checked against
    its base, so none is returned."""


class FinetuneMismatchError(DecoderConfigError):
    """The new data cannot refine the base decoder: other inputs, LED configuration or
    targets."""


def model_id(dec: Decoder) -> str:
    """Content hash (16 hex digits) of a decoder's runtime: weights, normalisation, heads."""
    h = hashlib.sha256()
    arrays = dec.runtime.arrays()
    for k in sorted(arrays):
        a = np.ascontiguousarray(arrays[k])
        h.update(k.encode())
        h.update(str(a.shape).encode())
        h.update(a.tobytes())
    h.update(repr(sorted(dec.layout.to_dict().items())).encode())
    return h.hexdigest()[:16]


def check_compatible(base: Decoder, dataset: Dataset, spec: TrainSpec) -> Plan:
    """The training plan of `spec` on `dataset`; FinetuneMismatchError unless its inputs, LED
    configuration, layout and heads are the base decoder's."""

    def refuse(why: str) -> FinetuneMismatchError:
        return FinetuneMismatchError(
            f"the new data does not match the base decoder ({why}): fine-tune only on data of "
            "the same sensor kind, LED configuration and targets, or train a new decoder"
        )

    if tuple(dataset.input_names) != base.layout.channels:
        raise refuse(
            f"inputs {list(dataset.input_names)} differ from the base's "
            f"{list(base.layout.channels)}"
        )
    diffs = sensor_config.differences(
        base.config, sensor_config.normalise(dataset.meta.get("config"))
    )
    if diffs:
        raise refuse("sensor configuration: " + "; ".join(diffs))
    missing = [t for t in base.heads.regression if t not in dataset.target_names]
    if missing:
        raise refuse(f"targets {missing} are not in the new data ({list(dataset.target_names)})")
    try:
        p = plan(dataset, spec)
    except DecoderConfigError as exc:
        raise refuse(str(exc)) from None
    # the rest signature is the new unit's own (its rest, seen in its data), the rest must match
    if replace(p.layout, rest=(), press=()) != replace(base.layout, rest=(), press=()):
        raise refuse("the LED steps or temporal layout differ")
    if p.heads != base.heads:
        raise refuse(f"heads {p.heads} differ from the base's {base.heads}")
    return p


def trainable(mode: str, arch_kind: str) -> Any:
    """Which parameters `mode` updates (a name predicate), or None for none (modes "scaler"
    and "gain")."""
    if mode in ("scaler", "gain"):
        return None
    if mode == "full":
        return lambda name: True
    first = {"resmlp": "stem.", "mlp": "layers.0.", "linear": "head."}[arch_kind]
    if mode == "head":
        return lambda name: name.startswith("head.")
    return lambda name: name.startswith(("head.", first))


def grouped_validation(
    dataset: Dataset, order: NDArray[np.intp], fraction: float = VAL_FRACTION
) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """(fit, val) rows of `order`: about `fraction` of the whole groups that training's
    validation uses (train/groups.py: sessions, else a press with the idle rows after it,
    else guarded time blocks) go to validation. No validation rows when there are fewer than
    MIN_VAL_GROUPS groups.

    >>> from spectratac.dataset import Dataset
    >>> ds = Dataset.generic(np.zeros((100, 1)), np.zeros(100), ["a"], ["Fz"])
    >>> ds.arrays["press"][:] = np.repeat(np.arange(20), 5)
    >>> ds.arrays["t_start"][:] = ds.arrays["t_end"][:] = np.arange(100.0)
    >>> fit, val = grouped_validation(ds, np.arange(100))
    >>> val.size, np.intersect1d(ds.press[fit], ds.press[val]).size
    (20, 0)
    """
    fit, val, _ = validation_groups(dataset, order, fraction)
    return fit, val


def validation_groups(
    dataset: Dataset, order: NDArray[np.intp], fraction: float = VAL_FRACTION
) -> tuple[NDArray[np.intp], NDArray[np.intp], str]:
    """`grouped_validation` and the kind of groups held out. With fewer than MIN_VAL_GROUPS
    sessions or presses, guarded time blocks are held out instead (a few sessions of a new
    unit are the normal case, and the keep-the-base check must still run); with too few
    rows even for those, FinetuneCheckError says so (never a silent skip)."""
    if fraction <= 0:
        return order, order[:0], "none"
    groups = row_groups(dataset.session, dataset.press, dataset.t_end, order)
    n_groups = np.count_nonzero(np.unique(groups.ids[order]) >= 0)
    if n_groups < MIN_VAL_GROUPS:
        blocks = np.full(dataset.n, -1, np.int64)
        # N_BLOCKS blocks of the rows being fine-tuned on, not of the whole dataset
        for k, chunk in enumerate(np.array_split(order, N_BLOCKS)):
            blocks[chunk] = k
        groups = Groups(blocks, "block")
        n_groups = np.count_nonzero(np.unique(blocks[order]) >= 0)
    # a guard gap wider than a quarter of a block would purge most of a minute of data
    guard = min(GUARD_ROWS, order.size // (4 * max(n_groups, 1)))
    short = order.size < MIN_BLOCK_ROWS * N_BLOCKS and groups.kind == "block"
    fit, val = (order, order[:0]) if short else val_split(order, fraction, groups, guard)
    if fit.size < 2 or val.size == 0:
        raise FinetuneCheckError(
            f"cannot check the recalibration: {order.size} usable rows are too few to hold "
            f"some {groups.kind}s out (the check against the base needs held-out data); "
            "record a minute or more of the new unit"
        )
    return fit, val, groups.kind


def finetune(
    base: Decoder,
    dataset: Dataset,
    rows: ArrayLike | None = None,
    *,
    mode: str = DEFAULT_MODE,
    refit_scaler: bool | None = None,
    epochs: int | None = None,
    lr: float | None = None,
    seed: int = 0,
    targets: Sequence[str] | None = None,
    progress: Progress = True,
) -> Decoder:
    """Recalibrate `base` on `rows` of `dataset` (a new unit's data). See the module doc.

    Raises FinetuneMismatchError when the data has other inputs, LED configuration or targets
    than the base (or when `targets`, if given, are not the base's), DecoderDataError on
    unusable rows, DecoderConfigError on an unknown mode.
    """
    if mode not in MODES:
        raise DecoderConfigError(f"fine-tuning mode {mode!r}: choose one of {', '.join(MODES)}")
    t0 = time.perf_counter()
    base_spec = TrainSpec.from_dict(dict(base.meta["spec"]))
    spec = replace(
        base_spec,
        epochs=int(epochs if epochs is not None else DEFAULT_EPOCHS),
        lr=float(lr if lr is not None else LR_FRACTION * base_spec.lr),
        seed=int(seed),
        val_fraction=0.0,
        best_val=False,
    )
    if targets is not None and tuple(targets) != spec.targets:
        raise FinetuneMismatchError(
            f"targets {list(targets)} differ from the base decoder's {list(spec.targets)}: a "
            "fine-tuned decoder keeps its base's targets; leave the targets out or train anew"
        )
    p = check_compatible(base, dataset, spec)
    sel = select_rows(dataset.n, rows)
    if sel.size < 2:
        raise DecoderDataError(f"need at least 2 rows to fine-tune on, got {sel.size}")
    check_rows(dataset, p, sel)
    u, valid = assemble(p.layout, dataset.inputs, dataset.step, dataset.session, dataset.t_end)
    keep = np.zeros(dataset.n, bool)
    keep[sel] = True
    keep &= valid
    order = np.concatenate(session_order(np.asarray(dataset.session), np.asarray(dataset.t_end)))
    order = order[keep[order]]
    if order.size < 2:
        raise DecoderDataError("fewer than 2 usable rows after LED-step assembly")
    predicate = trainable(mode, base.runtime.arch[0])
    if mode == "gain" and not p.reg_cols:
        raise DecoderConfigError(
            "a gain-only recalibration needs force or torque targets in the new data: give "
            "data recorded with a reference (--ft), or fine-tune without --gain-only"
        )
    fit_rows, val_rows, val_kind = validation_groups(dataset, order)
    y_all = np.asarray(dataset.targets, np.float64)[:, p.reg_cols]
    tv = np.asarray(dataset.target_valid, bool) & np.all(np.isfinite(y_all), axis=1)
    choose = bool(val_rows.size and p.reg_cols)  # held-out presses to decide with
    if mode == "gain":
        refits = []
    elif mode == "scaler":
        refits = [True]
    elif refit_scaler is None:
        refits = [False, True] if choose else [False]  # without validation: the measured best
    else:
        refits = [bool(refit_scaler)]

    def tuned(refit: bool) -> tuple[Runtime, list[float], list[float], int]:
        rt = base.runtime.with_dtype(np.float64)
        if refit:
            fresh = Runtime.create(p.features, rt.arch, rt.weights, rt.heads, u[fit_rows])
            rt = replace(rt, center=fresh.center, scaler=fresh.scaler)
        if predicate is None:
            return replace(rt, dtype=base.runtime.dtype), [], [], 0
        data = {
            "z": rt.normalised(u),
            "y": np.where(tv[:, None], y_all, 0.0) / rt.y_scale,
            "y_ok": tv,
            "label": np.asarray(dataset.region).astype(np.int64),
            "contact": np.asarray(dataset.in_contact, bool),
        }
        with_gain_inputs(data, spec, rt, u)
        net_rows = fit_rows
        if spec.augment != "none":
            data, net_rows = augmented(dataset, p, rt, data, u, rt.y_scale, fit_rows)
        data = gain_view(data, rt)
        run_spec = replace(spec, best_val=bool(val_rows.size))
        weights, hist, val_hist = fit_network(
            run_spec, p, data, net_rows, val_rows, progress, start=dict(rt.weights),
            trainable=predicate,
        )  # fmt: skip
        out = replace(rt, weights=weights, dtype=base.runtime.dtype)
        return out, hist, val_hist, int(net_rows.size - fit_rows.size)

    runs = {("finetuned+refit" if r else "finetuned"): (r, *tuned(r)) for r in refits}
    kept, val_scores = next(iter(runs), "gain"), {}
    if choose:
        # the last automatic choice, on the same held-out presses: recalibration must earn its
        # place against the base as it was (refitting the normalisation against not doing so)
        # ... and the layers must beat a gain-only recalibration (one output gain per
        # target, fitted on the fit rows): the first step, a unit's or a session's gain drift
        fit_ok = fit_rows[tv[fit_rows]]
        gain_rt = gain_calibrated(base.runtime, u[fit_ok], y_all[fit_ok])
        options = {k: v[1] for k, v in runs.items()} | {"base": base.runtime, "gain": gain_rt}
        ok = val_rows[tv[val_rows]]
        scale = base.runtime.y_scale  # one yardstick for every candidate
        val_scores = {k: _scaled_mae(r, u[ok], y_all[ok], scale) for k, r in options.items()}
        kept = min(val_scores, key=lambda k: val_scores[k])  # ties: the first
    if kept == "gain":
        refit, history, val_history, n_augmented = False, [], [], 0
        if mode == "gain":  # checked without the held-out presses; now fitted on every row
            every = order[tv[order]]
            gain_rt = gain_calibrated(base.runtime, u[every], y_all[every])
        out_rt = replace(gain_rt, dtype=base.runtime.dtype)
    elif kept == "base":
        refit, out_rt, history, val_history, n_augmented = False, base.runtime, [], [], 0
        out_rt = replace(out_rt)  # its own runtime, not the base's
    else:
        refit, out_rt, history, val_history, n_augmented = runs[kept]
    y_fit = y_all[fit_rows][tv[fit_rows]]
    new_guard = Guard.fit(
        u[fit_rows, : p.layout.base],
        y_fit,
        base.guard.saturation,
        base.guard.dark_cols,
        gain=spec.gain_jitter,
    )
    guard = Guard(
        np.minimum(base.guard.in_lo, new_guard.in_lo),
        np.maximum(base.guard.in_hi, new_guard.in_hi),
        np.minimum(base.guard.t_lo, new_guard.t_lo),
        np.maximum(base.guard.t_hi, new_guard.t_hi),
        base.guard.saturation,
        list(base.guard.dark_cols),
        new_guard.center,  # the distance model of the data it is now calibrated on
        new_guard.whiten,
        new_guard.dist_max,
    )
    meta = dict(base.meta)
    meta.pop("holdout", None)  # the base's training rows are not this model's
    meta.update(
        {
            "unit_id": dataset.meta.get("unit_id"),
            "n_train": int(fit_rows.size),
            "n_val": int(val_rows.size),
            "fit_rows": ranges(fit_rows),  # rows of `dataset`, not of the base's data
            "val_rows": ranges(val_rows),
            "val_groups": val_kind,
            "n_augmented": n_augmented,
            "train_seconds": time.perf_counter() - t0,
            "history": history,
            "val_history": val_history,
            "finetuned_from": {
                "id": model_id(base),
                "unit_id": base.unit_id,
                "mode": mode,
                "refit_scaler": refit,
                "epochs": spec.epochs if predicate else 0,
                "lr": spec.lr,
                "early_stopping": bool(val_rows.size),
                "val_groups": val_kind,  # what the check held out: sessions, presses, blocks
                "kept": kept,
                "val_mae_scaled": val_scores,
            },
        }
    )
    return Decoder(out_rt, p.layout, guard, meta)


GAIN_RANGE = (0.25, 4.0)  # a gain outside this is no drift but another sensor: clipped


def gain_calibrated(rt: Runtime, u: NDArray[np.float64], y: NDArray[np.float64]) -> Runtime:
    """`rt` with one output gain per regression target, fitted by least squares through
    zero on rows (u, y): the one-parameter recalibration of a sensor whose response has
    drifted by a factor (predictions 62-87 % of the true force on real later sessions)."""
    if not u.shape[0]:
        return rt
    pred = rt.run(u)[:, rt.heads.slices()["targets"]]
    ok = np.isfinite(pred) & np.isfinite(y)
    num = np.sum(np.where(ok, pred * y, 0.0), axis=0)
    den = np.sum(np.where(ok, pred * pred, 0.0), axis=0)
    g = np.where(den > 0, num / np.where(den > 0, den, 1.0), 1.0)
    return replace(rt, y_scale=rt.y_scale * np.clip(g, *GAIN_RANGE))


def _scaled_mae(
    rt: Runtime, u: NDArray[np.float64], y: NDArray[np.float64], scale: NDArray[np.float64]
) -> float:
    """Mean over regression targets of MAE / `scale` (the base's target scales): the
    validation score that decides between the base, its gain-only recalibration and the
    fine-tuned weights."""
    if not u.shape[0]:
        return float("inf")
    pred = rt.run(u)[:, rt.heads.slices()["targets"]]
    err = np.abs(pred - y) / scale
    return float(np.nanmean(err)) if np.isfinite(err).any() else float("inf")
