"""`spectratac bench decoder`: speed against error, or the improvements against the paper.

spectratac bench decoder [--quick] [--out DIR]              integration time x LED sequence
                                                            x model size: table + Pareto plot
spectratac bench decoder --variants [--quick] [--out DIR]   the paper's recipe vs temporal
                                                            context, drift baseline, contact
                                                            head, uncertainty, combination

Data: the twin's calibration scene (shortened; --duration), generated per setting. The full
runs take minutes on 2 cores; --quick takes seconds and its numbers mean nothing. The
benchmarks themselves live in `spectratac.studies.bench`, which tools/bench/ calls too.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

from spectratac.cli.options import add_force, refuse_overwrite
from spectratac.studies.bench.options import add_options


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
    add_force(d)
    d.add_argument("--json", action="store_true", help="print the result as one JSON object")
    d.add_argument("--no-progress", action="store_true")
    d.set_defaults(func=run)
    p.set_defaults(func=lambda args: (p.print_help(), 2)[1])


def run(args: argparse.Namespace) -> int:
    from spectratac.studies.bench import config_from_args, run_with_progress

    out = Path(args.out)
    config = config_from_args(args)  # bad settings first: they say more than "it exists"
    refuse_overwrite(out, args.force)
    res = run_with_progress(config, out, args.variants, show=not args.no_progress)
    name = "decoder_variants" if args.variants else "decoder_speed"
    if args.json:
        print(json.dumps(res))
    else:
        print((out / f"{name}.md").read_text())
        print(f"written: {out / (name + '.md')}, {out / (name + '.json')}")
    return 0
