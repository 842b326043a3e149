"""Fidelity report: how hard the twin is compared with the real sensor in the paper.

Trains the paper's recipe on one simulated 50-minute calibration session and evaluates it
(1) on a random 20 % of the samples, as the paper did, and (2) on the held-out last 20 % of
the session (trained on the first 80 %), the honest split for a time series. Each split also
reports the oracle (the true unit, model inversion per sample) on a subset of its test samples.
The calibration target: random-split MAEs within +-30 % of the paper's, region accuracy >= 99 %
and R^2 > 0.91 on all six components.

>>> PAPER["mae"]["Fz"], round(band(PAPER["mae"]["Fx"])[1], 4)
(0.429, 0.2093)
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from spectratac.evaluate.paper import PAPER
from spectratac.hardware.generated import vocabulary as vocab
from spectratac.train.fitting import train
from spectratac.train.metrics import region_accuracy, regression_metrics
from spectratac.train.spec import TrainSpec

BAND = 0.30
TARGET_REGION_ACCURACY = 0.99


def band(value: float) -> tuple[float, float]:
    return (value * (1 - BAND), value * (1 + BAND))


@dataclass(frozen=True)
class ReportConfig:
    seed: int = 0
    duration_s: float = 3000.0
    epochs: int = 30
    test_fraction: float = 0.2
    oracle_samples: int = 1000
    batch_size: int = 1024


def _scores(y: np.ndarray, pred_ft: np.ndarray, lab: np.ndarray, pred_reg: np.ndarray) -> dict:
    return {
        "axes": regression_metrics(y, pred_ft, vocab.FT_AXES),
        "region_accuracy": region_accuracy(lab, pred_reg),
        "n": int(y.shape[0]),
    }


def fidelity_report(
    cfg: ReportConfig | None = None, progress: Callable[[str, int], None] | None = None
) -> dict[str, Any]:
    """Run the whole report; `progress(stage, units_done)` is called as work completes."""
    from spectratac.twin import builtin_scenes as scenes
    from spectratac.twin import generate_session
    from spectratac.twin.oracle import Oracle

    cfg = cfg or ReportConfig()
    tick = progress or (lambda stage, n: None)
    t0 = time.perf_counter()
    scene = scenes.calibration_session(seed=cfg.seed, duration_s=cfg.duration_s)
    session = generate_session(scene, seed=cfg.seed)
    gen_s = time.perf_counter() - t0
    tick("generate", 1)
    from spectratac.sim.twin_dataset import from_twin_session

    ds = from_twin_session(session, scene)
    y, lab = session.ft_window, session.region
    n = len(session)
    n_test = max(1, round(cfg.test_fraction * n))
    rng = np.random.default_rng([cfg.seed, 0xF1DE])
    perm = rng.permutation(n)
    splits = {
        "random": (np.sort(perm[n_test:]), np.sort(perm[:n_test])),
        "heldout": (np.arange(n - n_test), np.arange(n - n_test, n)),
    }
    oracle = Oracle.for_session(session, scene)
    spec = TrainSpec.paper(epochs=cfg.epochs, batch_size=cfg.batch_size, seed=cfg.seed)
    out: dict[str, Any] = {}
    for name, (tr, te) in splits.items():
        dec = train(ds, spec, rows=tr, progress=lambda e, loss, s=name: tick(f"train {s}", 1))
        pred = dec.predict(ds, rows=te)
        sub = (
            te
            if te.shape[0] <= cfg.oracle_samples
            else np.sort(rng.choice(te, cfg.oracle_samples, replace=False))
        )
        tmid = 0.5 * (session.t_start[sub] + session.t_end[sub])
        orc = oracle.decode(session.counts[sub], tmid, session.step[sub])
        tick("oracle", 1)
        out[name] = {
            "recipe": _scores(y[te], pred.targets, lab[te], pred.region),
            "oracle": _scores(y[sub], orc.ft, lab[sub], orc.region),
            "train_loss": dec.meta["history"][-1],
        }
    rnd = out["random"]["recipe"]
    checks = {
        f"{a}_mae_within_30pct": bool(
            band(PAPER["mae"][a])[0] <= rnd["axes"][a]["mae"] <= band(PAPER["mae"][a])[1]
        )
        for a in vocab.FORCE_AXES
    }
    checks["r2_above_0.91_all_six"] = bool(
        all(rnd["axes"][a]["r2"] > PAPER["r2_min"] for a in vocab.FT_AXES)
    )
    checks["region_accuracy_at_least_99pct"] = bool(
        rnd["region_accuracy"] >= TARGET_REGION_ACCURACY
    )
    return {
        "config": asdict(cfg),
        "session": {
            "samples": n,
            "duration_s": cfg.duration_s,
            "generation_s": gen_s,
            "ft_samples": int(session.ft.shape[0]),
        },
        "paper": PAPER,
        "splits": out,
        "checks": checks,
        "pass": bool(all(checks.values())),
        "elapsed_s": time.perf_counter() - t0,
    }


def format_report(rep: dict[str, Any]) -> str:
    """Human-readable table of a `fidelity_report` result."""
    lines = [
        f"SpectraTac twin fidelity report: {rep['session']['samples']} samples "
        f"({rep['session']['duration_s'] / 60:.0f} min at 20 Hz), seed {rep['config']['seed']}, "
        f"{rep['config']['epochs']} epochs",
        "",
    ]
    paper = rep["paper"]["mae"]
    for split, title in (
        ("random", "random 20 % split (paper protocol)"),
        ("heldout", "held-out last 20 % of the session"),
    ):
        s = rep["splits"][split]
        lines.append(f"{title}: recipe n={s['recipe']['n']}, oracle n={s['oracle']['n']}")
        lines.append(
            f"  {'axis':<4} {'MAE':>9} {'RMSE':>9} {'R2':>7} | {'paper MAE':>9} | "
            f"{'oracle MAE':>10} {'R2':>7}"
        )
        for a in vocab.FT_AXES:
            r, o = s["recipe"]["axes"][a], s["oracle"]["axes"][a]
            unit = vocab.AXIS_UNITS[a]
            p = f"{paper[a]:9.3f}" if a in paper else f"{'<=0.004':>9}"
            lines.append(
                f"  {a:<4} {r['mae']:9.4f} {r['rmse']:9.4f} {r['r2']:7.3f} | {p} | "
                f"{o['mae']:10.4f} {o['r2']:7.3f}  {unit}"
            )
        lines.append(
            f"  region accuracy {100 * s['recipe']['region_accuracy']:.2f} % "
            f"(paper 99.9 %, oracle {100 * s['oracle']['region_accuracy']:.2f} %)"
        )
        lines.append("")
    lines.append("calibration checks (random split):")
    for k, v in rep["checks"].items():
        lines.append(f"  {'PASS' if v else 'FAIL'}  {k}")
    lines.append(
        f"overall: {'PASS' if rep['pass'] else 'FAIL'} "
        f"(generation {rep['session']['generation_s']:.1f} s, "
        f"total {rep['elapsed_s']:.0f} s)"
    )
    return "\n".join(lines)
