"""`spectratac train`: train a decoder from dataset files and write a .stac model.

spectratac train data.npz [more.npz ...] -o model.stac [--recipe paper|best|auto]
    [--budget 5m] [--ray ADDRESS] [--workers N]
    [--features F] [--model M] [--degree D] [--targets Fz,region] [--context K] [--drift baseline]
    [--augment rotate+mirror] [--uncertainty] [--gain-jitter G] [--skip]
    [--epochs N] [--batch-size B]
    [--seed S] [--holdout blocked|random] [--holdout-sessions 3,4,7]
    [--finetune BASE.stac]
    [--export onnx,c,...] [--json]

--recipe picks the starting point (the paper's recipe, or `TrainSpec.best()`); any other
option given replaces that one field. --holdout trains on the training rows of that split
only and records it in the model, so that `spectratac evaluate model.stac data.npz` scores
exactly the held-out rows; without it every row trains the model.

The work is `spectratac.train.fit`'s; this verb parses the options, writes the files and
prints the result. Training error and held-out error are always printed side by side (and in
--json: train_mae, heldout_mae, heldout_worst, forward, expected_mae, gap, warning), with the
worst held-out group beside the mean and, with 3 or more sessions, forward chaining (trained
on earlier sessions, scored on later ones), whose mean is printed as the MAE to expect on a
new session, its worst session beside it. Held out are whole groups (sessions, else presses,
else guarded time blocks: train/groups.py): the --holdout split's test rows, else the
model's own validation groups (--val-fraction), else those of a check model trained on the
other 80 % of the groups. When the held-out error exceeds the training error by more than
2x (train/check.py) a warning goes to stderr and into the JSON.

--recipe auto searches linear and polynomial ridge, MLPs and ResMLPs with and without
temporal context, drift baseline and regularisation by grouped K-fold cross-validation
within --budget (e.g. 300, 90s, 5m, 1h; the final refit included; counted in units of work
at the reference machine's rate, so a busy machine takes longer but chooses the same), on
--workers local
processes or on the Ray cluster at --ray ADDRESS, keeps the cheapest model within one
standard error of the best and prints every candidate's CV error and inference cost
(train/auto_recipe).

--holdout-sessions 3,4 (or 30-35) leaves whole sessions out of training and records them.

--finetune BASE.stac --gain-only fits one output gain per target and no weight: the
recalibration 30 s of a later session of the same skin can teach (its response drifts by a
factor).

--finetune BASE.stac recalibrates a trained decoder for a new unit from a minute or two of that
unit's data (spectratac.train.finetune): BASE's layout, features and targets are kept, its
weights are the start, and data of other inputs, LED configuration or targets is refused.
--epochs, --lr and --seed apply; the other recipe options are BASE's. On data without force
targets (a guided session recorded without --ft) it adapts what region labels teach: the region
head, the guard, the rest signature (spectratac.train.unlabelled), and says what it could not.

Files: SpectraTac dataset files (`spectratac dataset build`), or any sensor's CSV / column
.npz (host/spectratac/decode/DATA_FORMAT.md) with --inputs naming its channels.
"""

from __future__ import annotations

import argparse
import json
import re
import sys
from pathlib import Path
from typing import Any

from spectratac.cli.exit_codes import ExitCode, UsageError
from spectratac.cli.options import add_output, column_names, refuse_overwrite
from spectratac.cli.outputs import (
    Kind,
    is_c_header,
    is_npz,
    is_onnx,
    is_stac,
    is_torchscript,
    new_file,
)

RECIPES = ("paper", "best", "auto")
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
    "degree": "degree",
    "seed": "seed",
    "threads": "threads",
    "gain_jitter": "gain_jitter",
}
EXPORT_SUFFIX = {"onnx": ".onnx", "numpy": ".runtime.npz", "torchscript": ".pt", "c": ".h"}
#: What each export is, so that --force replaces only an export (cli/outputs.py)
EXPORT_KIND: dict[str, Kind] = {
    "onnx": is_onnx, "numpy": is_npz, "torchscript": is_torchscript, "c": is_c_header,
}  # fmt: skip


def _export_path(out: Path, fmt: str) -> Path:
    """The file `--export fmt` writes beside the model `out`."""
    return out.with_name(out.name.removesuffix(".stac") + EXPORT_SUFFIX[fmt])


def register(subparsers: Any) -> None:
    from spectratac.train.groups import KINDS as SPLIT_KINDS
    from spectratac.train.spec import AUGMENTS, DRIFT, FEATURES, LOSSES, MODELS

    p = subparsers.add_parser("train", help="train a decoder: dataset files -> model.stac")
    p.add_argument("data", nargs="+", help="dataset .npz files, or CSV / column .npz files")
    add_output(p, required=True, help="model file to write (.stac)")
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
    p.add_argument(
        "--gain-jitter", type=float, metavar="G",
        help="scale each training row's inputs by a factor in [1-G, 1+G] (best: 0.15)",
    )  # fmt: skip
    p.add_argument(
        "--skip", action="store_true",
        help="a linear path beside the network: forces beyond the training range extrapolate "
        "(not in the on-device model image)",
    )  # fmt: skip
    p.add_argument("--loss", choices=LOSSES)
    p.add_argument("--epochs", type=int)
    p.add_argument("--batch-size", type=int)
    p.add_argument("--lr", type=float)
    p.add_argument("--hidden", type=int)
    p.add_argument("--blocks", type=int)
    p.add_argument("--val-fraction", type=float)
    p.add_argument("--degree", type=int, help="--model ridge: polynomial degree 1-3")
    p.add_argument("--seed", type=int)
    p.add_argument(
        "--threads",
        type=int,
        help="torch threads (default: the thread policy, SPECTRATAC_THREADS; THREADS.md)",
    )
    p.add_argument("--holdout", choices=SPLIT_KINDS, help="train on this split's training rows")
    p.add_argument("--split-seed", type=int, default=0, help="seed of the --holdout split")
    p.add_argument(
        "--budget",
        type=parse_duration,
        default=300.0,
        help="--recipe auto: budget in nominal seconds of work, e.g. 300, 90s, 5m (default 5m)",
    )
    p.add_argument(
        "--ray",
        metavar="ADDRESS",
        help="--recipe auto: run trials on this Ray cluster (host:port, auto, local)",
    )
    p.add_argument("--workers", type=int, help="--recipe auto: parallel local trials (cores)")
    p.add_argument(
        "--holdout-sessions",
        metavar="IDS",
        help="leave these sessions out of training (e.g. 3,4,7 or 30-35); recorded in the model",
    )
    p.add_argument("--finetune", metavar="BASE.stac", help="recalibrate BASE on this data")
    p.add_argument(
        "--gain-only", action="store_true",
        help="--finetune: one output gain per target, no weight (30 s of a later session)",
    )  # fmt: skip
    p.add_argument("--export", help="also write these formats: onnx,numpy,torchscript,c")
    p.add_argument("--json", action="store_true", help="print one JSON summary")
    p.add_argument("--no-progress", action="store_true")
    p.set_defaults(func=_train)


def _train(args: argparse.Namespace) -> int:
    from spectratac.cli.eta import ClockBar, announce
    from spectratac.dataset.generic_io import load_data
    from spectratac.decode import DecoderError
    from spectratac.decode.export import FORMATS
    from spectratac.train import FinetuneOptions, SplitSpec, TrainSpec, fit
    from spectratac.train.finetune import DEFAULT_MODE
    from spectratac.train.plan import default_features, default_targets
    from spectratac.train.unlabelled import has_force_targets

    exports = column_names(args.export) or []
    unknown = [f for f in exports if f not in FORMATS]
    if unknown:
        raise DecoderError(f"--export {','.join(unknown)}: choose from {', '.join(FORMATS)}")
    out = Path(args.output)
    inputs = [*args.data, args.finetune]
    refuse_overwrite(out, args.force, verb="train", inputs=inputs, kind=is_stac)
    for fmt in exports:  # --force replaces only an export of the same kind
        refuse_overwrite(_export_path(out, fmt), args.force, verb="train", inputs=inputs,
                         kind=EXPORT_KIND[fmt])  # fmt: skip
    given = column_names(args.targets)
    classes = None if args.classes is None else (column_names(args.classes) or [])
    ds = load_data(args.data, column_names(args.inputs), given, classes)
    if args.holdout and args.holdout_sessions:
        raise DecoderError("give --holdout or --holdout-sessions, not both")
    if args.gain_only and not args.finetune:
        raise UsageError("--gain-only recalibrates a trained model: give --finetune BASE.stac")
    if args.gain_only and not has_force_targets(ds):
        raise UsageError(
            f"--gain-only fits the force gain to reference F/T targets, and {args.data} has "
            "none (a guided session without --ft): leave --gain-only out to adapt regions "
            "and guard from its labels"
        )
    if args.finetune and not has_force_targets(ds) and not exports:
        from spectratac.cli import train_unlabelled  # a guided session without a reference

        return train_unlabelled.run(args, ds, out)
    targets = tuple(given) if given is not None else default_targets(ds)
    features = args.features or default_features(ds)
    spec, tune = None, None
    if args.finetune:
        tune = FinetuneOptions(
            mode="gain" if args.gain_only else DEFAULT_MODE,
            epochs=args.epochs,
            lr=args.lr,
            seed=args.seed or 0,
            targets=None if given is None else tuple(given),
        )
    elif args.recipe == "auto":
        spec = TrainSpec.paper(features=features, targets=targets)
    else:
        spec = getattr(TrainSpec, args.recipe)(**_changes(args, features, targets))

    def say(line: str) -> None:
        if not args.no_progress:
            print(f"  {line}", file=sys.stderr)

    auto = args.recipe == "auto" and not args.finetune
    estimate = _estimate(ds, spec, auto, args)
    if estimate is not None and not args.json:
        announce("train", estimate)
    with ClockBar(
        estimate.total_s if estimate else 0.0,
        "searching",
        enabled=auto and estimate is not None and not args.no_progress,
    ):
        trained = fit(
            ds,
            spec,
            holdout=SplitSpec(args.holdout, seed=args.split_seed) if args.holdout else None,
            holdout_sessions=args.holdout_sessions,
            finetune_from=args.finetune,
            finetune_options=tune,
            budget=args.budget if auto else None,
            workers=args.workers,
            ray_address=args.ray,
            progress=not args.no_progress,
            log=say,
        )
    if trained.search is not None and not args.json:
        print(trained.search.text())
    dec = trained.decoder
    with new_file(out) as tmp:
        dec.save(tmp)
    written = {"model": str(out)}
    for fmt in exports:
        path = _export_path(out, fmt)
        with new_file(path) as tmp:
            dec.export(fmt, tmp)
        written[fmt] = str(path)
    summary = trained.report(written)
    if estimate is not None:
        summary["estimate"] = estimate.as_dict()
    check = trained.check
    if check.warning:
        print(f"warning: {check.warning}: the model fits what is particular to its "
              f"training {check.heldout_groups}s; expect the held-out error on new data "
              f"(try --recipe auto, --drift baseline, or more {check.heldout_groups}s)",
              file=sys.stderr)  # fmt: skip
    if args.json:
        print(json.dumps(summary))
    else:
        print(_human(summary))
    return ExitCode.OK


def _estimate(ds: Any, spec: Any, auto: bool, args: argparse.Namespace) -> Any:
    """How long this training will take: the auto recipe's --budget of nominal work (the
    search keeps to it, its forward folds and the final refit included) at the rate this
    machine gives now; a recipe's fit and its check's models (held-out and forward folds) at
    rates probed on the dataset's first rows; None for a fine-tune (its epochs stop early on
    held-out presses)."""
    from spectratac.apps.estimates import auto_estimate, training_estimate
    from spectratac.errors import SpectraTacError
    from spectratac.train.check import (
        check_predictions_for_options,
        check_recipe_for_options,
        check_rows_for_options,
    )

    if auto:
        return auto_estimate(args.budget, ds, args.workers)
    if spec is None or spec.model == "ridge":
        return None
    try:
        return training_estimate(
            ds,
            spec,
            check_rows=check_rows_for_options(ds, spec, args.holdout, args.holdout_sessions),
            predictions=check_predictions_for_options(ds, args.holdout, args.holdout_sessions),
            check_spec=check_recipe_for_options(ds, spec, args.holdout, args.holdout_sessions),
        )
    except SpectraTacError as exc:  # the probe's few rows did not suit the recipe: train anyway
        print(f"note: no time estimate ({exc})", file=sys.stderr)
        return None


def _changes(args: argparse.Namespace, features: str, targets: tuple[str, ...]) -> dict[str, Any]:
    """The TrainSpec fields the options replace in the recipe."""
    changes: dict[str, Any] = {"features": features, "targets": targets}
    changes.update(
        {f: getattr(args, o) for o, f in SPEC_OPTIONS.items() if getattr(args, o) is not None}
    )
    if args.dilated:
        changes["context_dilated"] = True
    if args.ema:
        changes["context_ema"] = tuple(float(v) for v in column_names(args.ema) or ())
    if args.uncertainty:
        changes["uncertainty"] = True
    if args.skip:
        changes["skip"] = True
    return changes


def parse_duration(text: str) -> float:
    """Seconds of "300", "90s", "5m", "1.5h".

    >>> parse_duration("5m"), parse_duration("90s"), parse_duration("300")
    (300.0, 90.0, 300.0)
    """
    m = re.fullmatch(r"\s*([0-9]*\.?[0-9]+)\s*([smh]?)\s*", text)
    if not m or float(m.group(1)) <= 0:
        raise argparse.ArgumentTypeError(f"{text!r}: give a duration like 300, 90s, 5m or 1h")
    return float(m.group(1)) * {"": 1, "s": 1, "m": 60, "h": 3600}[m.group(2)]


def _human(s: dict[str, Any]) -> str:
    from spectratac.train.check import plural

    spec = s["spec"]
    ft = s.get("finetuned_from")
    lines = (
        []
        if not ft
        else [
            f"fine-tuned {ft.get('path', ft['id'])} (unit {ft['unit_id']}, mode {ft['mode']}, "
            f"held-out {plural(ft.get('val_groups', 'group'))}: early stopping and the check "
            "against the base)"
        ]
    )
    if ft and ft.get("kept") == "gain" and not ft["val_mae_scaled"]:
        lines.append("  recalibrated by one output gain per target (too few presses to check)")
    elif ft and ft.get("kept") == "gain":
        sc = ft["val_mae_scaled"]
        beat = "the base" if ft["mode"] == "gain" else "the fine-tuned layers and the base"
        lines.append(
            f"  recalibrated by one output gain per target: it beat {beat} on the held-out "
            f"{plural(ft.get('val_groups', 'group'))} (scaled MAE {sc['gain']:.4g} against "
            f"base {sc['base']:.4g})"
        )
    if ft and ft.get("kept") == "base":
        lines.append(
            f"  kept the base as it was: fine-tuning did worse on the held-out "
            f"{plural(ft.get('val_groups', 'group'))} "
            f"(scaled MAE {min(v for k, v in ft['val_mae_scaled'].items() if k != 'base'):.4g} "
            f"against {ft['val_mae_scaled']['base']:.4g}); more data of the new unit may help"
        )
    epochs = ft["epochs"] if ft else spec["epochs"]
    # ridge is solved in closed form: no epochs to report
    how = "closed form" if spec["model"] == "ridge" and not ft else f"{epochs} epochs"
    lines += [
        f"trained {spec['model']} on {spec['features']} features "
        f"(context {spec['context']}, drift {spec['drift']}) for {', '.join(spec['targets'])}",
        f"  {s['n_train']} rows, {how} in {s['train_seconds']:.1f} s; "
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
    lines.append(
        f"  training against held-out groups: {s['heldout_groups']} ({s['heldout_source']}, "
        f"{s['n_heldout']} rows):"
    )
    for t, v in s["heldout_mae"].items():
        tr = s["train_mae"].get(t, float("nan"))
        ratio = v / tr if tr > 0 else float("nan")
        lines.append(f"    {t:<8} training {tr:.4g}  held-out {v:.4g}  ({ratio:.1f}x)")
    if s.get("heldout_worst"):
        cells = "  ".join(f"{t} {v:.4g}" for t, v in s["heldout_worst"].items())
        lines.append(
            f"    worst held-out {s['heldout_groups']} ({s['heldout_worst_group']}): {cells}"
        )
    fwd = s.get("forward")
    if fwd:
        lines.append(
            f"  forward in time (trained on earlier sessions, scored on sessions "
            f"{', '.join(map(str, fwd['sessions']))}): "
            f"{'figure' if fwd.get('horizon', 1) > 1 else 'recent-weighted mean'} / worst "
            f"(session {fwd['worst_session']})"
        )
        for t, v in fwd["mean_mae"].items():
            lines.append(f"    {t:<8} {v:.4g} / {fwd['worst_mae'].get(t, float('nan')):.4g}")
    if s.get("expected_text"):
        lines.append("  " + s["expected_text"].replace("\n", "\n  "))
    if s["warning"]:
        lines.append(f"  WARNING: {s['warning']}")
    if s["class_accuracy"] is not None:
        lines.append(f"    classes  {100 * s['class_accuracy']:.2f} % correct")
    for kind, path in s["written"].items():
        lines.append(f"  wrote {kind}: {path}")
    return "\n".join(lines)
