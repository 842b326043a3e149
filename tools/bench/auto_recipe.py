"""Benchmark `--recipe auto` against the paper's recipe and the classical baselines.

On held-out later sessions: the synthetic drifting skin (4 channels at 100 Hz, Fz; train on
the first two thirds of the sessions, test on the rest) and the twin (a population of
sessions from `spectratac.sim.twin_dataset.population` when it exists, else the calibration
session split into blocked presses). Figures, each a ratio measured in the same run:
auto's held-out MAE over the paper recipe's and over the best classical baseline's, and the
search's wall time over its budget (with the load average, since the machine is shared).

    .venv/bin/python tools/bench/auto_recipe.py [--budget 300] [--data skin,twin] [--json]
"""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import benchlib
from spectratac.dataset.schema import Dataset
from spectratac.train import TrainSpec, train
from spectratac.train.auto_recipe import search
from spectratac.train.auto_recipe.search import MAX_RIDGE_FEATURES
from spectratac.train.metrics import decoder_mae
from spectratac.train.plan import plan

CLASSICAL = {
    "linear": {"degree": 1},
    "poly2": {"degree": 2},
    "poly3": {"degree": 3},
    "linear+drift": {"degree": 1, "drift": "baseline"},
    "poly2+drift": {"degree": 2, "drift": "baseline"},
}


def skin(seed: int) -> tuple[Dataset, np.ndarray, np.ndarray, str, tuple[str, ...]]:
    from spectratac.sim.generic_skin import generic_skin

    ds = generic_skin(sessions=36, session_s=20.0, seed=seed)
    return ds, np.flatnonzero(ds.session < 24), np.flatnonzero(ds.session >= 24), "generic", ("Fz",)


def twin(seed: int) -> tuple[Dataset, np.ndarray, np.ndarray, str, tuple[str, ...]]:
    from spectratac.hardware.generated import vocabulary as vocab
    from spectratac.sim import twin_dataset

    targets = vocab.FORCE_AXES
    if hasattr(twin_dataset, "population"):
        ds = twin_dataset.population(units=1, sessions_per_unit=9, session_s=120.0, seed=seed)
        n = int(ds.session.max()) + 1
        cut = round(2 * n / 3)
        return (
            ds,
            np.flatnonzero(ds.session < cut),
            np.flatnonzero(ds.session >= cut),
            ("paper33"),
            targets,
        )
    from spectratac.train.groups import SplitSpec, split_dataset
    from spectratac.twin import builtin_scenes, generate_session

    scene = builtin_scenes.calibration_session(seed=seed, duration_s=900.0)
    ds = twin_dataset.from_twin_session(generate_session(scene, seed=seed), scene)
    split = split_dataset(ds, SplitSpec("blocked", seed=seed, test_fraction=0.3))
    return ds, split.train, split.test, "paper33", targets


def score(ds: Dataset, dec: Any, rows: np.ndarray, std: dict[str, float]) -> tuple[float, dict]:
    mae = decoder_mae(dec, ds, rows)
    return float(np.mean([mae[t] / std[t] for t in mae])), mae


def run(name: str, make: Any, budget: float, seed: int) -> list[benchlib.Figure]:
    ds, tr, te, feats, targets = make(seed)
    y = ds.targets[tr]
    std = {t: float(np.std(y[:, list(ds.target_names).index(t)])) for t in targets}
    held: dict[str, tuple[float, dict]] = {}
    t0 = time.perf_counter()
    paper = train(ds, TrainSpec.paper(features=feats, targets=targets), rows=tr, progress=False)
    paper_s = time.perf_counter() - t0
    held["paper"] = score(ds, paper, te, std)
    for label, kw in CLASSICAL.items():
        spec = TrainSpec(features=feats, model="ridge", targets=targets, **kw)
        if plan(ds, spec).features.n_features > MAX_RIDGE_FEATURES:
            continue  # e.g. cubic over the paper's 33 features: 7139 monomials
        held[label] = score(ds, train(ds, spec, rows=tr, progress=False), te, std)
    load0 = os.getloadavg()[0]
    t0 = time.perf_counter()
    res = search(ds, budget, rows=tr, targets=targets, features=feats,
                 progress=lambda s: print(f"  [{name}] {s}", file=sys.stderr))  # fmt: skip
    wall = time.perf_counter() - t0
    load1 = os.getloadavg()[0]
    held["auto"] = score(ds, res.decoder, te, std)
    print(res.text(), file=sys.stderr)
    best_cl = min((k for k in CLASSICAL if k in held), key=lambda k: held[k][0])
    info = {
        "heldout_score": {k: round(v[0], 4) for k, v in held.items()},
        "heldout_mae": {k: {t: round(m, 4) for t, m in v[1].items()} for k, v in held.items()},
        "chosen": res.report["chosen"],
        "paper_train_s": round(paper_s, 1),
        "rows_train": int(tr.size),
        "rows_test": int(te.size),
    }
    a = held["auto"][0]
    return [
        benchlib.Figure(
            f"{name}: auto held-out score",
            a,
            "MAE/std",
            "paper recipe",
            held["paper"][0],
            a / held["paper"][0],
            info,
        ),
        benchlib.Figure(
            f"{name}: auto held-out score",
            a,
            "MAE/std",
            f"best classical ({best_cl})",
            held[best_cl][0],
            a / held[best_cl][0],
            {"chosen": res.report["chosen"]},
        ),
        benchlib.Figure(
            f"{name}: auto wall time",
            wall,
            "s",
            "budget",
            budget,
            wall / budget,
            {
                "search_s": round(res.report["search_s"], 1),
                "refit_s": round(res.report["refit_s"], 1),
                "load_avg_1m": [round(load0, 2), round(load1, 2)],
                "cores": os.cpu_count(),
            },
        ),
    ]


def main() -> int:
    p = benchlib.parser(__doc__.splitlines()[0])
    p.add_argument("--budget", type=float, default=300.0, help="search budget, seconds")
    p.add_argument("--data", default="skin,twin", help="skin, twin or both")
    p.add_argument("--seed", type=int, default=0)
    args = p.parse_args()
    figures: list[benchlib.Figure] = []
    for name in args.data.split(","):
        figures += run(name, {"skin": skin, "twin": twin}[name], args.budget, args.seed)
    benchlib.report(figures, args.json)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
