"""`spectratac train g.npz --finetune base.stac -o unit.stac` on data without force targets
(a guided session recorded without a reference F/T): the adaptation of
`spectratac.train.unlabelled`, its figures, and what it could not adapt.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

from spectratac.cli.exit_codes import ExitCode
from spectratac.cli.outputs import new_file


def run(args: argparse.Namespace, ds: Any, out: Path) -> int:
    from spectratac.decode import Decoder
    from spectratac.train.unlabelled import adapt_without_targets

    base = Decoder.load(args.finetune)
    if not args.json:
        print(
            f"{args.finetune}: this data has region labels and no force targets (no reference "
            "F/T): adapting what the labels teach",
            file=sys.stderr,
        )
    epochs = {} if args.epochs is None else {"epochs": args.epochs}
    dec, report = adapt_without_targets(
        base, ds, seed=args.seed or 0, progress=not args.no_progress, **epochs
    )
    with new_file(out) as tmp:
        dec.save(tmp)
    summary = {
        "model": str(out),
        "finetuned_from": str(args.finetune),
        "targets": "none",
        "forces": dec.meta["finetuned_from"]["forces"],
        "adapted": report.adapted,
        "not_adapted": report.not_adapted,
        **report.figures,
    }
    if args.json:
        print(json.dumps(summary))
    else:
        print(_human(summary))
    return ExitCode.OK


def _human(s: dict[str, Any]) -> str:
    forces = {"rest": "the base's, offset so that this unit's rest reads zero",
              "kept": "the base's as they are"}[s["forces"]]  # fmt: skip
    lines = [
        f"adapted {s['finetuned_from']} to this unit without a reference F/T",
        f"  adapted: {', '.join(s['adapted'])}",
        f"  region accuracy on the labelled presses it trained on: "
        f"{100 * s['region_before']:.1f} % -> {100 * s['region_after']:.1f} %",
        f"  estimates out of distribution on the session: {100 * s['ood_before']:.1f} % -> "
        f"{100 * s['ood_after']:.1f} %",
        f"  forces: {forces} (Fz at rest {s['rest_force_before'][2]:+.3f} N before)",
        "  could not adapt (no force targets):",
        *(f"    - {what}" for what in s["not_adapted"]),
        "  to adapt forces too, record this unit against a reference F/T (record --ft) and "
        "fine-tune on that",
        f"  wrote model: {s['model']}",
    ]
    return "\n".join(lines)
