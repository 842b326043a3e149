"""Beyond the paper, measured side by side with the paper's recipe: the same dataset, the
same splits, the same training budget, one change at a time, then the combination.

Each variant is `TrainSpec.paper(**changes)`; every variant is trained on each split's
training rows and scored on its test rows (`evaluate.fit_both_splits.fit_and_evaluate`). The
table reports MAE per force axis with the change in % against the paper's recipe, mean and
minimum R², region and contact accuracy, interval coverage (uncertainty), and inference cost
(flops per sample, and single-sample latency measured side by side).

The target: the best decoder has >= 25 % lower MAE than the paper's recipe on the
blocked split on every force axis, at no more than its inference cost (flops per sample).

>>> list(VARIANTS)[:3], VARIANTS["contact"]["targets"][-1]
(['paper', 'context', 'context-ema'], 'contact')
>>> target_check([{"name": "paper", "blocked": {"mae": {"Fx": 1.0}}, "flops": 10},
...               {"name": "x", "blocked": {"mae": {"Fx": 0.7}}, "flops": 9}], ["Fx"])["met"]
True
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from spectratac.dataset.schema import Dataset
from spectratac.evaluate.metrics import improvement
from spectratac.hardware.generated import vocabulary as vocab

FT6 = vocab.FT_AXES
FORCES = vocab.FORCE_AXES
TARGET_IMPROVEMENT_PCT = 25.0
COST_TOLERANCE = 0.02  # flops above the paper's still counted as "its inference cost"
REFERENCE = "paper"

# Temporal context: the elastomer creeps with time constants of ~0.5 s and ~8 s (twin
# MODEL.md), i.e. 10 and 160 samples at 20 Hz. Two forms: raw-input deltas at dilated lags
# 1, 2, 4, ..., 32 samples (reach 1.6 s), and deltas to moving averages at the creep time
# constants themselves.
CONTEXT = {"context": 6, "context_dilated": True}
CONTEXT_EMA = {"context_ema": (10.0, 160.0)}
# Training-only regularisation (free at inference): the blocked split shows that the
# paper's recipe is limited by generalising to unseen presses, not by fitting.
REGULARISED = {"dropout": 0.1, "input_noise": 0.1, "best_val": True}
VARIANTS: dict[str, dict[str, Any]] = {
    "paper": {},
    "context": dict(CONTEXT),
    "context-ema": dict(CONTEXT_EMA),
    "baseline": {"drift": "baseline"},
    "contact": {"targets": (*FT6, "region", "contact")},
    "uncertainty": {"uncertainty": True},
    "regularised": dict(REGULARISED),
    # The sensor's three-fold symmetry: every training press also rotated and mirrored.
    "symmetry": {"augment": "rotate+mirror"},
    # Everything at once, with the backbone narrowed (128 -> 116) so that the wider input
    # does not cost more flops per sample than the paper's recipe.
    "combined": {
        **CONTEXT,
        **REGULARISED,
        "drift": "baseline",
        "targets": (*FT6, "region", "contact"),
        "uncertainty": True,
        "hidden": 116,
    },
}


def best_changes() -> dict[str, Any]:
    """What the decoder's own `TrainSpec.best()` changes against the paper's recipe."""
    from spectratac.train import TrainSpec

    if not hasattr(TrainSpec, "best"):
        return {}
    paper, best = TrainSpec.paper().to_dict(), TrainSpec.best().to_dict()
    return {k: v for k, v in best.items() if v != paper.get(k)}


if best_changes():
    VARIANTS["best"] = best_changes()

DESCRIPTIONS = {
    "paper": "the paper's recipe (33 features, ResMLP 128x3, weighted L1 + masked CE)",
    "context": "temporal context: raw-input deltas at dilated lags 1..32 samples",
    "context-ema": "temporal context: deltas to input moving averages at 0.5 s and 8 s",
    "baseline": "drift compensation: inputs relative to a running no-contact baseline",
    "contact": "a contact/no-contact head (otherwise contact = |F| > 0.3 N)",
    "uncertainty": "a calibrated per-target standard deviation head",
    "regularised": "dropout 0.1, input noise 0.1, best validation epoch (training only)",
    "symmetry": "every training press also rotated by 120/240° and mirrored (training only)",
    "combined": "context + baseline + contact + uncertainty + regularised, ResMLP 116x3",
    "best": "the decoder's TrainSpec.best(): "
    + ", ".join(f"{k}={v}" for k, v in best_changes().items()),
}


def row_of(name: str, fit: Any, seconds: dict[str, float]) -> dict[str, Any]:
    """One table row (JSON-ready) from a `FitResult` of one variant."""
    row: dict[str, Any] = {"name": name, "description": DESCRIPTIONS.get(name, name)}
    for kind, sec in fit.sections.items():
        if sec.decoder is None:
            continue
        s = sec.decoder.scores
        comp = s["components"]
        r2 = [m["r2"] for m in comp.values() if np.isfinite(m["r2"])]
        d: dict[str, Any] = {
            "n_test": s["n"],
            "mae": {k: m["mae"] for k, m in comp.items()},
            "r2_mean": float(np.mean(r2)) if r2 else float("nan"),
            "r2_min": float(np.min(r2)) if r2 else float("nan"),
            "region_accuracy": s.get("region", {}).get("accuracy", float("nan")),
            "contact_accuracy": s.get("contact", {}).get("accuracy", float("nan")),
            "contact_source": s.get("contact", {}).get("source", ""),
            "n_unpredicted": s.get("n_unpredicted", 0),
            "train_s": seconds.get(kind, float("nan")),
        }
        if "coverage" in s:
            cov = s["coverage"]
            d["coverage"] = {
                lv: float(np.mean([c[lv] for c in cov.values() if c.get(lv) is not None]))
                for lv in ("0.68", "0.95")
            }
        row[kind] = d
    model = fit.models.get("blocked") or next(iter(fit.models.values()))
    row["flops"] = int(getattr(model, "flops_per_sample", 0))
    row["params"] = int(getattr(model, "n_params", 0))
    return row


def add_improvements(rows: list[dict[str, Any]], axes: Sequence[str] = FORCES) -> None:
    """Per split and axis: % MAE reduction against the reference (paper) row, in place."""
    ref = next((r for r in rows if r["name"] == REFERENCE), None)
    if ref is None:
        return
    for r in rows:
        for kind in ("random", "blocked"):
            if kind in r and kind in ref:
                r[kind]["improvement_pct"] = {
                    a: improvement(ref[kind]["mae"][a], r[kind]["mae"][a])
                    for a in axes
                    if a in r[kind]["mae"] and a in ref[kind]["mae"]
                }


def target_check(rows: list[dict[str, Any]], axes: Sequence[str] = FORCES) -> dict[str, Any]:
    """Is there a variant with >= 25 % lower blocked-split MAE on every force axis at no
    more inference cost than the paper's recipe? Cost: flops per sample, with COST_TOLERANCE
    (an extra output or input adds ~0.1-2 %, far below what a latency measurement resolves).
    Names the best candidate within the cost and the best overall, by worst-axis change."""
    ref = next((r for r in rows if r["name"] == REFERENCE), None)
    if ref is None or "blocked" not in ref:
        return {"met": False, "reason": "no paper-recipe row on the blocked split"}
    limit = ref["flops"] * (1.0 + COST_TOLERANCE)
    scored = []
    for r in rows:
        if r["name"] == REFERENCE or "blocked" not in r:
            continue
        imp = [improvement(ref["blocked"]["mae"][a], r["blocked"]["mae"][a]) for a in axes]
        worst = float(np.nanmin(imp)) if np.isfinite(imp).any() else -np.inf
        scored.append((worst, r, dict(zip(axes, imp, strict=True))))
    if not scored:
        return {"met": False, "reason": "no variant besides the paper's recipe"}
    within = [s for s in scored if s[1]["flops"] <= limit]
    best_all = max(scored, key=lambda s: s[0])
    best = max(within, key=lambda s: s[0]) if within else None
    met = best is not None and best[0] >= TARGET_IMPROVEMENT_PCT
    out: dict[str, Any] = {
        "met": bool(met),
        "target_pct": TARGET_IMPROVEMENT_PCT,
        "paper_flops": ref["flops"],
        "cost_limit_flops": int(limit),
        "best_overall": best_all[1]["name"],
        "best_overall_improvement_pct": best_all[2],
        "best_overall_flops": best_all[1]["flops"],
    }
    if best is not None:
        out.update(
            best=best[1]["name"], improvement_pct=best[2], flops=best[1]["flops"], within_cost=True
        )
    else:
        out.update(best=None, improvement_pct={}, within_cost=False)
    return out


def merge_seeds(rows: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """One row from the same variant trained with several seeds: per split, the mean of every
    score over the seeds that ran it, plus ``mae_std`` (sample std) and ``seeds``."""
    out = dict(rows[0])
    for kind in ("random", "blocked"):
        runs = [r[kind] for r in rows if kind in r]
        if not runs:
            continue
        d = dict(runs[0])
        d["seeds"] = len(runs)
        d["mae"] = {a: float(np.mean([r["mae"][a] for r in runs])) for a in runs[0]["mae"]}
        d["mae_std"] = {
            a: float(np.std([r["mae"][a] for r in runs], ddof=1)) if len(runs) > 1 else 0.0
            for a in runs[0]["mae"]
        }
        for key in ("r2_mean", "r2_min", "region_accuracy", "contact_accuracy", "train_s"):
            d[key] = float(np.mean([r[key] for r in runs]))
        if "coverage" in d:
            d["coverage"] = {
                lv: float(np.mean([r["coverage"][lv] for r in runs])) for lv in d["coverage"]
            }
        out[kind] = d
    return out


def run_variants(
    dataset: Dataset,
    names: Sequence[str],
    base: dict[str, Any],
    *,
    seed: int = 0,
    train_seeds: Sequence[int] = (0,),
    kinds: Sequence[str] = ("random", "blocked"),
    on_done: Callable[[str], None] | None = None,
) -> tuple[list[dict[str, Any]], dict[str, Any]]:
    """Train and score each variant (spec = paper + `base` + the variant's changes) on the
    same splits (split seed `seed`). The blocked split is repeated for every training seed
    in `train_seeds` (scores are means, with the MAE's spread); the other kinds use the first.
    Returns the table rows and the trained models (by variant, blocked split, first seed)."""
    from spectratac.evaluate.fit_both_splits import fit_and_evaluate
    from spectratac.train import TrainSpec

    rows: list[dict[str, Any]] = []
    models: dict[str, Any] = {}
    for name in names:
        per_seed = []
        for k, ts in enumerate(train_seeds):
            spec = TrainSpec.paper(**{**base, **VARIANTS[name], "seed": ts})
            run_kinds = kinds if k == 0 else [c for c in kinds if c == "blocked"]
            fit = fit_and_evaluate(dataset, spec, run_kinds, seed=seed)
            per_seed.append(row_of(name, fit, fit.train_seconds))
            if k == 0:
                models[name] = fit.models.get("blocked") or next(iter(fit.models.values()))
        rows.append(merge_seeds(per_seed))
        if on_done is not None:
            on_done(name)
    add_improvements(rows)
    return rows, models
