"""`spectratac evaluate MODEL DATA -o DIR`: score a trained decoder on a dataset.

Trains nothing. The model's metadata says which rows it was trained on (see
`spectratac.train.holdout`): on its own training dataset only the held-out rows of its
split are scored (the companion model named in the file scores the other split); on any other
dataset every row is held out; a model trained with --holdout-sessions is scored on the sessions
it left out. --holdout-sessions 3,4,7 (or 30-35) scores only those sessions, and refuses when
the model's metadata says it was trained on any of them. Data: a SpectraTac dataset .npz, or
any CSV / column .npz that `spectratac train` reads. Writes report.md, report.json and the
Fig. 3 panels to DIR, with the paper's figures and, for simulated data, the twin oracle's floor
beside ours, and the MAE per session.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

from spectratac.cli.exit_codes import ExitCode
from spectratac.cli.options import add_output, column_names
from spectratac.cli.outputs import check_output, new_folder
from spectratac.evaluate.metrics import COVERAGE_LEVELS


def register(subparsers: Any) -> None:
    p = subparsers.add_parser(
        "evaluate",
        help="score a trained decoder on a dataset; write a report (Fig. 3 panels)",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("model", help="decoder file (.stac)")
    p.add_argument("data", help="dataset .npz, or CSV / column .npz (as train reads them)")
    add_output(p, required=True, help="folder for the report")
    p.add_argument(
        "--split",
        choices=("random", "blocked", "both"),
        default="both",
        help="which split(s) to report when the data is the model's training set",
    )
    p.add_argument(
        "--holdout-sessions",
        metavar="IDS",
        help="score only these sessions, e.g. 3,4,7 or 30-35 (refused if trained on)",
    )
    p.add_argument(
        "--inputs", help="input channel columns of CSV / generic data (default: the model's)"
    )
    p.add_argument("--classes", help="class column of CSV / generic data (default: auto; '' none)")
    p.add_argument("--baseline", metavar="MODEL", help="another decoder scored on the same rows")
    p.add_argument(
        "--oracle-samples",
        type=int,
        default=500,
        metavar="N",
        help="rows the twin oracle decodes per split (simulated data; 0 turns it off)",
    )
    p.add_argument("--seed", type=int, default=0, help="seed of the oracle's subsample")
    p.add_argument("--json", action="store_true", help="print the report as one JSON object")
    p.add_argument("--no-progress", action="store_true")
    p.set_defaults(func=run)


VERB = "evaluate"


def report_files(names: list[str]) -> bool:
    """Whether an unmarked folder holds only an earlier report (made before the marker):
    report.json, report.md and its panels."""
    return {"report.json", "report.md"} <= set(names) and all(
        n in ("report.json", "report.md") or n.endswith(".png") for n in names
    )


def run(args: argparse.Namespace) -> int:
    from spectratac.apps.estimates import evaluation_estimate
    from spectratac.cli.eta import announce
    from spectratac.dataset.generic_io import load_data
    from spectratac.decode import Decoder
    from spectratac.evaluate.fit_both_splits import load_companions
    from spectratac.evaluate.report import write_report
    from spectratac.evaluate.run import evaluate_model, with_model_classes
    from spectratac.progress import bar as progress_bar
    from spectratac.studies.cost_model import with_oracle
    from spectratac.studies.oracle_floor import OracleFloor
    from spectratac.train.holdout import fingerprint, parse_sessions

    if args.oracle_samples < 0:
        from spectratac.errors import SpectraTacError

        raise SpectraTacError("--oracle-samples must be >= 0")
    sessions = None if args.holdout_sessions is None else parse_sessions(args.holdout_sessions)
    out = check_output(
        args.output,
        args.force,
        verb=VERB,
        inputs=(args.model, args.data, args.baseline),
        folder=True,
        recognise=report_files,
    )
    model = Decoder.load(args.model)
    inputs = column_names(args.inputs) or list(model.layout.channels)
    classes = None if args.classes is None else (column_names(args.classes) or [])
    dataset, class_note = with_model_classes(load_data([args.data], inputs, None, classes), model)
    companions = load_companions(model, args.model, Decoder.load)
    baseline = Decoder.load(args.baseline) if args.baseline else None
    kinds = ("random", "blocked") if args.split == "both" else (args.split,)
    if sessions is not None:
        kinds = ("sessions",)
    per = 1 + (baseline is not None) + (args.oracle_samples > 0)
    models = len(kinds) * (1 + (baseline is not None))
    # the user's model on the user's rows; the twin's inverse only where it runs (twin data)
    estimate = evaluation_estimate(model, dataset, models)
    estimate = with_oracle(estimate, dataset, len(kinds) * args.oracle_samples)
    if not args.json:
        announce("evaluate", estimate)
    bar = progress_bar(
        total=len(kinds) * per, desc="evaluate", unit="step", leave=False,
        enabled=not args.no_progress,
    )  # fmt: skip

    def tick(stage: str) -> None:
        bar.set_postfix_str(stage)
        bar.update(1)

    try:
        ev = evaluate_model(
            model,
            dataset,
            splits=kinds,
            sessions=sessions,
            companions=companions,
            baseline=baseline,
            floor=OracleFloor(args.oracle_samples) if args.oracle_samples > 0 else None,
            seed=args.seed,
            progress=tick,
        )
    finally:
        bar.close()
    if class_note:
        ev.notes.append(class_note)
    dataset_info = {
        "path": str(args.data),
        "rows": dataset.n,
        "fingerprint": fingerprint(dataset),
        "unit_id": dataset.meta.get("unit_id"),
        "config": dataset.meta.get("config"),
        "sessions": dataset.meta.get("sessions"),
    }
    model_info = {
        "path": str(args.model),
        "companions": {k: str(v) for k, v in _companion_files(model).items()},
        "baseline": args.baseline,
        "finetuned_from": (model.meta or {}).get("finetuned_from"),
    }
    with new_folder(out, VERB, recognise=report_files) as staged:
        rep = write_report(ev, staged, dataset_info, model_info, dataset)
    rep["estimate"] = estimate.as_dict()
    training = rep["sections"].get("training")
    if training is not None:  # in the terminal too, not only in report.md
        print(f"warning: evaluated on the model's own training rows: {training['note']}",
              file=sys.stderr)  # fmt: skip
    if args.json:
        print(json.dumps(rep))
    else:
        print(summary(rep, Path(args.output)))
    return ExitCode.OK


def _companion_files(model: Any) -> dict[str, str]:
    rec = (getattr(model, "meta", {}) or {}).get("holdout") or {}
    return dict(rec.get("companions") or {})


def _num(v: Any, digits: int = 4) -> str:
    return "–" if v is None else f"{v:.{digits}g}"


def summary(rep: dict[str, Any], out: Path) -> str:
    """Short human table per section; the full one is in report.md."""
    from spectratac.evaluate.paper import paper_mae
    from spectratac.evaluate.report import NO_CONTACT_LABELS

    paper = rep.get("paper") is not None  # the paper's figures: SpectraTac data only
    lines: list[str] = []
    for name, sec in rep["sections"].items():
        lines.append(f"{name}: {sec['note']}")
        if not sec["available"]:
            lines.append("")
            continue
        orc = sec.get("oracle", {}).get("components", {})
        base = sec.get("baseline", {}).get("components", {})
        head = f"  {'':<4} {'MAE':>9} {'RMSE':>9} {'R2':>7}" + (f" {'paper':>9}" if paper else "")
        lines.append(head + f" {'oracle':>9}" + (f" {'baseline':>9}" if base else ""))
        for comp, m in sec["decoder"]["components"].items():
            row = (
                f"  {comp:<4} {_num(m['mae']):>9} {_num(m['rmse']):>9} {_num(m['r2'], 3):>7}"
                + (f" {paper_mae(comp) or '–':>9}" if paper else "")
                + f" {_num(orc.get(comp, {}).get('mae')):>9}"
            )
            lines.append(row + (f" {_num(base.get(comp, {}).get('mae')):>9}" if base else ""))
        reg = sec["decoder"].get("region")
        if reg and reg["accuracy"] is not None:
            ref = " (paper 99.9 %)" if paper else ""
            lines.append(f"  region accuracy {100 * reg['accuracy']:.2f} %{ref}")
        con = sec["decoder"].get("contact")
        if con and con.get("labels") == "none":
            lines.append(f"  contact accuracy not scored ({NO_CONTACT_LABELS})")
        elif con and con["accuracy"] is not None:
            lines.append(f"  contact accuracy {100 * con['accuracy']:.2f} % ({con['source']})")
        cov = sec["decoder"].get("coverage")
        if cov:
            lv = "/".join(f"{100 * v:.0f} %" for v in COVERAGE_LEVELS)
            cells = ", ".join(
                f"{k} " + "/".join(f"{100 * (c.get(f'{v:g}') or 0):.0f}" for v in COVERAGE_LEVELS)
                for k, c in cov.items()
            )
            lines.append(f"  interval coverage (nominal {lv}): {cells}")
        per = sec.get("per_session") or {}
        if len(per) > 1:
            names = list(sec["decoder"]["components"])
            lines.append("  per session MAE: " + " ".join(f"{n:>7}" for n in names))
            for sid, d in per.items():
                cells = " ".join(f"{_num(d['mae'].get(n)):>7}" for n in names)
                unit = f" unit {d['unit']}" if d.get("unit") is not None else ""
                lines.append(f"    session {sid:>4} ({d['n']} rows{unit}): {cells}")
        lines.append("")
    lines.append(f"report: {out / 'report.md'} (+ report.json and PNG panels)")
    return "\n".join(lines)
