"""Benchmark `--recipe auto` against the paper's recipe and the classical baselines.

On held-out later sessions: the synthetic drifting skin (4 channels at 100 Hz, Fz; train on
the first two thirds of the sessions, test on the rest) and the twin (a population of
sessions from `spectratac.sim.twin_dataset.population` when it exists, else the calibration
session split into blocked presses). Figures, each a ratio measured in the same run:
auto's held-out MAE over the paper recipe's and over the best classical baseline's, and the
search's wall time over its budget (with the load average, since the machine is shared).

    .venv/bin/python tools/bench/auto_recipe.py [--budget 300] [--data skin,twin] [--json]

`--data big`: the search on 250 000 rows of the skin (125 sessions of 20 s), run quiet and
again beside two busy-loop processes (`--busy 2`) in the same run: how many networks it
evaluated within the budget, and whether it picked the same candidate both times (the budget
is in units of work, so it must). `--data throughput`: the paper network's training
throughput on 266 000 rows (a measured number of epochs, scaled to 30: every epoch does the
same work) beside a NumPy float32 matmul workload of the same FLOPs, in the same run.
"""

from __future__ import annotations

import contextlib
import os
import subprocess
import sys
import time
from collections.abc import Iterator
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
    res = search(
        ds,
        budget,
        rows=tr,
        targets=targets,
        features=feats,
        progress=lambda s: print(f"  [{name}] {s}", file=sys.stderr),
    )
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


def _say(tag: str) -> Any:
    return lambda line: print(f"  [{tag}] {line}", file=sys.stderr)


@contextlib.contextmanager
def busy_loops(n: int) -> Iterator[None]:
    """`n` Python busy-loop processes for the duration (each stopped by its own pid)."""
    procs = [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(n)]
    try:
        yield
    finally:
        for proc in procs:
            proc.kill()
            proc.wait()


def big(budget: float, seed: int, busy: int) -> list[benchlib.Figure]:
    from spectratac.sim.generic_skin import generic_skin

    ds = generic_skin(sessions=125, session_s=20.0, seed=seed)
    runs: dict[str, dict[str, Any]] = {}
    for label, n in (("quiet", 0), (f"{busy} busy loops", busy)):
        with busy_loops(n):
            load0 = os.getloadavg()[0]
            say = _say(f"big {label}")
            res = search(ds, budget, targets=("Fz",), features="generic", progress=say)
            load1 = os.getloadavg()[0]
        print(res.text(), file=sys.stderr)
        rep = res.report
        done = [c for c in rep["candidates"] if c["status"] == "done"]
        runs[label] = {
            "chosen": rep["chosen"],
            "networks_done": [c["name"] for c in done if c["family"] == "network"],
            "status": {c["name"]: c["status"] for c in rep["candidates"]},
            "wall_s": round(rep["elapsed_s"], 1),
            "work_s": round(rep["work_s"], 1),
            "within_budget": rep["within_budget"],
            "load_avg_1m": [round(load0, 2), round(load1, 2)],
        }
    q, b = runs.values()
    same = q["chosen"] == b["chosen"] and q["status"] == b["status"]
    return [
        benchlib.Figure(
            f"big ({ds.n} rows): networks evaluated, quiet",
            len(q["networks_done"]),
            "networks",
            "candidates",
            len(q["status"]),
            len(q["networks_done"]) / len(q["status"]),
            q,
        ),
        benchlib.Figure(
            f"big: same choice beside {busy} busy loops",
            float(same),
            "bool",
            "quiet",
            1.0,
            float(same),
            b,
        ),
        benchlib.Figure(
            "big: wall time beside busy loops",
            b["wall_s"],
            "s",
            "quiet",
            q["wall_s"],
            b["wall_s"] / q["wall_s"],
            {"cores": os.cpu_count()},
        ),
    ]


def throughput(rows: int, epochs: int, threads: int) -> list[benchlib.Figure]:
    """The paper network's training loop (train/torch_loop.py) on `rows` synthetic rows of
    the paper's feature and head shapes, beside NumPy matmuls of the same FLOPs."""
    import torch  # imported before the clock starts
    from spectratac.decode.networks import flops
    from spectratac.sim import twin_dataset
    from spectratac.train.torch_loop import fit_network
    from spectratac.twin import builtin_scenes, generate_session

    scene = builtin_scenes.calibration_session(seed=0, duration_s=60.0)
    ds = twin_dataset.from_twin_session(generate_session(scene, seed=0), scene)
    spec = TrainSpec.paper(epochs=epochs, threads=threads)
    p = plan(ds, spec)
    rng = np.random.default_rng(0)
    data = {
        "z": rng.standard_normal((rows, p.features.n_features)).astype(np.float32),
        "y": rng.standard_normal((rows, p.heads.n_reg)).astype(np.float32),
        "y_ok": np.ones(rows, bool),
        "label": rng.integers(0, p.heads.n_classes + 1, rows),
        "contact": rng.integers(0, 2, rows).astype(np.float32),
    }
    train_flops = 3 * flops(spec.arch, p.features.n_features, p.heads.n_out)
    a = rng.standard_normal((spec.batch_size, 128)).astype(np.float32)
    w = rng.standard_normal((128, 128)).astype(np.float32)
    per = 2 * spec.batch_size * 128 * 128
    reps = int(train_flops * rows * epochs / per)
    torch.set_num_threads(threads)
    load0 = os.getloadavg()[0]
    t_torch: list[float] = []
    t_np: list[float] = []
    for _ in range(2):  # alternated, so that load spikes hit both
        t0 = time.perf_counter()
        fit_network(spec, p, data, np.arange(rows), np.arange(0), False)
        t_torch.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        for _ in range(reps):
            a @ w
        t_np.append(time.perf_counter() - t0)
    tt, tn = min(t_torch), min(t_np)
    scale = 30 / epochs
    info = {
        "rows": rows,
        "epochs_measured": epochs,
        "threads": threads,
        "train_flops_per_sample": train_flops,
        "torch_gflops": round(train_flops * rows * epochs / tt / 1e9, 2),
        "numpy_gflops": round(reps * per / tn / 1e9, 2),
        "load_avg_1m": [round(load0, 2), round(os.getloadavg()[0], 2)],
        "cores": os.cpu_count(),
    }
    return [
        benchlib.Figure(
            f"paper network, {rows} rows x 30 epochs (from {epochs})",
            tt * scale,
            "s",
            "NumPy matmuls of the same FLOPs",
            tn * scale,
            tt / tn,
            info,
        ),
    ]


def main() -> int:
    p = benchlib.parser(__doc__.splitlines()[0])
    p.add_argument("--budget", type=float, default=300.0, help="search budget, seconds")
    p.add_argument("--data", default="skin,twin", help="skin, twin, big, throughput")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--busy", type=int, default=2, help="big: busy-loop processes beside it")
    p.add_argument("--rows", type=int, default=266_000, help="throughput: training rows")
    p.add_argument("--epochs", type=int, default=2, help="throughput: epochs measured")
    p.add_argument("--threads", type=int, default=2, help="throughput: torch threads")
    args = p.parse_args()
    figures: list[benchlib.Figure] = []
    for name in args.data.split(","):
        if name == "big":
            figures += big(args.budget, args.seed, args.busy)
        elif name == "throughput":
            figures += throughput(args.rows, args.epochs, args.threads)
        else:
            figures += run(name, {"skin": skin, "twin": twin}[name], args.budget, args.seed)
    benchlib.report(figures, args.json)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
