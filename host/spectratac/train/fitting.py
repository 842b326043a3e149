"""Fitting one decoder on given rows of a Dataset: `train` (torch is imported only when a
network is fitted; ridge is NumPy).

Assembles the inputs, splits the rows into fit and validation groups (`val_fraction`,
train/groups.py), scales the targets, adds the symmetric copies (`augment`), fits the
network (train/torch_loop.py) or the ridge head (train/ridge.py), calibrates the
uncertainty on the validation rows and fits the guard. `fit` (train/trained.py) wraps it
with the held-out check.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from spectratac.dataset.schema import Dataset
from spectratac.decode import sensor_config
from spectratac.decode.assemble import assemble, session_order
from spectratac.decode.decoder import Decoder
from spectratac.decode.errors import DecoderDataError
from spectratac.decode.guard import SATURATION, Guard
from spectratac.decode.runtime import Runtime
from spectratac.train.groups import GUARD_ROWS, row_groups
from spectratac.train.groups import val_split as groups_val_split
from spectratac.train.plan import Plan, check_rows, plan, ranges, select_rows
from spectratac.train.spec import TrainSpec
from spectratac.train.torch_loop import Progress, fit_network

F64 = NDArray[np.float64]


def val_split(
    dataset: Dataset, order: NDArray[np.intp], fraction: float, guard: int = GUARD_ROWS
) -> tuple[NDArray[np.intp], NDArray[np.intp], str]:
    """(fit rows, validation rows, group kind): whole sessions, presses or guarded time
    blocks held out (train/groups.py), never random rows."""
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
    with_gain_inputs(data, spec, rt, u)
    net_rows = fit_rows
    if spec.augment != "none":
        data, net_rows = augmented(dataset, p, rt, data, u, y_scale, fit_rows)
    data = gain_view(data, rt)
    if spec.model == "ridge":  # closed form, NumPy only
        from spectratac.train.ridge import fit_ridge

        weights, history, val_history, ridge = fit_ridge(spec, p, data, net_rows, val_rows, dataset)
    else:
        ridge = None
        weights, history, val_history = fit_network(spec, p, data, net_rows, val_rows, progress)
    rt.set_weights(weights)
    if p.heads.uncertainty and val_rows.size:
        rt.std_scale = _calibrate(rt, u[val_rows], y_all[val_rows], tv[val_rows])
    base = p.layout.base
    is_st = dataset.meta.get("kind") == "spectratac"
    dark = (
        [s * len(p.layout.channels) + 4 * k + 3 for s in range(p.layout.steps) for k in range(3)]
        if is_st
        else []
    )
    guard = Guard.fit(u[fit_rows, :base], y_fit, SATURATION if is_st else None, dark,
                      gain=spec.gain_jitter)  # fmt: skip
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
        "fit_rows": ranges(fit_rows),
        "val_rows": ranges(val_rows),
        "train_seconds": time.perf_counter() - t0,
        "history": history,
        "val_history": val_history,
        "std_scale": rt.std_scale.tolist(),
    }
    if ridge is not None:
        meta["ridge"] = ridge
    return Decoder(rt, p.layout, guard, meta)


def with_gain_inputs(data: dict[str, Any], spec: TrainSpec, rt: Runtime, u: F64) -> None:
    """With `spec.gain_jitter`, add the assembled inputs "u" (float32), which `augmented`
    extends with the symmetric copies; `gain_view` then turns them into the loop's view."""
    if spec.gain_jitter > 0:
        data["u"] = u.astype(np.float32)


def gain_view(data: dict[str, Any], rt: Runtime) -> dict[str, Any]:
    """`data` with its assembled inputs "u" replaced by their GainView (train/gain.py)."""
    if "u" not in data:
        return data
    from spectratac.train.gain import GainView

    out = {k: v for k, v in data.items() if k != "u"}
    out["gain"] = GainView(rt.with_dtype(np.float64), data["u"])
    return out


def augmented(
    dataset: Dataset,
    p: Plan,
    rt: Runtime,
    data: dict[str, Any],
    u: F64,
    y_scale: F64,
    fit_rows: NDArray[np.intp],
) -> tuple[dict[str, Any], NDArray[np.intp]]:
    """`data` with the training rows' symmetric copies appended (train/symmetry.py), and
    the training row indices extended to them. Normalisation stays that of the real rows."""
    from spectratac.train import symmetry

    symmetry.check_symmetric(
        dataset.input_names, sensor_config.normalise(dataset.meta.get("config"))
    )
    names = list(dataset.target_names)
    y_full = np.asarray(dataset.targets, np.float64)[fit_rows]
    extra: dict[str, list[Any]] = {k: [] for k in data}
    for turns, mirror in symmetry.transforms(p.spec.augment):
        y_t = symmetry.rotate_targets(y_full, names, turns, mirror)[:, p.reg_cols]
        ok = data["y_ok"][fit_rows] & np.all(np.isfinite(y_t), axis=1)
        u_t = symmetry.permute_assembled(u[fit_rows], turns, mirror)
        extra["z"].append(rt.with_dtype(np.float64).normalised(u_t))
        if "u" in extra:
            extra["u"].append(u_t.astype(np.float32))
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
