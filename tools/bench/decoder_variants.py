"""Benchmark: the paper's decoding recipe against each improvement beyond the paper
(temporal context, drift baseline, contact head, calibrated uncertainty, their combination)
on the same twin calibration data and the same blocked and random splits.

    .venv/bin/python tools/bench/decoder_variants.py [--quick] [--out DIR] [--json]
        [--duration S] [--epochs N] [--only VARIANT ...]

Writes decoder_variants.md and decoder_variants.json into --out. Figures: per variant, the
blocked-split MAE per force axis and the single-sample latency as ratios to the paper's
recipe trained and timed side by side in the same run; plus the target check
(>= 25 % lower blocked MAE per force axis at no more flops). Same as
`spectratac bench decoder --variants`.
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "host"))

import benchlib
from spectratac.hardware.generated import vocabulary as vocab
from spectratac.studies.bench import add_options, config_from_args, run_with_progress


def figures(result: dict) -> list[benchlib.Figure]:
    rows = result["rows"]
    ref = next(r for r in rows if r["name"] == "paper")
    out = []
    for r in rows:
        for kind in ("blocked", "random"):
            if kind not in r:
                continue
            for axis in vocab.FORCE_AXES:
                v, rv = r[kind]["mae"][axis], ref[kind]["mae"][axis]
                out.append(
                    benchlib.Figure(
                        f"{r['name']} {kind} {axis} MAE",
                        v,
                        "N",
                        f"paper {kind} {axis} MAE",
                        rv,
                        v / rv if rv else float("nan"),
                        {"improvement_pct": r[kind].get("improvement_pct", {}).get(axis)},
                    )
                )
        out.append(
            benchlib.Figure(
                f"{r['name']} latency",
                r["latency_us"],
                "µs",
                "paper latency",
                ref["latency_us"],
                r["latency_ratio"],
                {"flops": r["flops"], "paper_flops": ref["flops"], "p99_us": r["latency_p99_us"]},
            )
        )
    chk = result["target"]
    best = chk.get("improvement_pct") or chk.get("best_overall_improvement_pct", {})
    worst = min(best.values()) if best else float("nan")
    out.append(
        benchlib.Figure(
            "target: worst force-axis MAE reduction of the best variant",
            worst,
            "%",
            "target",
            chk.get("target_pct", 25.0),
            worst / chk.get("target_pct", 25.0),
            {k: v for k, v in chk.items() if k != "improvement_pct"} | {"per_axis": best},
        )
    )
    return out


def main() -> None:
    p = benchlib.parser(__doc__.splitlines()[0])
    add_options(p)
    args = p.parse_args()
    result = run_with_progress(config_from_args(args), Path(args.out), variants=True)
    if not args.json:
        print((Path(args.out) / "decoder_variants.md").read_text())
    benchlib.report(figures(result), args.json)


if __name__ == "__main__":
    main()
