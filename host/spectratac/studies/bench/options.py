"""Command-line options of the decoder benchmarks (`tools/bench/decoder.py`), kept beside the
library so that its settings and its options cannot drift apart.

>>> import argparse
>>> p = argparse.ArgumentParser()
>>> add_options(p)
>>> cfg = config_from_args(p.parse_args(["--quick", "--models", "linear", "--seed", "3"]))
>>> cfg.models, cfg.seed, cfg.duration_s
(('linear',), 3, 40.0)
>>> config_from_args(p.parse_args(["--epochs", "0"]))
Traceback (most recent call last):
...
spectratac.errors.SpectraTacError: --epochs must be >= 1
"""

from __future__ import annotations

import argparse
from dataclasses import replace
from typing import Any

from spectratac.errors import SpectraTacError
from spectratac.studies.bench.acquisition import Acquisition
from spectratac.studies.bench.decoder import BenchConfig
from spectratac.studies.bench.speed import MODELS
from spectratac.studies.bench.variants import VARIANTS


def add_options(d: argparse.ArgumentParser) -> None:
    """Add the options every decoder benchmark entry point takes."""
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


def config_from_args(args: argparse.Namespace) -> BenchConfig:
    """The `BenchConfig` the parsed options ask for; SpectraTacError names a bad value."""
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
