"""Benchmark: decoders on units and sessions they never saw, and few-shot recalibration.

    .venv/bin/python tools/bench/generalisation.py [--quick] [--json] [--no-progress]
        [--units N] [--session-s S] [--full-cal-s S] [--test-s S] [--epochs N]
        [--best-epochs N] [--seed S]

All data comes from the twin: a population of units (UnitParams.from_seed), each recorded in
calibration sessions. A new unit (never in the population) has a full calibration session
(50 min by default), a separate few-shot session whose first minutes are its recalibration
data, and a separate test session that every figure below is scored on (force MAE: the mean
of the Fx, Fy, Fz MAE, N).

(a) held-out unit: each recipe (the paper's, TrainSpec.best(), a polynomial ridge baseline,
    and the auto recipe when `spectratac.evaluate.auto_recipe` exists) trained on the
    population, scored on the new unit; as a ratio to the paper recipe trained on the new
    unit's own full calibration (measured in the same run).
(b) held-out sessions: each recipe trained on every session of one population unit but the
    last, with a random 20 % of those rows held out; the last session's MAE as a ratio to
    the random-split MAE (what the paper's protocol reports).
(c) few-shot curve: the population's paper model recalibrated with `decode.finetune` on 0.5,
    1, 2 and 5 minutes of the new unit (every fine-tuning mode), and the paper recipe trained
    from scratch on the same minutes; ratios to the full calibration. The base model with
    no recalibration is the 0-minute point. Target: 2 minutes within 1.3x of the full
    calibration.

Prints a table, or one JSON line per figure with --json (the last one, the target check,
carries the configuration and the run's seconds).
"""

from __future__ import annotations

import sys
import time
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "host"))

import benchlib
from spectratac.dataset.schema import FT_NAMES, Dataset, concat
from spectratac.decode import DecoderUnitWarning, TrainSpec, train
from spectratac.decode.finetune import MODES, finetune
from spectratac.evaluate.holdout import mark_sessions
from spectratac.evaluate.run import evaluate_model
from spectratac.evaluate.splits import SplitSpec, split_dataset
from spectratac.sim.twin_dataset import from_twin_session
from spectratac.twin.builtin_scenes import calibration_session
from spectratac.twin.generate import generate_session
from spectratac.twin.unit import UnitParams

FORCES = ("Fx", "Fy", "Fz")
NEW_UNIT = 1000  # a unit seed far from the population's 1..N
MINUTES = (0.5, 1.0, 2.0, 5.0)
TARGET_RATIO = 1.3  # few-shot at 2 minutes against the full calibration
RIDGE_ALPHA = 1.0


@dataclass(frozen=True)
class Config:
    units: int = 4
    sessions_per_unit: int = 3
    session_s: float = 150.0
    full_cal_s: float = 3000.0
    test_s: float = 300.0
    # Epoch counts below the recipes' own (30) keep the default run near half an hour on two
    # shared cores; the population model and the full calibration use the same count.
    epochs: int | None = 10  # None: the recipe's own
    best_epochs: int | None = 3
    minutes: tuple[float, ...] = MINUTES
    modes: tuple[str, ...] = MODES
    few_shot_base: str = "paper"  # the population model that (c) recalibrates
    sections: str = "abc"  # (c) always runs, with the (a) model it starts from
    auto_budget_s: float = 600.0  # the auto recipe's search budget per training
    seed: int = 0


QUICK = Config(
    units=3, sessions_per_unit=3, session_s=60.0, full_cal_s=300.0, test_s=120.0, epochs=6,
    best_epochs=2, auto_budget_s=60.0,
)  # fmt: skip


# ---------------------------------------------------------------- data
def _session(unit: int, seed: int, duration_s: float) -> Dataset:
    scene = calibration_session(seed, duration_s)
    ds = from_twin_session(
        generate_session(scene, seed=seed, unit=UnitParams.from_seed(unit)), scene
    )
    ds.meta["sessions"][0]["unit"] = unit
    ds.meta["unit_id"] = f"twin-unit-{unit}"
    return ds


def population(
    units: Sequence[int],
    sessions_per_unit: int,
    session_s: float,
    seed: int = 0,
    progress: Callable[[str], None] | None = None,
) -> Dataset:
    """One calibration session per (unit, session index); meta["sessions"][i]["unit"]."""
    parts = []
    for u in units:
        for k in range(sessions_per_unit):
            parts.append(_session(int(u), 10_000 * (seed + 1) + 100 * int(u) + k, session_s))
            if progress:
                progress(f"unit {u} session {k}")
    ds = concat(parts)
    ds.meta["unit_id"] = parts[0].meta["unit_id"] if len(units) == 1 else None
    return ds


# ---------------------------------------------------------------- recipes
Predictor = Callable[[Dataset, NDArray[np.int64]], NDArray[np.float64]]


def _decoder_predictor(dec: Any) -> Predictor:
    def run(ds: Dataset, rows: NDArray[np.int64]) -> NDArray[np.float64]:
        est = dec.predict(ds, rows)
        out = np.full((rows.size, len(FT_NAMES)), np.nan)
        for j, name in enumerate(FT_NAMES):
            if name in est.target_names:
                out[:, j] = est.targets[:, list(est.target_names).index(name)]
        return out

    run.decoder = dec  # type: ignore[attr-defined]
    return run


def _poly(x: NDArray[np.float64]) -> NDArray[np.float64]:
    i, j = np.triu_indices(x.shape[1])
    return np.hstack([np.ones((x.shape[0], 1)), x, x[:, i] * x[:, j]])


def ridge(ds: Dataset, rows: NDArray[np.int64] | None) -> Predictor:
    """Degree-2 polynomial ridge regression on the z-scored raw channels (closed form)."""
    r = np.arange(ds.n) if rows is None else np.asarray(rows)
    r = r[np.asarray(ds.target_valid, bool)[r]]
    x = np.asarray(ds.inputs, np.float64)[r]
    mean, std = x.mean(axis=0), np.where(x.std(axis=0) > 0, x.std(axis=0), 1.0)
    phi = _poly((x - mean) / std)
    gram = phi.T @ phi + RIDGE_ALPHA * np.eye(phi.shape[1])
    w = np.linalg.solve(gram, phi.T @ np.asarray(ds.targets, np.float64)[r])

    def run(d: Dataset, idx: NDArray[np.int64]) -> NDArray[np.float64]:
        return _poly((np.asarray(d.inputs, np.float64)[idx] - mean) / std) @ w

    return run


def recipes(cfg: Config) -> dict[str, Callable[[Dataset, Any], Predictor]]:
    paper = TrainSpec.paper(**({"epochs": cfg.epochs} if cfg.epochs else {}))
    best = TrainSpec.best(**({"epochs": cfg.best_epochs} if cfg.best_epochs else {}))
    out: dict[str, Callable[[Dataset, Any], Predictor]] = {
        "paper": lambda ds, rows: _decoder_predictor(train(ds, paper, rows, progress=False)),
        "best": lambda ds, rows: _decoder_predictor(train(ds, best, rows, progress=False)),
        "ridge": ridge,
    }
    auto = _auto_recipe(cfg)
    if auto is not None:
        out["auto"] = auto
    return out


def _auto_recipe(cfg: Config) -> Callable[[Dataset, Any], Predictor] | None:
    """The auto recipe's search, when this checkout has it (spectratac.evaluate.auto_recipe)."""
    try:
        from spectratac.evaluate import auto_recipe  # type: ignore[attr-defined]
    except ImportError:
        return None
    budget = cfg.auto_budget_s

    def run(ds: Dataset, rows: Any) -> Predictor:
        # search(...).decoder is the chosen recipe refitted on `rows` (grouped CV inside)
        return _decoder_predictor(auto_recipe.search(ds, budget_s=budget, rows=rows).decoder)

    return run


# ---------------------------------------------------------------- scoring
def force_mae(pred: Predictor, ds: Dataset, rows: NDArray[np.int64] | None = None) -> dict:
    r = np.arange(ds.n) if rows is None else np.asarray(rows, np.int64)
    p = pred(ds, r)
    y = np.asarray(ds.targets, np.float64)[r]
    ok = np.asarray(ds.target_valid, bool)[r] & np.all(np.isfinite(p), axis=1)
    axes = {a: float(np.mean(np.abs(p[ok, i] - y[ok, i]))) for i, a in enumerate(FT_NAMES)}
    return {"force": float(np.mean([axes[a] for a in FORCES])), "axes": axes, "n": int(ok.sum())}


def _fig(name: str, value: dict, ref_name: str, ref: dict, **extra: Any) -> benchlib.Figure:
    return benchlib.Figure(
        name,
        value["force"],
        "N",
        ref_name,
        ref["force"],
        value["force"] / ref["force"],
        {"axes": value["axes"], "n": value["n"], **extra},
    )


# ---------------------------------------------------------------- the benchmark
def run(cfg: Config, progress: Callable[[str], None]) -> list[benchlib.Figure]:
    warnings.filterwarnings("ignore", category=DecoderUnitWarning)  # other units on purpose
    t0 = time.perf_counter()
    pop = population(range(1, cfg.units + 1), cfg.sessions_per_unit, cfg.session_s, cfg.seed,
                     progress)  # fmt: skip
    full = _session(NEW_UNIT, 7_000 + cfg.seed, cfg.full_cal_s)
    shots = _session(NEW_UNIT, 8_000 + cfg.seed, 60.0 * max(cfg.minutes) + 1.0)
    test = _session(NEW_UNIT, 9_000 + cfg.seed, cfg.test_s)
    progress("new unit data")
    makers = recipes(cfg)
    figs: list[benchlib.Figure] = []

    own = force_mae(makers["paper"](full, None), test)
    progress("paper: new unit's own full calibration")
    own_name = f"paper on the new unit's own {cfg.full_cal_s / 60:g} min calibration"

    # (a) held-out unit
    pop_models: dict[str, Predictor] = {}
    first = makers if "a" in cfg.sections else {cfg.few_shot_base: makers[cfg.few_shot_base]}
    for name, make in first.items():
        pop_models[name] = make(pop, None)
        figs.append(_fig(f"(a) held-out unit: {name}", force_mae(pop_models[name], test),
                         own_name, own, units=cfg.units))  # fmt: skip
        progress(f"(a) {name}")

    # (b) held-out sessions of one unit
    one = population([1], cfg.sessions_per_unit, cfg.session_s, cfg.seed)
    last = int(np.max(one.session))
    before = np.flatnonzero(np.asarray(one.session) != last)
    split = split_dataset(one.subset(before), SplitSpec("random", seed=cfg.seed))
    train_rows, random_test = before[split.train], before[split.test]
    for name, make in makers.items() if "b" in cfg.sections else ():
        pred = make(one, train_rows)
        dec = getattr(pred, "decoder", None)
        if dec is not None:  # the decoder path: evaluate's own held-out-session scoring
            mark_sessions(dec, one, [last])
            ev = evaluate_model(dec, one, oracle_samples=0)
            held_rows = ev.sections["sessions"].rows
        else:
            held_rows = np.flatnonzero(np.asarray(one.session) == last)
        figs.append(_fig(f"(b) held-out session: {name}", force_mae(pred, one, held_rows),
                         f"{name} random-split test rows of the trained sessions",
                         force_mae(pred, one, random_test)))  # fmt: skip
        progress(f"(b) {name}")

    # (c) few-shot curve
    base = pop_models[cfg.few_shot_base].decoder  # type: ignore[attr-defined]
    of = "" if cfg.few_shot_base == "paper" else f" of {cfg.few_shot_base}"
    figs.append(_fig(f"(c) 0 min: population model{of}, no recalibration",
                     force_mae(pop_models[cfg.few_shot_base], test), own_name, own))  # fmt: skip
    t_shot = np.asarray(shots.t_start) - float(np.min(shots.t_start))
    paper_small = TrainSpec.paper(**({"epochs": cfg.epochs} if cfg.epochs else {}))
    for minutes in cfg.minutes:
        rows = np.flatnonzero(t_shot < 60.0 * minutes)
        for mode in cfg.modes:
            dec = finetune(base, shots, rows, mode=mode, progress=False)
            stopped = dec.meta["finetuned_from"]["early_stopping"]
            figs.append(_fig(f"(c) {minutes:g} min fine-tune {mode}{of}",
                             force_mae(_decoder_predictor(dec), test), own_name, own,
                             minutes=minutes, mode=mode,
                             early_stopping=stopped))  # fmt: skip
            progress(f"(c) {minutes:g} min {mode}")
        scratch = _decoder_predictor(train(shots, paper_small, rows, progress=False))
        figs.append(_fig(f"(c) {minutes:g} min paper from scratch",
                         force_mae(scratch, test), own_name, own, minutes=minutes))  # fmt: skip
        progress(f"(c) {minutes:g} min scratch")
    at = 2.0 if 2.0 in cfg.minutes else max(cfg.minutes)
    two = [f for f in figs if f.extra.get("minutes") == at and "mode" in f.extra]
    best2 = min(two, key=lambda f: f.ratio)
    figs.append(
        benchlib.Figure(
            f"target: {at:g} min fine-tune{of} ({best2.extra['mode']}) vs full calibration",
            best2.ratio,
            "x",
            "target",
            TARGET_RATIO,
            best2.ratio / TARGET_RATIO,
            {
                "met": bool(best2.ratio <= TARGET_RATIO),
                "seconds": time.perf_counter() - t0,
                "config": cfg.__dict__,
            },
        )
    )
    return figs


def table(figs: list[benchlib.Figure]) -> str:
    """Human table: MAE with 4 significant digits (benchlib's shows one decimal)."""
    width = max(len(f.name) for f in figs)
    return "\n".join(
        f"{f.name:<{width}}  {f.value:>8.4g} {f.unit:<2} = {f.ratio:6.3f} x {f.reference_name} "
        f"({f.reference_value:.4g})"
        for f in figs
    )


def stages(cfg: Config, n_recipes: int) -> int:
    a = n_recipes if "a" in cfg.sections else 1
    b = n_recipes if "b" in cfg.sections else 0
    return (cfg.units * cfg.sessions_per_unit + 2 + a + b
            + len(cfg.minutes) * (len(cfg.modes) + 1))  # fmt: skip


def main(argv: Sequence[str] | None = None) -> int:
    p = benchlib.parser(__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true", help="CI-sized run (a few minutes)")
    p.add_argument("--units", type=int, help="units in the training population")
    p.add_argument("--sessions-per-unit", type=int)
    p.add_argument("--session-s", type=float, help="length of each population session (s)")
    p.add_argument("--full-cal-s", type=float, help="the new unit's full calibration (s)")
    p.add_argument("--test-s", type=float, help="the new unit's test session (s)")
    p.add_argument("--epochs", type=int, help="epochs of the paper recipe (default: its own)")
    p.add_argument("--best-epochs", type=int, help="epochs of TrainSpec.best()")
    p.add_argument("--minutes", help="few-shot minutes, comma list (default 0.5,1,2,5)")
    p.add_argument("--modes", help=f"fine-tuning modes, comma list (default {','.join(MODES)})")
    p.add_argument("--few-shot-base", choices=("paper", "best"), help="model (c) starts from")
    p.add_argument("--sections", help="which of a, b to run besides c (default abc)")
    p.add_argument("--seed", type=int)
    p.add_argument("--no-progress", action="store_true")
    args = p.parse_args(argv)
    cfg = QUICK if args.quick else Config()
    given = {k: getattr(args, k) for k in Config.__dataclass_fields__ if getattr(args, k, None)}
    if args.minutes:
        given["minutes"] = tuple(float(v) for v in args.minutes.split(","))
    if args.modes:
        given["modes"] = tuple(args.modes.split(","))
        if not set(given["modes"]) <= set(MODES):
            p.error(f"--modes: choose from {', '.join(MODES)}")
    cfg = replace(cfg, **given)
    if cfg.sessions_per_unit < 2:
        p.error("--sessions-per-unit must be >= 2 (one session is held out)")
    from tqdm import tqdm

    bar = tqdm(total=stages(cfg, len(recipes(cfg))), desc="generalisation", unit="step",
               file=sys.stderr, leave=False, disable=args.no_progress)  # fmt: skip

    def tick(stage: str) -> None:
        bar.set_postfix_str(stage)
        bar.update(1)

    try:
        figs = run(cfg, tick)
    finally:
        bar.close()
    if args.json:
        benchlib.report(figs, True)
    else:
        print(table(figs))
    if not args.json:
        print(f"config: {cfg}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
