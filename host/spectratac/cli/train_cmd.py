"""`spectratac train`: train a decoder from dataset files and write a .stac model.

spectratac train data.npz [more.npz ...] -o model.stac [--recipe paper|best]
    [--features F] [--model M] [--targets Fz,region] [--context K] [--drift baseline]
    [--augment rotate+mirror] [--uncertainty] [--epochs N] [--batch-size B]
    [--seed S] [--holdout blocked|random] [--holdout-sessions 3,4,7]
    [--finetune BASE.stac]
    [--export onnx,c,...] [--json]

--recipe picks the starting point (the paper's recipe, or `TrainSpec.best()`); any other
option given replaces that one field. --holdout trains on the training rows of that split
only and records it in the model, so that `spectratac evaluate model.stac data.npz` scores
exactly the held-out rows; without it every row trains and the printed MAE is optimistic.
--holdout-sessions 3,4 (or 30-35) leaves whole sessions out of training and records them.

--finetune BASE.stac recalibrates a trained decoder for a new unit from a minute or two of that
unit's data (spectratac.decode.finetune): BASE's layout, features and targets are kept, its
weights are the start, and data of other inputs, LED configuration or targets is refused.
--epochs, --lr and --seed apply; the other recipe options are BASE's.

Files: SpectraTac dataset files (`spectratac dataset build`), or any sensor's CSV / column
.npz (host/spectratac/decode/DATA_FORMAT.md) with --inputs naming its channels.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

import numpy as np

from spectratac.cli.exit_codes import ExitCode
from spectratac.cli.options import add_output, column_names, refuse_overwrite

RECIPES = ("paper", "best")
# CLI option -> TrainSpec field, for the options that replace one field of the recipe.
SPEC_OPTIONS = {
    "model": "model",
    "context": "context",
    "drift": "drift",
    "augment": "augment",
    "loss": "loss",
    "epochs": "epochs",
    "batch_size": "batch_size",
    "lr": "lr",
    "hidden": "hidden",
    "blocks": "blocks",
    "val_fraction": "val_fraction",
    "seed": "seed",
    "threads": "threads",
}
EXPORT_SUFFIX = {"onnx": ".onnx", "numpy": ".runtime.npz", "torchscript": ".pt", "c": ".h"}


def register(subparsers: Any) -> None:
    from spectratac.decode.spec import AUGMENTS, DRIFT, FEATURES, LOSSES, MODELS
    from spectratac.evaluate.splits import KINDS as SPLIT_KINDS

    p = subparsers.add_parser("train", help="train a decoder: dataset files -> model.stac")
    p.add_argument("data", nargs="+", help="dataset .npz files, or CSV / column .npz files")
    add_output(p, required=True, help="model file to write (.stac)", renamed_from=("--out",))
    p.add_argument("--recipe", choices=RECIPES, default="paper", help="starting spec")
    p.add_argument("--features", choices=FEATURES, help="default: paper33, or generic")
    p.add_argument("--model", choices=MODELS)
    p.add_argument("--targets", help="comma list, e.g. Fz,region (default: all + region)")
    p.add_argument("--inputs", help="input channel columns of CSV / generic data, in order")
    p.add_argument("--classes", help="class column of CSV / generic data (default: auto; '' none)")
    p.add_argument("--context", type=int, help="past samples fed as context")
    p.add_argument("--dilated", action="store_true", help="context lags 1, 2, 4, ... samples")
    p.add_argument("--ema", help="moving-average context time constants in samples, e.g. 10,40")
    p.add_argument("--drift", choices=DRIFT)
    p.add_argument(
        "--augment", choices=AUGMENTS, help="train on rotated (and mirrored) presses too"
    )
    p.add_argument("--uncertainty", action="store_true", help="calibrated per-target std")
    p.add_argument("--loss", choices=LOSSES)
    p.add_argument("--epochs", type=int)
    p.add_argument("--batch-size", type=int)
    p.add_argument("--lr", type=float)
    p.add_argument("--hidden", type=int)
    p.add_argument("--blocks", type=int)
    p.add_argument("--val-fraction", type=float)
    p.add_argument("--seed", type=int)
    p.add_argument("--threads", type=int)
    p.add_argument("--holdout", choices=SPLIT_KINDS, help="train on this split's training rows")
    p.add_argument("--split-seed", type=int, default=0, help="seed of the --holdout split")
    p.add_argument(
        "--holdout-sessions",
        metavar="IDS",
        help="leave these sessions out of training (e.g. 3,4,7 or 30-35); recorded in the model",
    )
    p.add_argument("--finetune", metavar="BASE.stac", help="recalibrate BASE on this data")
    p.add_argument("--export", help="also write these formats: onnx,numpy,torchscript,c")
    p.add_argument("--json", action="store_true", help="print one JSON summary")
    p.add_argument("--no-progress", action="store_true")
    p.set_defaults(func=_train)


def _train(args: argparse.Namespace) -> int:
    from spectratac.dataset.generic_io import load_data
    from spectratac.decode import DecoderError, TrainSpec, train
    from spectratac.decode.export import FORMATS

    exports = column_names(args.export) or []
    unknown = [f for f in exports if f not in FORMATS]
    if unknown:
        raise DecoderError(f"--export {','.join(unknown)}: choose from {', '.join(FORMATS)}")
    out = Path(args.output)
    refuse_overwrite(
        [out, *(out.with_name(out.name.removesuffix(".stac") + EXPORT_SUFFIX[f]) for f in exports)],
        args.force,
    )
    targets = column_names(args.targets)
    classes = None if args.classes is None else (column_names(args.classes) or [])
    ds = load_data(args.data, column_names(args.inputs), targets, classes)
    if targets is None:
        targets = list(ds.target_names)
        if np.any(ds.region > 0):
            targets.append(ds.meta.get("region_name", "region"))
    features = args.features or ("paper33" if ds.meta.get("kind") == "spectratac" else "generic")
    changes: dict[str, Any] = {"features": features, "targets": tuple(targets)}
    changes.update(
        {f: getattr(args, o) for o, f in SPEC_OPTIONS.items() if getattr(args, o) is not None}
    )
    if args.dilated:
        changes["context_dilated"] = True
    if args.ema:
        changes["context_ema"] = tuple(float(v) for v in column_names(args.ema) or ())
    if args.uncertainty:
        changes["uncertainty"] = True
    spec = getattr(TrainSpec, args.recipe)(**changes)
    rows, split, held = None, None, None
    if args.holdout and args.holdout_sessions:
        raise DecoderError("give --holdout or --holdout-sessions, not both")
    if args.holdout_sessions:
        from spectratac.evaluate.holdout import parse_sessions, session_rows

        held = parse_sessions(args.holdout_sessions)
        rows = np.setdiff1d(np.arange(ds.n), session_rows(ds, held))
        if rows.size == 0:
            raise DecoderError(f"--holdout-sessions {args.holdout_sessions} leaves no training row")
    if args.holdout:
        from spectratac.evaluate.splits import SplitSpec, split_dataset

        split = split_dataset(ds, SplitSpec(args.holdout, seed=args.split_seed))
        rows = split.train
    if args.finetune:
        dec = _finetune(args, ds, rows)
    else:
        dec = train(ds, spec, rows=rows, progress=not args.no_progress)
    if split is not None:
        from spectratac.evaluate.holdout import mark

        mark(dec, ds, split)
    if held is not None:
        from spectratac.evaluate.holdout import mark_sessions

        mark_sessions(dec, ds, held)
    dec.save(out)
    written = {"model": str(out)}
    for fmt in exports:
        path = out.with_name(out.name.removesuffix(".stac") + EXPORT_SUFFIX[fmt])
        written[fmt] = str(dec.export(fmt, path))
    test = split.test if split is not None else None
    if held is not None:
        test = np.setdiff1d(np.arange(ds.n), rows)
    summary = _summary(dec, ds, written, test)
    if args.json:
        print(json.dumps(summary))
    else:
        print(_human(summary))
    return ExitCode.OK


def _finetune(args: argparse.Namespace, ds: Any, rows: Any) -> Any:
    """BASE recalibrated on `rows` of `ds`, with its file's name in `finetuned_from`."""
    from spectratac.decode import Decoder
    from spectratac.decode.finetune import finetune

    dec = finetune(
        Decoder.load(args.finetune),
        ds,
        rows,
        epochs=args.epochs,
        lr=args.lr,
        seed=args.seed or 0,
        targets=column_names(args.targets),
        progress=not args.no_progress,
    )
    dec.meta["finetuned_from"]["path"] = str(args.finetune)
    return dec


def _summary(dec: Any, ds: Any, written: dict[str, str], test: Any = None) -> dict[str, Any]:
    """Training summary with the MAE on the held-out rows `test`, or on every row (training
    rows included: optimistic) when there is no holdout."""
    rows = np.arange(ds.n) if test is None else np.asarray(test)
    est = dec.predict(ds, rows)
    names = list(ds.target_names)
    fit: dict[str, float] = {}
    for i, t in enumerate(dec.target_names):
        y = ds.targets[rows, names.index(t)]
        ok = ~est.invalid & ds.target_valid[rows]
        fit[t] = float(np.mean(np.abs(est.targets[ok, i] - y[ok]))) if ok.any() else float("nan")
    region = ds.region[rows]
    lab = region > 0
    acc = float(np.mean(est.region[lab] == region[lab])) if dec.heads.n_classes else None
    m = dec.meta
    held = m.get("holdout")
    return {
        "mae_rows": "held-out" if test is not None else "all (training rows included)",
        "holdout": (held.get("split") or {"kind": "sessions", **held["sessions"]})
        if held
        else None,
        "n_test": int(rows.size) if test is not None else 0,
        "written": written,
        "spec": m["spec"],
        "n_train": m["n_train"],
        "train_seconds": round(m["train_seconds"], 2),
        "final_loss": m["history"][-1] if m["history"] else float("nan"),
        "params": dec.n_params,
        "flops_per_sample": dec.flops_per_sample,
        "mae": fit,
        "class_accuracy": acc,
        "unit_id": dec.unit_id,
        "finetuned_from": m.get("finetuned_from"),
    }


def _human(s: dict[str, Any]) -> str:
    spec = s["spec"]
    ft = s.get("finetuned_from")
    lines = (
        []
        if not ft
        else [
            f"fine-tuned {ft.get('path', ft['id'])} (unit {ft['unit_id']}, mode {ft['mode']}, "
            f"{'early stopping on held-out presses' if ft['early_stopping'] else 'fixed epochs'})"
        ]
    )
    epochs = ft["epochs"] if ft else spec["epochs"]
    lines += [
        f"trained {spec['model']} on {spec['features']} features "
        f"(context {spec['context']}, drift {spec['drift']}) for {', '.join(spec['targets'])}",
        f"  {s['n_train']} rows, {epochs} epochs in {s['train_seconds']:.1f} s; "
        f"final loss {s['final_loss']:.4f}; {s['params']:,} parameters, "
        f"{s['flops_per_sample']:,} FLOPs per sample",
    ]
    if s["holdout"]:
        what = (
            "rows of the held-out sessions"
            if s["holdout"]["kind"] == "sessions"
            else f"held-out rows of the {s['holdout']['kind']} split"
        )
        lines.append(
            f"  MAE on the {s['n_test']} {what} (`spectratac evaluate` for the full report):"
        )
    else:
        lines.append(
            "  MAE on every row, training rows included (optimistic; train with --holdout "
            "blocked for held-out numbers):"
        )
    for t, v in s["mae"].items():
        lines.append(f"    {t:<8} {v:.4g}")
    if s["class_accuracy"] is not None:
        lines.append(f"    classes  {100 * s['class_accuracy']:.2f} % correct")
    for kind, path in s["written"].items():
        lines.append(f"  wrote {kind}: {path}")
    return "\n".join(lines)
