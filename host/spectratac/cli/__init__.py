"""`spectratac <verb>`: the command-line entry point.

Each verb lives in its own module exposing ``register(subparsers)``; the module sets
``func`` on its parser, which returns the process exit code. Modules are imported lazily
by name so that a verb's heavy dependencies (torch, matplotlib) load only when it runs.
"""

from __future__ import annotations

import argparse
import importlib
import sys
from collections.abc import Sequence

from spectratac import __version__
from spectratac.errors import SpectraTacError

# Exit codes shared by all verbs.
EXIT_OK = 0
EXIT_FAILURE = 1  # the command ran but its check failed (e.g. a conformance test)
EXIT_USAGE = 2  # bad arguments (argparse's own convention)
EXIT_ERROR = 3  # a SpectraTacError: bad input, device problem; message says what to do

# Verb modules under spectratac.cli, in the order they appear in --help.
VERB_MODULES: tuple[str, ...] = (
    "device_cmd",
    "sim_cmd",
    "conformance_cmd",
    "demo_cmd",
    "protocol_cmd",
    "twin_cmd",
    "ft_cmd",
    "record_cmd",
    "dataset_cmd",
    "evaluate_cmd",
    "bench_cmd",
    "train_cmd",
    "decode_cmd",
    "live_cmd",
    "snake_cmd",
)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="spectratac",
        description="Toolkit for the SpectraTac optical tactile sensor.",
    )
    parser.add_argument("--version", action="version", version=f"spectratac {__version__}")
    subparsers = parser.add_subparsers(dest="verb", metavar="<verb>")
    for name in VERB_MODULES:
        importlib.import_module(f"spectratac.cli.{name}").register(subparsers)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if not hasattr(args, "func"):
        parser.print_help()
        return EXIT_USAGE
    try:
        return int(args.func(args))
    except SpectraTacError as exc:
        print(f"spectratac {args.verb}: error: {exc}", file=sys.stderr)
        return EXIT_ERROR
    except KeyboardInterrupt:
        return 130


if __name__ == "__main__":
    sys.exit(main())
