"""`spectratac bringup URL`: the bring-up plan of a new board as one command: identity, clock,
reset cause, sensors, sample rates, each LED channel, model store, a soak and the watchdog,
each check pass, fail or skipped with its reason, with what it measured. Text for a person,
`--json` for machines, `-o report.json` to file with the board."""

from __future__ import annotations

import argparse
import json
from typing import Any

from spectratac import progress
from spectratac.cli.exit_codes import ExitCode
from spectratac.cli.options import add_device_url, add_output, refuse_overwrite
from spectratac.cli.outputs import new_file


def register(subparsers: argparse._SubParsersAction) -> None:
    from spectratac.conformance.bringup import SOAK_S

    p = subparsers.add_parser(
        "bringup", help="check a new board step by step: a pass/fail report to file with it"
    )
    add_device_url(p)
    p.add_argument("--json", action="store_true", help="the report as one JSON object")
    add_output(p, help="also write the report as JSON to this file (e.g. board1-bringup.json)")
    p.add_argument(
        "--soak",
        type=float,
        default=SOAK_S,
        metavar="S",
        help=f"seconds of the device's clock to stream in the soak, 0 to skip it "
        f"(default {SOAK_S:g})",
    )
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=_run)


def _run(args: argparse.Namespace) -> int:
    from spectratac.conformance.bringup import Report, is_report, plan, run_bringup

    if args.output is not None:
        refuse_overwrite(args.output, args.force, verb="bringup", kind=is_report)
    report = Report(args.url, {})
    bar = progress.bar(
        total=len(plan(args.soak)),
        desc="bring-up",
        unit="check",
        enabled=not (args.no_progress or args.json),
    )

    def show(name: str, row: Any) -> None:
        if row is None:
            bar.set_postfix_str(name)
        else:
            bar.update(1)

    try:
        run_bringup(args.url, args.timeout, args.soak, show, into=report)
    except KeyboardInterrupt:
        _write(args.output, report.as_dict())  # the checks done so far are kept
        raise
    finally:
        bar.close()
    _write(args.output, report.as_dict())
    print(json.dumps(report.as_dict()) if args.json else report.text(), flush=True)
    return ExitCode.OK if report.passed else ExitCode.FAILURE


def _write(path: str | None, data: dict[str, Any]) -> None:
    if path is None:
        return
    with new_file(path) as tmp:
        tmp.write_text(json.dumps(data, indent=1) + "\n", encoding="utf-8")
