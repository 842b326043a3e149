"""Training a decoder from a Dataset (torch is imported inside `train` only).

The loss is the paper's masked multitask objective, generalised to any target subset:
component-weighted L1 on zero-anchored scaled targets (paper weights Fx 1, Fy 1, Fz 0.5,
Tx 0.1, Ty 0.1, Tz 0.2; 1 for other targets; rows whose target_valid is False excluded),
plus cross-entropy over classes on rows labelled 1..K, plus binary cross-entropy on
in_contact with a contact head, plus a Laplace NLL for the uncertainty head (on a detached
mean, so that asking for uncertainty never changes the point estimates' loss). AdamW with a
One-Cycle learning-rate schedule.

>>> paper_weight("Fz"), paper_weight("Tz"), paper_weight("pressure")
(0.5, 0.2, 1.0)
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from spectratac.dataset.schema import Dataset
from spectratac.decode import sensor_config
from spectratac.decode.assemble import assemble, session_order
from spectratac.decode.decoder import Decoder
from spectratac.decode.errors import DecoderConfigError, DecoderDataError
from spectratac.decode.feature_matrices import FeatureSet, build_features
from spectratac.decode.groups import GUARD_ROWS, row_groups
from spectratac.decode.groups import val_split as groups_val_split
from spectratac.decode.guard import SATURATION, Guard
from spectratac.decode.heads import Heads
from spectratac.decode.layout import Layout
from spectratac.decode.runtime import Runtime
from spectratac.decode.spec import TrainSpec
from spectratac.hardware.generated import vocabulary as vocab

F64 = NDArray[np.float64]
PAPER_LOSS_WEIGHTS = {"Fx": 1.0, "Fy": 1.0, "Fz": 0.5, "Tx": 0.1, "Ty": 0.1, "Tz": 0.2}
HUBER_DELTA = 0.1  # in scaled target units
Progress = bool | Callable[[int, float], None]


def paper_weight(name: str) -> float:
    return PAPER_LOSS_WEIGHTS.get(name, 1.0)


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


def val_split(
    dataset: Dataset, order: NDArray[np.intp], fraction: float, guard: int = GUARD_ROWS
) -> tuple[NDArray[np.intp], NDArray[np.intp], str]:
    """(fit rows, validation rows, group kind): whole sessions, presses or guarded time
    blocks held out (decode/groups.py), never random rows."""
    if fraction <= 0:
        return order, order[:0], "none"
    g = row_groups(dataset.session, dataset.press, dataset.t_end, order)
    fit, val = groups_val_split(order, fraction, g, guard)
    return fit, val, g.kind


def train(
    dataset: Dataset,
    spec: TrainSpec | None = None,
    rows: ArrayLike | None = None,
    progress: Progress = True,
) -> Decoder:
    """Train a decoder on `rows` (mask, indices or None: all) of `dataset`.

    Reproducible: the same dataset, spec and rows give the same weights (spec.seed).
    `progress`: True for a tqdm bar on stderr, False for none, or a callable
    (epoch, mean loss). Raises DecoderDataError naming unusable rows and
    DecoderConfigError when the spec asks for targets or features the data lacks.
    """
    t0 = time.perf_counter()
    spec = spec or TrainSpec.paper()
    p = plan(dataset, spec)
    n = dataset.n
    sel = select_rows(n, rows)
    if sel.size < 2:
        raise DecoderDataError(f"need at least 2 training rows, got {sel.size}")
    check_rows(dataset, p, sel)
    u, valid = assemble(p.layout, dataset.inputs, dataset.step, dataset.session, dataset.t_end)
    keep_mask = np.zeros(n, bool)
    keep_mask[sel] = True
    keep_mask &= valid
    order = np.concatenate(session_order(np.asarray(dataset.session), np.asarray(dataset.t_end)))
    order = order[keep_mask[order]]
    fit_rows, val_rows, val_kind = val_split(dataset, order, spec.val_fraction, max(
        GUARD_ROWS, max(p.layout.lags, default=0)))  # fmt: skip
    if fit_rows.size < 2:
        raise DecoderDataError("fewer than 2 usable training rows after LED-step assembly")
    y_all = np.asarray(dataset.targets, np.float64)[:, p.reg_cols]
    tv = np.asarray(dataset.target_valid, bool) & np.all(np.isfinite(y_all), axis=1)
    y_fit = y_all[fit_rows][tv[fit_rows]]
    y_scale = _safe_std(y_fit) if p.reg_cols else np.ones(0)
    from spectratac.decode.networks import init_weights

    dummy = init_weights(spec.arch, p.features.n_features, p.heads.n_out, np.random.default_rng(0))
    rt = Runtime.create(p.features, spec.arch, dummy, p.heads, u[fit_rows], y_scale)
    z = rt.with_dtype(np.float64).normalised(u)
    data = {
        "z": z,
        "y": np.where(tv[:, None], y_all, 0.0) / y_scale,
        "y_ok": tv,
        "label": np.asarray(dataset.region).astype(np.int64),
        "contact": np.asarray(dataset.in_contact, bool),
    }
    net_rows = fit_rows
    if spec.augment != "none":
        data, net_rows = _augmented(dataset, p, rt, data, u, y_scale, fit_rows)
    if spec.model == "ridge":  # closed form, NumPy only
        from spectratac.decode.ridge import fit_ridge

        weights, history, val_history, ridge = fit_ridge(spec, p, data, net_rows, val_rows, dataset)
    else:
        ridge = None
        weights, history, val_history = _fit(spec, p, data, net_rows, val_rows, progress)
    rt.weights = weights
    rt._plan = None
    if p.heads.uncertainty and val_rows.size:
        rt.std_scale = _calibrate(rt, u[val_rows], y_all[val_rows], tv[val_rows])
    base = p.layout.base
    is_st = dataset.meta.get("kind") == "spectratac"
    dark = (
        [s * len(p.layout.channels) + 4 * k + 3 for s in range(p.layout.steps) for k in range(3)]
        if is_st
        else []
    )
    guard = Guard.fit(u[fit_rows, :base], y_fit, SATURATION if is_st else None, dark)
    meta = {
        "spec": spec.to_dict(),
        "features": {"kind": spec.features, "names": p.features.names},
        "targets": list(spec.targets),
        "regression_targets": list(p.heads.regression),
        "class_name": p.class_name,
        "class_labels": p.class_labels,
        "input_names": list(dataset.input_names),
        "kind": dataset.meta.get("kind"),
        "config": sensor_config.normalise(dataset.meta.get("config")),
        "unit_id": dataset.meta.get("unit_id"),
        "n_train": int(fit_rows.size),
        "n_augmented": int(net_rows.size - fit_rows.size),
        "n_val": int(val_rows.size),
        "val_groups": val_kind,
        "fit_rows": _ranges(fit_rows),
        "val_rows": _ranges(val_rows),
        "train_seconds": time.perf_counter() - t0,
        "history": history,
        "val_history": val_history,
        "std_scale": rt.std_scale.tolist(),
    }
    if ridge is not None:
        meta["ridge"] = ridge
    return Decoder(rt, p.layout, guard, meta)


def _ranges(rows: NDArray[np.intp]) -> list[list[int]]:
    """Sorted rows as [start, stop) runs: which rows fitted and which validated, compactly
    (the train command scores both).

    >>> _ranges(np.array([5, 1, 2, 3]))
    [[1, 4], [5, 6]]
    """
    r = np.unique(rows)
    if not r.size:
        return []
    cut = np.flatnonzero(np.diff(r) != 1) + 1
    return [[int(b[0]), int(b[-1]) + 1] for b in np.split(r, cut)]


def rows_of(ranges: list[list[int]]) -> NDArray[np.intp]:
    """The rows of `_ranges` output."""
    parts = [np.arange(a, b) for a, b in ranges]
    return np.concatenate(parts).astype(np.intp) if parts else np.zeros(0, np.intp)


def _augmented(
    dataset: Dataset,
    p: Plan,
    rt: Runtime,
    data: dict[str, Any],
    u: F64,
    y_scale: F64,
    fit_rows: NDArray[np.intp],
) -> tuple[dict[str, Any], NDArray[np.intp]]:
    """`data` with the training rows' symmetric copies appended (decode/symmetry.py), and
    the training row indices extended to them. Normalisation stays that of the real rows."""
    from spectratac.decode import symmetry

    symmetry.check_symmetric(
        dataset.input_names, sensor_config.normalise(dataset.meta.get("config"))
    )
    names = list(dataset.target_names)
    y_full = np.asarray(dataset.targets, np.float64)[fit_rows]
    extra: dict[str, list[Any]] = {k: [] for k in data}
    for turns, mirror in symmetry.transforms(p.spec.augment):
        y_t = symmetry.rotate_targets(y_full, names, turns, mirror)[:, p.reg_cols]
        ok = data["y_ok"][fit_rows] & np.all(np.isfinite(y_t), axis=1)
        extra["z"].append(
            rt.with_dtype(np.float64).normalised(
                symmetry.permute_assembled(u[fit_rows], turns, mirror)
            )
        )
        extra["y"].append(np.where(ok[:, None], y_t, 0.0) / y_scale)
        extra["y_ok"].append(ok)
        extra["label"].append(symmetry.transform_labels(data["label"][fit_rows], turns, mirror))
        extra["contact"].append(data["contact"][fit_rows])
    n = data["z"].shape[0]
    out = {k: np.concatenate([data[k], *extra[k]]) for k in data}
    return out, np.concatenate([fit_rows, np.arange(n, out["z"].shape[0])])


def _safe_std(y: F64) -> F64:
    sd = y.std(axis=0) if y.shape[0] else np.ones(y.shape[1])
    return np.where(sd > 1e-12, sd, 1.0)


def _calibrate(rt: Runtime, u: F64, y: F64, ok: NDArray[np.bool_]) -> F64:
    """Per-target factor making held-out |error| / std match the Laplace expectation."""
    out = rt.with_dtype(np.float64).run(u)
    s = rt.heads.slices()
    err = np.abs(out[:, s["targets"]] - y)[ok]
    std = out[:, s["std"]][ok]
    if err.shape[0] < 10:
        return np.ones(rt.heads.n_reg)
    # Laplace: E|e| = b = std / sqrt(2); scale std so that mean(|e| / std) = 1/sqrt(2)
    return np.sqrt(2.0) * np.mean(err / np.maximum(std, 1e-12), axis=0)


def loss_weights(spec: TrainSpec, targets: tuple[str, ...]) -> list[float]:
    """Regression loss weight per target: the loss's own, then spec.loss_weights.

    >>> loss_weights(TrainSpec.paper(loss_weights=(("Fz", 2.0),)), ("Fx", "Fz", "Tz"))
    [1.0, 2.0, 0.2]
    """
    own = [paper_weight(t) if spec.loss == "paper" else 1.0 for t in targets]
    given = dict(spec.loss_weights)
    return [given.get(t, w) for t, w in zip(targets, own, strict=True)]


def batch_sizes(n: int, batch_size: int) -> list[int]:
    """Sizes of the ceil(n / batch_size) batches of one epoch, as equal as possible: a short
    remainder batch would make one noisy optimiser step per epoch (measured with a 1-row
    remainder: blocked MAE Fx 0.18 -> 0.27 N).

    >>> batch_sizes(2049, 1024), batch_sizes(5, 1024)
    ([683, 683, 683], [5])
    """
    steps = -(-n // max(1, batch_size))
    return [n // steps + (1 if i < n % steps else 0) for i in range(steps)]


def average_decay(requested: float, total_steps: int) -> float:
    """Decay of the weight average: the requested one, capped so that the average's time
    scale 1 / (1 - decay) is at most a tenth of the run; on a short run a fixed decay would
    keep the untrained early weights in it (measured: Fz MAE 0.68 -> 1.2 N).

    >>> average_decay(0.999, 100_000), round(average_decay(0.999, 200), 3)
    (0.999, 0.95)
    """
    return min(requested, 1.0 - 10.0 / max(total_steps, 11))


def _fit(
    spec: TrainSpec,
    p: Plan,
    data: dict[str, Any],
    fit_rows: NDArray[np.intp],
    val_rows: NDArray[np.intp],
    progress: Progress,
    start: dict[str, NDArray[Any]] | None = None,
    trainable: Callable[[str], bool] | None = None,
) -> tuple[dict, list, list]:
    """Optimise the network on `fit_rows`. `start`: initial weights (fine-tuning) instead of a
    fresh initialisation; `trainable`: which parameters (by name) the optimiser updates."""
    import torch

    from spectratac.decode.torch_net import Net, laplace_nll, numpy_weights

    torch.manual_seed(spec.seed)
    torch.set_num_threads(max(1, spec.threads))
    gen = torch.Generator().manual_seed(spec.seed)
    heads = p.heads
    sl = heads.slices()
    net = Net(spec.arch, p.features.n_features, heads.n_out, spec.dropout)
    if start is not None:
        net.load_state_dict({k: torch.as_tensor(np.asarray(v)) for k, v in start.items()})
    for name, param in net.named_parameters():
        param.requires_grad_(trainable is None or trainable(name))

    def tensors(idx: NDArray[np.intp]) -> dict[str, torch.Tensor]:
        return {
            "z": torch.as_tensor(data["z"][idx], dtype=torch.float32),
            "y": torch.as_tensor(data["y"][idx], dtype=torch.float32),
            "y_ok": torch.as_tensor(data["y_ok"][idx], dtype=torch.float32),
            "label": torch.as_tensor(
                np.where(data["label"][idx] > 0, data["label"][idx] - 1, -100)
            ),
            "contact": torch.as_tensor(data["contact"][idx], dtype=torch.float32),
        }

    tr, va = tensors(fit_rows), tensors(val_rows)
    w = torch.tensor(loss_weights(spec, heads.regression), dtype=torch.float32)
    ce = torch.nn.CrossEntropyLoss(ignore_index=-100, reduction="sum")
    bce = torch.nn.BCEWithLogitsLoss()

    def loss_of(out: torch.Tensor, b: dict[str, torch.Tensor]) -> torch.Tensor:
        total = out.new_zeros(())
        if heads.n_reg:
            err = out[:, sl["targets"]] - b["y"]
            if spec.loss == "huber":
                e = torch.nn.functional.huber_loss(
                    err, torch.zeros_like(err), reduction="none", delta=HUBER_DELTA
                )
            else:
                e = err.abs()
            m = b["y_ok"][:, None]
            denom = heads.n_reg * torch.clamp(b["y_ok"].sum(), min=1.0)
            total = total + (w * e * m).sum() / denom
            if heads.uncertainty:
                nll = laplace_nll(err.detach(), out[:, sl["std"]])
                total = total + (nll * m).sum() / denom
        if heads.n_classes:
            lab = b["label"]
            total = total + ce(out[:, sl["classes"]], lab) / max(int((lab >= 0).sum()), 1)
        if heads.contact:
            total = total + bce(out[:, sl["contact"]][:, 0], b["contact"])
        return total

    n = tr["z"].shape[0]
    sizes = batch_sizes(n, spec.batch_size)
    steps = len(sizes)
    params = [q for q in net.parameters() if q.requires_grad]
    opt = torch.optim.AdamW(params, lr=spec.lr, weight_decay=spec.weight_decay)
    sched = torch.optim.lr_scheduler.OneCycleLR(
        opt, max_lr=spec.lr, total_steps=spec.epochs * steps
    )
    bar = None
    if progress is True:
        from tqdm import tqdm

        bar = tqdm(total=spec.epochs, desc="train", unit="epoch", file=sys.stderr, leave=False)
    history: list[float] = []
    val_history: list[float] = []
    best: dict[str, Any] | None = None
    avg = None
    if spec.weight_average > 0:  # an exponential moving average of the weights, per step
        from torch.optim.swa_utils import AveragedModel, get_ema_multi_avg_fn

        decay = average_decay(spec.weight_average, spec.epochs * steps)
        avg = AveragedModel(net, multi_avg_fn=get_ema_multi_avg_fn(decay))
    try:
        for epoch in range(spec.epochs):
            perm = torch.randperm(n, generator=gen)
            net.train()
            total = 0.0
            for idx in torch.split(perm, sizes):
                batch = {k: v[idx] for k, v in tr.items()}
                z = batch["z"]
                if spec.input_noise > 0:  # regularises against press-specific detail
                    z = z + spec.input_noise * torch.randn(z.shape, generator=gen)
                loss = loss_of(net(z), batch)
                opt.zero_grad(set_to_none=True)
                loss.backward()
                opt.step()
                sched.step()
                if avg is not None:
                    avg.update_parameters(net)
                total += float(loss.detach()) * idx.shape[0]
            history.append(total / n)
            if va["z"].shape[0]:
                model = avg.module if avg is not None else net
                model.eval()
                with torch.no_grad():
                    val_history.append(float(loss_of(model(va["z"]), va)))
                if spec.best_val and val_history[-1] <= min(val_history):
                    best = numpy_weights(model)
            if bar is not None:
                bar.set_postfix(loss=f"{history[-1]:.4f}")
                bar.update(1)
            elif callable(progress):
                progress(epoch + 1, history[-1])
    finally:
        if bar is not None:
            bar.close()
    final = avg.module if avg is not None else net
    return (best if best is not None else numpy_weights(final)), history, val_history
