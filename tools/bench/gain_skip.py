"""Benchmark: gain augmentation (TrainSpec.gain_jitter) and the linear skip (TrainSpec.skip).

    .venv/bin/python tools/bench/gain_skip.py [--json] [--units N] [--session-s S]
        [--epochs N] [--jitter G] [--gain G] [--heavy Q] [--seed S]

All data comes from the twin population (`spectratac.sim.twin_dataset.population`).

(a) gain drift: one recipe (TrainSpec.best, --epochs) trained on --units units with and
    without gain_jitter=--jitter, scored (force MAE: mean of Fx, Fy, Fz MAE, N) on a new
    unit's session whose counts are scaled by 1 - gain, 1 and 1 + gain (an optical gain
    drift of +-15 % by default). Reference: the same recipe without jitter, same data.
(b) extrapolation: the paper recipe trained on the rows whose |F| lies in the lighter
    --heavy quantile (85 % by default) of the population's contact rows, with and without
    skip, scored on the heavier rows of the same sessions. Reference: without the skip.

Prints a table, or one JSON line per figure with --json.
"""

from __future__ import annotations

import sys
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "host"))

import benchlib
from spectratac.dataset.schema import Dataset
from spectratac.decode import DecoderUnitWarning
from spectratac.hardware.generated import vocabulary as vocab
from spectratac.sim.twin_dataset import population
from spectratac.train import TrainSpec, train

FORCES = vocab.FORCE_AXES
NEW_UNIT = 1000  # a unit seed far from the population's 1..N


def force_mae(dec, ds: Dataset, rows: np.ndarray) -> float:
    est = dec.predict(ds, rows)
    names = list(est.target_names)
    cols = [list(ds.target_names).index(a) for a in FORCES]
    y = np.asarray(ds.targets, np.float64)[rows][:, cols]
    p = est.targets[:, [names.index(a) for a in FORCES]]
    ok = np.asarray(ds.target_valid, bool)[rows] & np.all(np.isfinite(p), axis=1)
    return float(np.mean(np.abs(p[ok] - y[ok])))


def scaled(ds: Dataset, gain: float) -> Dataset:
    """The same session seen by a unit whose optical gain is `gain` times this one's."""
    arrays = {**ds.arrays, "inputs": np.asarray(ds.inputs, np.float64) * gain}
    return Dataset(arrays, dict(ds.meta))


def main() -> None:
    p = benchlib.parser(__doc__.splitlines()[0])
    p.add_argument("--units", type=int, default=4)
    p.add_argument("--session-s", type=float, default=300.0)
    p.add_argument("--epochs", type=int, default=10)
    p.add_argument("--jitter", type=float, default=0.15)
    p.add_argument("--gain", type=float, default=0.15)
    p.add_argument("--heavy", type=float, default=0.85)
    p.add_argument("--seed", type=int, default=0)
    args = p.parse_args()
    warnings.filterwarnings("ignore", category=DecoderUnitWarning)  # other units on purpose
    pop = population(range(1, args.units + 1), 1, args.session_s, seed=args.seed)
    test = population([NEW_UNIT], 1, args.session_s, seed=args.seed + 1)
    figures: list[benchlib.Figure] = []

    # (a) gain drift
    base = TrainSpec.best(epochs=args.epochs, seed=args.seed, gain_jitter=0.0)
    plain = train(pop, base, progress=False)
    jit = train(pop, replace(base, gain_jitter=args.jitter), progress=False)
    rows = np.arange(test.n)
    for g in (1.0 - args.gain, 1.0, 1.0 + args.gain):
        ds = scaled(test, g)
        ref, val = force_mae(plain, ds, rows), force_mae(jit, ds, rows)
        figures.append(
            benchlib.Figure(
                f"gain x{g:.2f}: best + gain_jitter={args.jitter}",
                val,
                "N",
                "without jitter",
                ref,
                val / ref,
                {"gain": g},
            )
        )

    # (b) extrapolation beyond the training force range
    f = np.asarray(pop.targets, np.float64)[:, [list(pop.target_names).index(a) for a in FORCES]]
    mag = np.linalg.norm(f, axis=1)
    contact = np.asarray(pop.in_contact, bool) & np.asarray(pop.target_valid, bool)
    cut = float(np.quantile(mag[contact], args.heavy))
    light, heavy = np.flatnonzero(mag <= cut), np.flatnonzero(contact & (mag > cut))
    paper = TrainSpec.paper(epochs=args.epochs, seed=args.seed)
    no_skip = train(pop, paper, light, progress=False)
    skip = train(pop, replace(paper, skip=True), light, progress=False)
    ref, val = force_mae(no_skip, pop, heavy), force_mae(skip, pop, heavy)
    figures.append(
        benchlib.Figure(
            f"|F| > {cut:.2f} N (heaviest {1 - args.heavy:.0%}): paper + skip",
            val,
            "N",
            "without skip",
            ref,
            val / ref,
            {"cut_N": cut, "n_heavy": int(heavy.size)},
        )
    )
    ref_in, val_in = force_mae(no_skip, pop, light), force_mae(skip, pop, light)
    figures.append(
        benchlib.Figure(
            "training range (lighter rows): paper + skip",
            val_in,
            "N",
            "without skip",
            ref_in,
            val_in / ref_in,
            {"n_light": int(light.size)},
        )
    )
    if args.json:
        benchlib.report(figures, True)
        return
    width = max(len(f.name) for f in figures)
    for f in figures:  # MAE of a few tenths of a newton: three decimals, not benchlib's one
        print(
            f"{f.name:<{width}}  {f.value:7.3f} {f.unit}  = {f.ratio:6.3f} x "
            f"{f.reference_name} ({f.reference_value:.3f} {f.unit})"
        )


if __name__ == "__main__":
    main()
