"""Does the figure every recipe prints hold on a skin that ages, and does `train`'s time
estimate hold?

On the ageing skin (`spectratac.sim.ageing_skin`: one unit, `--sessions` sessions, a press
response that weakens session after session, re-mountings now and then), each recipe (the
paper's, `best()` without the rotation augmentation the 4-channel skin cannot have, and the
auto recipe) is trained with `spectratac.train.fit` on the first `--train` sessions. Two
figures per recipe:

- forward figure: the MAE `train` prints to expect on your next sessions
  (`HeldOutCheck.expected`) against the MAE then measured on the sessions that follow
  (target: within 1.5x, and never beaten by 2x);
- estimate to wall: the time estimate `train` prints (the fit, the held-out check and the
  forward folds; for auto, its budget at this machine's measured rate) against the wall
  seconds `fit` took, quiet and (`--busy 2`) beside two busy loops (target: within 1.5x).

Beside them, for the zero-shot question (issue 35 item 3): the recipe's MAE on the next
sessions, and the 30-s recalibration of its model on each next session (gain-only and
fine-tuned), scored on the rest of that session.

    python -m tools.bench.forward_figure [--sessions 36] [--train 28] [--session-s 20]
        [--seed 0] [--recipes paper,best,auto] [--budget 120] [--epochs N] [--busy 2]
        [--busy-only] [--no-recal] [--json]

`--recipes` may also name the variants of the paper's recipe in VARIANTS (drift baseline,
gain jitter): their MAE on the next sessions is the zero-shot comparison.
"""

from __future__ import annotations

import argparse
import time
from typing import Any

import numpy as np
from spectratac.apps.estimates import auto_estimate, training_estimate
from spectratac.dataset import Dataset
from spectratac.sim.ageing_skin import ageing_skin
from spectratac.train import FinetuneOptions, TrainSpec, fit
from spectratac.train.check import (
    check_predictions_for_options,
    check_recipe_for_options,
    check_rows_for_options,
)
from spectratac.train.metrics import decoder_mae

from tools.bench.benchlib import Figure, busy_loops, load_label, loadavg, parser, report

TARGET = 1.5
RECAL_S = 30.0


#: What zero-shot robustness each option buys (issue 35 item 3), beside the recipes.
VARIANTS: dict[str, dict[str, Any]] = {
    "paper+drift": {"drift": "baseline"},
    "paper+jitter": {"gain_jitter": 0.3},
    "paper+drift+jitter": {"drift": "baseline", "gain_jitter": 0.3},
}


def spec_of(recipe: str, epochs: int | None) -> TrainSpec:
    base: dict[str, Any] = {"features": "generic", "targets": ("Fz",)}
    if epochs:
        base["epochs"] = epochs
    if recipe == "best":
        return TrainSpec.best(augment="none", **base)
    return TrainSpec.paper(**base, **VARIANTS.get(recipe, {}))


def run_recipe(
    ds: Dataset, train_ds: Dataset, recipe: str, args: argparse.Namespace, load: str
) -> list[Figure]:
    ses = np.asarray(ds.session, np.int64)
    later = np.flatnonzero(ses >= args.train)
    spec = spec_of(recipe, args.epochs)
    if recipe == "auto":
        estimate = auto_estimate(args.budget, train_ds, workers=args.workers).total_s
    else:
        estimate = training_estimate(
            train_ds,
            spec,
            check_rows=check_rows_for_options(train_ds, spec, None, None),
            predictions=check_predictions_for_options(train_ds, None, None),
            check_spec=check_recipe_for_options(train_ds, spec, None, None),
        ).total_s
    t0 = time.perf_counter()
    trained = fit(
        train_ds,
        None if recipe == "auto" else spec,
        budget=args.budget if recipe == "auto" else None,
        workers=args.workers,
        progress=False,
    )
    wall = time.perf_counter() - t0
    printed = trained.check.expected()[0]["Fz"]
    fwd = trained.check.forward
    truth = decoder_mae(trained.decoder, ds, later)["Fz"]
    per = {
        int(k): decoder_mae(trained.decoder, ds, np.flatnonzero(ses == k))["Fz"]
        for k in range(args.train, int(ses.max()) + 1)
    }
    extra: dict[str, Any] = {
        "load": load,
        "loadavg": loadavg(),
        "recipe": recipe,
        "expected_text": trained.check.expected_text(),
        "next_sessions_mae": per,
        "forward_folds": fwd.folds if fwd else None,
        "model_train_mae": fwd.model_train_mae if fwd else None,
        "range": trained.check.expected_range(),
        "range_holds": holds(trained.check.expected_range().get("Fz"), truth),
        "remounted_seen": fwd.remounted if fwd else None,
        "chosen": trained.search.report["chosen"] if trained.search else None,
    }
    figs = [
        Figure(f"forward figure: {recipe} ({load})", printed, "N MAE",
               f"MAE on the next {len(per)} sessions", truth, printed / truth, extra),
        Figure(f"estimate to wall: {recipe} ({load})", estimate, "s",
               "wall seconds of fit", wall, estimate / wall, {"load": load}),
    ]  # fmt: skip
    if recipe != "auto" and args.recal:
        figs += recalibration(ds, trained.decoder, args, recipe, load)
    return figs


def holds(span: list[float] | None, truth: float) -> bool:
    """Whether the printed range holds the next sessions' error."""
    return span is not None and span[0] <= truth <= span[1]


def recalibration(
    ds: Dataset, base: Any, args: argparse.Namespace, recipe: str, load: str
) -> list[Figure]:
    """Each next session, recorded for RECAL_S + 30 s (the same drift: `ageing_skin` draws it
    apart from the presses), recalibrates `base` on its first RECAL_S seconds; scored on the
    rest of it, against the base on the same rows (means over the next sessions)."""
    long = ageing_skin(args.sessions, RECAL_S + 30.0, args.seed)
    ses = np.asarray(long.session, np.int64)
    t = np.asarray(long.t_end, np.float64)
    base_mae, tuned = [], {"gain": [], "first": []}
    kept: dict[str, list[str]] = {"gain": [], "first": []}
    for k in range(args.train, args.sessions):
        rows = np.flatnonzero(ses == k)
        since = t[rows] - t[rows[0]]
        cal, rest = rows[since < RECAL_S], rows[since >= RECAL_S]
        base_mae.append(decoder_mae(base, long, rest)["Fz"])
        for mode in tuned:
            dec = fit(
                long.subset(cal), finetune_from=base, finetune_options=FinetuneOptions(mode=mode),
                progress=False,
            ).decoder  # fmt: skip
            tuned[mode].append(decoder_mae(dec, long, rest)["Fz"])
            kept[mode].append(str(dec.meta["finetuned_from"]["kept"]))
    b = float(np.mean(base_mae))
    return [
        Figure(f"recalibrated {mode}: {recipe} ({load})", float(np.mean(v)), "N MAE",
               "base on the same rows", b, float(np.mean(v)) / b,
               {"kept": kept[mode], "per_session": v, "base_per_session": base_mae})
        for mode, v in tuned.items()
    ]  # fmt: skip


def main() -> None:
    p = parser(__doc__ or "", busy=True)
    p.add_argument("--sessions", type=int, default=36)
    p.add_argument("--train", type=int, default=28)
    p.add_argument("--session-s", type=float, default=20.0)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--recipes", default="paper,best,auto")
    p.add_argument("--budget", type=float, default=120.0)
    p.add_argument("--epochs", type=int, default=None)
    p.add_argument("--workers", type=int, default=None)
    p.add_argument("--no-recal", dest="recal", action="store_false")
    p.add_argument("--busy-only", action="store_true", help="with --busy N: not quiet first")
    args = p.parse_args()
    ds = ageing_skin(args.sessions, args.session_s, args.seed)
    ses = np.asarray(ds.session, np.int64)
    train_ds = ds.subset(np.flatnonzero(ses < args.train))
    figs: list[Figure] = []
    for busy in [args.busy] if args.busy_only and args.busy else sorted({0, args.busy}):
        with busy_loops(busy):
            for recipe in args.recipes.split(","):
                figs += run_recipe(ds, train_ds, recipe, args, load_label(busy))
    within = [f for f in figs if f.name.startswith(("forward figure", "estimate to wall"))]
    ok = sum(1 / TARGET <= f.ratio <= TARGET for f in within)
    figs.append(Figure(f"share within {TARGET}x: forward figure and estimate", ok / len(within),
                       "share", "figures", float(len(within)), ok / len(within)))  # fmt: skip
    fwd = [f for f in figs if f.name.startswith("forward figure")]
    held = sum(bool(f.extra.get("range_holds")) for f in fwd)
    figs.append(Figure("share of printed ranges holding the next sessions' error", held / len(fwd),
                       "share", "forward figures", float(len(fwd)), held / len(fwd)))  # fmt: skip
    report(figs, args.json)


if __name__ == "__main__":
    main()
