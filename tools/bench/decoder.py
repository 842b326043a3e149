"""Benchmark: decoder speed against error over integration time (50/100/200/400 ms), LED
sequencing (white; R, G, B steps; one step per LED) and model size (linear, small MLP, the
paper's ResMLP, larger), on one twin calibration scene.

    .venv/bin/python tools/bench/decoder.py [--quick] [--out DIR] [--json] [--duration S]

Writes decoder_speed.md, decoder_speed.json and decoder_speed_pareto.png into --out. Figures:
single-sample latency and training time of every point as ratios to the paper's setting
(50 ms, white, ResMLP) measured side by side in the same run; MAE and observation rate ride
along in `extra`. Same as `spectratac bench decoder`.
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "host"))

import benchlib
from spectratac.studies.bench import add_options, config_from_args, run_with_progress


def figures(result: dict) -> list[benchlib.Figure]:
    rows = result["rows"]
    ref_name = rows[0]["reference"]
    ref = next(r for r in rows if f"{r['acquisition']}/{r['model']}" == ref_name)
    out = []
    for r in rows:
        name = f"{r['acquisition']}/{r['model']}"
        extra = {
            "observations_per_s": r["observations_per_s"],
            "mae": r["mae"],
            "force_mae_mean": r["force_mae_mean"],
            "r2_mean": r["r2_mean"],
            "region_accuracy": r["region_accuracy"],
            "params": r["params"],
            "flops": r["flops"],
            "latency_p99_us": r["latency_p99_us"],
            "pareto": bool(r.get("pareto")),
        }
        out.append(
            benchlib.Figure(
                f"{name} latency",
                r["latency_us"],
                "µs",
                f"{ref_name} latency",
                ref["latency_us"],
                r["latency_ratio"],
                extra,
            )
        )
        out.append(
            benchlib.Figure(
                f"{name} training",
                r["train_s"],
                "s",
                f"{ref_name} training",
                ref["train_s"],
                r["train_ratio"],
                {"n_train": r["n_train"]},
            )
        )
    return out


def main() -> None:
    p = benchlib.parser(__doc__.splitlines()[0])
    add_options(p)
    args = p.parse_args()
    result = run_with_progress(config_from_args(args), Path(args.out), variants=False)
    if not args.json:
        print((Path(args.out) / "decoder_speed.md").read_text())
    benchlib.report(figures(result), args.json)


if __name__ == "__main__":
    main()
