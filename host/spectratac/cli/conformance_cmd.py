"""`spectratac conformance URL`: run the protocol conformance suite against a device."""

from __future__ import annotations

import argparse
import json

from spectratac.cli.exit_codes import ExitCode
from spectratac.cli.options import add_device_url


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser("conformance", help="check a device against the protocol")
    add_device_url(p)
    p.add_argument("--json", action="store_true", help="one JSON object with every check")
    p.set_defaults(func=_run)


def _run(args: argparse.Namespace) -> int:
    from spectratac.conformance import run_suite

    def show(name: str, outcome: object) -> None:
        if not args.json:
            print(
                f"{'PASS' if outcome.passed else 'FAIL'}  {name:<46} {outcome.detail}", flush=True
            )

    result = run_suite(args.url, timeout=args.timeout, progress=show)
    if args.json:
        print(json.dumps(result.as_dict()))
    else:
        passed = sum(o.passed for _, o in result.rows)
        print(f"{passed}/{len(result.rows)} checks passed against {args.url}")
    return ExitCode.OK if result.passed else ExitCode.FAILURE
