"""A new unit without a reference sensor: adapt a decoder from a guided session's region
labels alone (`spectratac train g.npz --finetune base.stac` on data without force targets).

A guided session (`record --guided`, no `--ft`) says where the skin was pressed and when it
rested, never how hard. What that teaches, and is adapted:

- the rest signature (the unit's own rest and press direction: the live baseline starts
  from this unit's rest);
- the region head (its class rows, on the labelled presses; the hidden layers are kept);
- the guard: input ranges widened to this unit's, and the out-of-distribution distance
  model of this unit's inputs (another unit's gains put every sample of it outside the
  base unit's, so every estimate was flagged);
- forces, by `forces`: "kept" (the base unit's force layers as they are) or "rest" (the
  same, with the output offset moved so that this unit's rest reads zero force: the rest is
  the one force level a session without a reference knows).

What it cannot adapt, and says so (`Adaptation.not_adapted`): the force and torque scale of
this unit (no reference: a press reads what the base unit would have read for the same
light), the force layers themselves, and a check of forces against a reference.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from spectratac.dataset.schema import Dataset
from spectratac.decode.assemble import assemble, session_order
from spectratac.decode.decoder import Decoder
from spectratac.decode.errors import DecoderConfigError, DecoderDataError
from spectratac.decode.guard import Guard
from spectratac.decode.runtime import Runtime
from spectratac.train.finetune import check_compatible, model_id
from spectratac.train.fitting import augmented, gain_view, with_gain_inputs
from spectratac.train.spec import TrainSpec
from spectratac.train.torch_loop import Progress, fit_network

FORCES = ("kept", "rest")
DEFAULT_FORCES = "rest"
EPOCHS = 60
LR_FRACTION = 0.3  # of the base recipe's: the class rows start from the base's
MIN_LABELLED = 20  # labelled rows at least (a minute's guided session has ~400)
MIN_REGIONS = 2


@dataclass
class Adaptation:
    """What an adaptation without targets changed, measured on its session."""

    adapted: list[str] = field(default_factory=list)
    not_adapted: list[str] = field(default_factory=list)
    figures: dict[str, Any] = field(default_factory=dict)


def has_force_targets(dataset: Dataset) -> bool:
    """True when some row has a valid target (a reference F/T was recorded)."""
    return bool(np.any(np.asarray(dataset.target_valid, bool)))


def adapt_without_targets(
    base: Decoder,
    dataset: Dataset,
    *,
    forces: str = DEFAULT_FORCES,
    epochs: int = EPOCHS,
    augment: bool = True,
    seed: int = 0,
    progress: Progress = True,
) -> tuple[Decoder, Adaptation]:
    """`base` adapted to the unit of `dataset` (region labels, no force targets); see the
    module doc. DecoderDataError when the data has force targets (use `finetune`) or too
    few labelled presses; FinetuneMismatchError when it does not match the base."""
    if forces not in FORCES:
        raise DecoderConfigError(f"forces={forces!r}: choose one of {', '.join(FORCES)}")
    if has_force_targets(dataset):
        raise DecoderDataError("this data has force targets: fine-tune with them (finetune)")
    t0 = time.perf_counter()
    base_spec = TrainSpec.from_dict(dict(base.meta["spec"]))
    spec = replace(
        base_spec, epochs=int(epochs), lr=LR_FRACTION * base_spec.lr, seed=int(seed),
        val_fraction=0.0, best_val=False,
    )  # fmt: skip
    if not augment:
        spec = replace(spec, augment="none")
    region = np.asarray(dataset.region).astype(np.int64)
    _check_labels(region)
    p = check_compatible(base, dataset, spec)
    contact = np.asarray(dataset.in_contact, bool)
    u, valid = assemble(p.layout, dataset.inputs, dataset.step, dataset.session, dataset.t_end)
    order = np.concatenate(session_order(np.asarray(dataset.session), np.asarray(dataset.t_end)))
    order = order[valid[order]]
    labelled = order[region[order] > 0]
    rt = base.runtime.with_dtype(np.float64)
    report = Adaptation()
    report.figures["ood_before"] = _ood_share(base, u[order], rt)
    report.figures["region_before"] = _region_accuracy(rt, u[labelled], region[labelled])

    # the region head: its class (and contact) rows, on the labelled presses
    data: dict[str, Any] = {
        "z": rt.normalised(u),
        "y": np.zeros((dataset.n, len(p.reg_cols))),
        "y_ok": np.zeros(dataset.n, bool),
        "label": region,
        "contact": contact,
    }
    with_gain_inputs(data, spec, rt, u)
    rows = order
    if spec.augment != "none":  # the base's symmetric copies: a mirror relabels the press
        data, rows = augmented(dataset, p, rt, data, u, rt.y_scale, order)
    data = gain_view(data, rt)
    weights, history, _ = fit_network(
        spec, p, data, rows, order[:0], progress, start=dict(rt.weights),
        trainable=lambda name: name.startswith("head."),
    )  # fmt: skip
    sl = rt.heads.slices()
    keep = np.r_[sl["targets"], sl["std"]]  # the force rows stay the base's, bit for bit
    for name in ("head.weight", "head.bias"):
        w = np.array(weights[name], dtype=np.float64)
        w[keep] = np.asarray(rt.weights[name], np.float64)[keep]
        weights[name] = w
    out = replace(rt, weights=weights)
    report.adapted += ["rest signature", "region head", "guard ranges", "OOD distance model"]

    rest_rows = order[(~contact[order]) & (np.asarray(dataset.press)[order] < 0)]
    offset = _rest_offset(out, u[rest_rows])
    report.figures["rest_force_before"] = offset.tolist()
    if forces == "rest" and rest_rows.size:
        bias = np.array(out.weights["head.bias"], dtype=np.float64)
        bias[sl["targets"]] -= offset / out.y_scale
        out = replace(out, weights={**out.weights, "head.bias": bias})
        report.adapted.append("force offset at rest")
    report.not_adapted += [
        "force and torque scale (no reference F/T: a press reads what the base unit read for "
        "the same light)",
        "force and torque layers (kept from the base)",
    ]
    if forces == "kept":
        report.not_adapted.append("force offset at rest (forces='kept')")
    guard = _unit_guard(base.guard, u[order, : p.layout.base], spec.gain_jitter)
    dec = Decoder(replace(out, dtype=base.runtime.dtype), p.layout, guard, _meta(base, dataset))
    report.figures["region_after"] = _region_accuracy(out, u[labelled], region[labelled])
    report.figures["ood_after"] = _ood_share(dec, u[order], out)
    report.figures["rest_force_after"] = _rest_offset(out, u[rest_rows]).tolist()
    dec.meta.update(
        {
            "n_train": int(order.size),
            "train_seconds": time.perf_counter() - t0,
            "history": history,
            "finetuned_from": {
                "id": model_id(base),
                "unit_id": base.unit_id,
                "mode": "regions",
                "forces": forces,
                "epochs": spec.epochs,
                "lr": spec.lr,
                "kept": "regions",
                "adapted": report.adapted,
                "not_adapted": report.not_adapted,
                "figures": report.figures,
            },
        }
    )
    return dec, report


def _check_labels(region: NDArray[np.int64]) -> None:
    """DecoderDataError unless enough rows over enough regions are labelled."""
    n, kinds = int(np.count_nonzero(region > 0)), np.unique(region[region > 0]).size
    if n < MIN_LABELLED or kinds < MIN_REGIONS:
        raise DecoderDataError(
            f"{n} rows with a region label over {kinds} regions: too few to adapt the region "
            f"head (need {MIN_LABELLED} rows over {MIN_REGIONS} regions or more); record a "
            "guided session: spectratac record URL --guided 9 -o g.mcap"
        )


def _meta(base: Decoder, dataset: Dataset) -> dict[str, Any]:
    meta = dict(base.meta)
    meta.pop("holdout", None)  # the base's held-out check is not this model's
    meta["unit_id"] = dataset.meta.get("unit_id")
    meta["targets_from"] = "base"  # no reference: the forces are the base unit's
    return meta


def _unit_guard(base: Guard, x: NDArray[np.float64], gain: float) -> Guard:
    """The base guard with this unit's inputs in range, and this unit's distance model; the
    target ranges stay the base's (this session has no targets)."""
    new = Guard.fit(x, np.zeros((x.shape[0], 0)), base.saturation, base.dark_cols, gain=gain)
    return Guard(
        np.minimum(base.in_lo, new.in_lo),
        np.maximum(base.in_hi, new.in_hi),
        base.t_lo,
        base.t_hi,
        base.saturation,
        list(base.dark_cols),
        new.center,
        new.whiten,
        new.dist_max,
    )


def _rest_offset(rt: Runtime, u: NDArray[np.float64]) -> NDArray[np.float64]:
    """Median force/torque `rt` reads on rest rows `u` (zeros without rows)."""
    if not u.shape[0]:
        return np.zeros(rt.heads.n_reg)
    return np.asarray(np.median(rt.run(u)[:, rt.heads.slices()["targets"]], axis=0))


def _region_accuracy(rt: Runtime, u: NDArray[np.float64], region: NDArray[np.int64]) -> float:
    probs = rt.run(u)[:, rt.heads.slices()["classes"]]
    return float(np.mean(np.argmax(probs, axis=1) + 1 == region)) if len(region) else 0.0


def _ood_share(dec: Decoder, u: NDArray[np.float64], rt: Runtime) -> float:
    """Share of rows `dec`'s guard flags (inputs and decoded targets)."""
    y = rt.run(u)[:, rt.heads.slices()["targets"]]
    return float(np.mean(dec.guard.check(u[:, : dec.layout.base], y)))
