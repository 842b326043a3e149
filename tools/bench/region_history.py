"""Benchmark: the best decoder's region accuracy against the paper recipe's on the demo's
blocked split, with and without teaching the region on swapped history
(TrainSpec.region_history_swap).

    .venv/bin/python tools/bench/region_history.py DEMO_DIR [DEMO_DIR ...] [--json]
        [--swaps 0,0.5] [--no-context] [--epochs N]

Each DEMO_DIR is a `spectratac demo` output folder (its data.npz; `spectratac demo --seed N
-o DIR` makes one per seed). Per folder, on the demo's own clock and blocked split (the
demo's seed, read from the recording's URL), trains as `make demo` does (40 epochs, the
seed as training seed): the paper's recipe (the reference), `TrainSpec.best()` at each
--swaps share, and with --no-context best() without temporal context (the diagnosis: the
same network without history). Prints blocked region accuracy beside the recipe's, the
force MAE gain over the recipe, and where best's wrong rows sit in their press (first and
last fifth against the steady part between).
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "host"))

import benchlib
from spectratac.apps.calibration_demo import on_scene_clock
from spectratac.dataset import Dataset
from spectratac.evaluate.predictions import predict
from spectratac.hardware.generated import vocabulary as vocab
from spectratac.train import TrainSpec, train
from spectratac.train.groups import SplitSpec, split_dataset

EDGE = 0.2  # the first and last fifth of a press's labelled rows: onset and release


def demo_scene(ds: Dataset) -> tuple[int, float]:
    """(seed, scene seconds) of the demo's recording, from its sim:// URL (the demo trains
    with the same seed)."""
    for s in ds.meta.get("sessions", []):
        url = str(s.get("url") or "")
        seed, duration = re.search(r"[?&]seed=(\d+)", url), re.search(r"[?&]duration=([\d.]+)", url)
        if seed and duration:
            return int(seed.group(1)), float(duration.group(1))
    raise SystemExit(
        "no seed and duration in the recording's URL: is this a `spectratac demo` folder?"
    )


def press_phase(rows: np.ndarray, labels: np.ndarray, press: np.ndarray) -> np.ndarray:
    """Each labelled row's place in its run of labelled rows of one press, in (0, 1)."""
    phase = np.full(rows.size, np.nan)
    start = None
    for k in range(rows.size + 1):
        run_on = k < rows.size and labels[k] > 0
        same = run_on and start is not None and rows[k] == rows[k - 1] + 1
        same = same and press[rows[k]] == press[rows[k - 1]]
        if start is not None and not same:
            n = k - start
            phase[start:k] = (np.arange(n) + 0.5) / n
            start = None
        if run_on and start is None:
            start = k
    return phase


def scores(model, ds: Dataset, rows: np.ndarray) -> dict:
    p = predict(model, ds, rows)
    labels = np.asarray(ds.region)[rows]
    lab = labels > 0
    wrong = lab & (p.region != labels)
    phase = press_phase(rows, labels, np.asarray(ds.press))
    edge = lab & ((phase < EDGE) | (phase > 1 - EDGE))
    names = list(ds.target_names)
    cols = [names.index(a) for a in vocab.FORCE_AXES]
    y = np.asarray(ds.targets, np.float64)[rows][:, cols]
    ok = np.asarray(ds.target_valid, bool)[rows]
    est = p.aligned(list(vocab.FORCE_AXES))
    return {
        "region": float(np.mean(p.region[lab] == labels[lab])),
        "mae": np.mean(np.abs(est[ok] - y[ok]), axis=0),
        "wrong_edge": int(np.sum(wrong & edge)),
        "wrong_steady": int(np.sum(wrong & lab & ~edge)),
    }


def main() -> None:
    p = benchlib.parser(__doc__.splitlines()[0])
    p.add_argument("demo_dirs", nargs="+", type=Path)
    p.add_argument("--swaps", default="0,0.5", help="region_history_swap shares of best()")
    p.add_argument("--no-context", action="store_true", help="also best() without context")
    p.add_argument("--epochs", type=int, default=40)
    args = p.parse_args()
    figures: list[benchlib.Figure] = []
    for folder in args.demo_dirs:
        ds = Dataset.load(folder / "data.npz")
        seed, scene_s = demo_scene(ds)
        ds = on_scene_clock(ds, scene_s)
        split = split_dataset(ds, SplitSpec("blocked", seed=seed))
        rows, train_rows = np.sort(split.test), split.train
        ref = scores(train(ds, TrainSpec.paper(epochs=args.epochs, seed=seed), train_rows,
                           progress=False), ds, rows)  # fmt: skip
        variants = {
            f"best swap {s:g}": TrainSpec.best(epochs=args.epochs, seed=seed, region_history_swap=s)
            for s in (float(v) for v in args.swaps.split(","))
        }
        if args.no_context:
            variants["best without context"] = TrainSpec.best(
                epochs=args.epochs, seed=seed, context=0, context_ema=()
            )
        for name, spec in variants.items():
            got = scores(train(ds, spec, train_rows, progress=False), ds, rows)
            gains = 100.0 * (1.0 - got["mae"] / ref["mae"])
            figures.append(
                benchlib.Figure(
                    f"seed {seed} {name}: blocked region accuracy",
                    100.0 * got["region"],
                    "%",
                    "paper recipe",
                    100.0 * ref["region"],
                    got["region"] / ref["region"],
                    {
                        "mae_gain_pct": dict(
                            zip(vocab.FORCE_AXES, gains.round(1).tolist(), strict=True)
                        ),
                        "wrong_rows_edge_steady": [got["wrong_edge"], got["wrong_steady"]],
                        "recipe_wrong_rows_edge_steady": [ref["wrong_edge"], ref["wrong_steady"]],
                    },
                )
            )
            if not args.json:
                print(
                    f"seed {seed} {name:22} region {100 * got['region']:5.1f} % (recipe "
                    f"{100 * ref['region']:5.1f} %); force MAE gain "
                    + " ".join(
                        f"{a} {g:+.0f}%" for a, g in zip(vocab.FORCE_AXES, gains, strict=True)
                    )
                    + f"; wrong rows onset/release {got['wrong_edge']}, steady "
                    f"{got['wrong_steady']} (recipe {ref['wrong_edge']}, {ref['wrong_steady']})",
                    flush=True,
                )
    if args.json:
        benchlib.report(figures, True)


if __name__ == "__main__":
    main()
