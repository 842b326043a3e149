"""`spectratac bench decoder`: speed against error, or the improvements against the paper.

spectratac bench decoder [--quick] [--out DIR]              integration time x LED sequence
                                                            x model size: table + Pareto plot
spectratac bench decoder --variants [--quick] [--out DIR]   the paper's recipe vs temporal
                                                            context, drift baseline, contact
                                                            head, uncertainty, combination

Data: the twin's calibration scene (shortened; --duration), generated per setting. The full
runs take minutes on 2 cores; --quick takes seconds and its numbers mean nothing.
"""

from __future__ import annotations

import argparse
import json
import sys
from dataclasses import replace
from pathlib import Path
from typing import Any


def register(subparsers: Any) -> None:
    p = subparsers.add_parser(
        "bench",
        help="decoder benchmarks: speed vs error, improvements vs the paper's recipe",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    sub = p.add_subparsers(dest="bench_verb", metavar="<benchmark>")
    d = sub.add_parser("decoder", help="speed against error (default) or --variants")
    d.add_argument("--variants", action="store_true", help="improvements vs the paper's recipe")
    add_options(d)
    d.add_argument("--json", action="store_true", help="print the result as one JSON object")
    d.add_argument("--no-progress", action="store_true")
    d.set_defaults(func=run)
    p.set_defaults(func=lambda args: (p.print_help(), 2)[1])


def add_options(d: argparse.ArgumentParser) -> None:
    """Options shared with tools/bench/decoder.py and tools/bench/decoder_variants.py."""
    d.add_argument("--quick", action="store_true", help="tiny run for tests (seconds)")
    d.add_argument("--out", default="build/bench-decoder", help="output folder (tables, plot)")
    d.add_argument("--duration", type=float, help="calibration scene length in s")
    d.add_argument("--epochs", type=int, help="training epochs per model")
    d.add_argument("--seed", type=int, default=0)
    d.add_argument("--integration", type=int, nargs="+", help="subset of 50 100 200 400")
    d.add_argument("--sequences", nargs="+", help="subset of white rgb per-led")
    d.add_argument("--models", nargs="+", help="subset of linear mlp resmlp resmlp-large")
    d.add_argument("--only", nargs="+", metavar="VARIANT", help="variants besides 'paper'")
    d.add_argument(
        "--full-grid", action="store_true", help="train resmlp-large on every LED sequence too"
    )


def config(args: argparse.Namespace) -> Any:
    from spectratac.errors import SpectraTacError
    from spectratac.evaluate.acquisition import Acquisition
    from spectratac.evaluate.benches import BenchConfig
    from spectratac.evaluate.speed import MODELS
    from spectratac.evaluate.variants import VARIANTS

    cfg = BenchConfig.quick() if args.quick else BenchConfig()
    changes: dict[str, Any] = {"seed": args.seed, "full_grid": args.full_grid}
    if args.duration is not None:
        if args.duration < 20:
            raise SpectraTacError("--duration must be >= 20 s (a few presses per split)")
        changes["duration_s"] = args.duration
    if args.epochs is not None:
        if args.epochs < 1:
            raise SpectraTacError("--epochs must be >= 1")
        changes["epochs"] = args.epochs
    if args.integration:
        for it in args.integration:
            Acquisition(it)  # raises with the allowed values
        changes["integrations"] = tuple(args.integration)
    if args.sequences:
        for s in args.sequences:
            Acquisition(50, s)
        changes["sequences"] = tuple(args.sequences)
    if args.models:
        bad = [m for m in args.models if m not in MODELS]
        if bad:
            raise SpectraTacError(f"unknown models {bad}: choose from {', '.join(MODELS)}")
        changes["models"] = tuple(args.models)
    if args.only:
        bad = [v for v in args.only if v not in VARIANTS]
        if bad:
            raise SpectraTacError(f"unknown variants {bad}: choose from {', '.join(VARIANTS)}")
        changes["variants"] = tuple(args.only)
    return replace(cfg, **changes)


def planned_points(cfg: Any) -> list[tuple[int, str, str]]:
    """(integration, sequence, model) triples the speed bench will train."""
    from spectratac.evaluate.speed import HEAVY

    return [
        (i, s, m)
        for i in cfg.integrations
        for s in cfg.sequences
        for m in cfg.models
        if cfg.full_grid or m not in HEAVY or s == "white"
    ]


def run_with_progress(cfg: Any, out: Path, variants: bool, show: bool = True) -> dict:
    """Run the speed (or, with `variants`, the variants) benchmark with a progress bar on
    stderr, one step per trained model; shared by this command and tools/bench/."""
    from tqdm import tqdm

    from spectratac.evaluate.benches import speed_bench, variants_bench

    points = len({"paper", *cfg.variants}) if variants else len(planned_points(cfg))
    bar = tqdm(
        total=points + 1,  # + the latency / oracle stage
        desc="bench decoder",
        unit="model",
        file=sys.stderr,
        leave=False,
        disable=not show,
    )

    def tick(stage: str) -> None:
        bar.set_postfix_str(stage)
        bar.update(1)

    try:
        return (variants_bench if variants else speed_bench)(cfg, out, tick)
    finally:
        bar.close()


def run(args: argparse.Namespace) -> int:
    out = Path(args.out)
    res = run_with_progress(config(args), out, args.variants, show=not args.no_progress)
    name = "decoder_variants" if args.variants else "decoder_speed"
    if args.json:
        print(json.dumps(res))
    else:
        print((out / f"{name}.md").read_text())
        print(f"written: {out / (name + '.md')}, {out / (name + '.json')}")
    return 0
