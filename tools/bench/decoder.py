"""Decoder benchmarks on twin calibration data, through the library `spectratac.studies.bench`.

    python -m tools.bench.decoder [--quick] [--out DIR] [--json] [--duration S] ...
    python -m tools.bench.decoder --variants [--quick] [--only VARIANT ...] ...

Speed against error (default): integration time (50/100/200/400 ms) x LED sequencing (white;
R, G, B steps; one step per LED) x model size (linear, small MLP, the paper's ResMLP, larger),
on one twin calibration scene. Writes decoder_speed.md, decoder_speed.json and
decoder_speed_pareto.png into --out. Figures: single-sample latency and training time of every
point as ratios to the paper's setting (50 ms, white, ResMLP) measured side by side in the same
run; MAE and observation rate ride along in `extra`.

--variants: the paper's decoding recipe against each improvement beyond it (temporal context,
drift baseline, contact head, calibrated uncertainty, their combination) on the same data and
the same blocked and random splits. Writes decoder_variants.md and decoder_variants.json.
Figures: per variant, the MAE per force axis and the single-sample latency as ratios to the
paper's recipe trained and timed in the same run; plus the target check (>= 25 % lower blocked
MAE per force axis at no more flops).
"""

from __future__ import annotations

from pathlib import Path

from spectratac.errors import SpectraTacError
from spectratac.hardware.generated import vocabulary as vocab
from spectratac.studies.bench import add_options, config_from_args, run_with_progress

from tools.bench import benchlib


def speed_figures(result: dict) -> list[benchlib.Figure]:
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


def variant_figures(result: dict) -> list[benchlib.Figure]:
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
    p.add_argument("--variants", action="store_true", help="improvements vs the paper's recipe")
    args = p.parse_args()
    try:
        config = config_from_args(args)
    except SpectraTacError as exc:
        p.error(str(exc))
    result = run_with_progress(config, Path(args.out), variants=args.variants)
    name = "decoder_variants" if args.variants else "decoder_speed"
    if not args.json:
        print((Path(args.out) / f"{name}.md").read_text())
    figures = variant_figures(result) if args.variants else speed_figures(result)
    benchlib.report(figures, args.json)


if __name__ == "__main__":
    main()
