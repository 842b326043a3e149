"""`spectratac <verb>`: the command-line entry point.

Each verb lives in its own module exposing ``register(subparsers)``; the module sets
``func`` on its parser, which returns the process exit code (an ExitCode). Verbs raise
SpectraTacErrors, which main() reports and maps to exit codes in one place. Modules are
imported lazily by name so that a verb's heavy dependencies (torch, matplotlib) load only
when it runs.
"""

from __future__ import annotations

import argparse
import importlib
import sys
import warnings
from collections.abc import Sequence

from spectratac import __version__, threads
from spectratac.cli.exit_codes import ExitCode, exit_code_for
from spectratac.cli.options import show_defaults
from spectratac.cli.values import check_values
from spectratac.errors import SpectraTacError

# Verb modules under spectratac.cli, in the order they appear in --help.
VERB_MODULES: tuple[str, ...] = (
    "device_cmd",
    "flash_cmd",
    "model_cmd",
    "sim_cmd",
    "conformance_cmd",
    "bringup_cmd",
    "demo_cmd",
    "protocol_cmd",
    "twin_cmd",
    "ft_cmd",
    "record_cmd",
    "dataset_cmd",
    "export_cmd",
    "evaluate_cmd",
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
    check_values(parser)  # every option's range and text checks, in one place
    show_defaults(parser)
    _full_spellings_only(parser)
    return parser


def _full_spellings_only(parser: argparse.ArgumentParser) -> None:
    """Turn off argparse's prefix matching in `parser` and its sub-verbs: an option has the
    one spelling --help shows (a prefix such as --out would be a second name of --output)."""
    parser.allow_abbrev = False
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for child in action.choices.values():
                _full_spellings_only(child)


def _one_line(message: Warning | str, category: type[Warning], *_: object, **__: object) -> None:
    from spectratac.cli.options import warn

    warn(str(message))


def command(args: argparse.Namespace) -> str:
    """The verb and sub-verb that ran, e.g. 'ft info' (sub-verb dests end in _verb)."""
    subs = [v for k, v in vars(args).items() if k.endswith("_verb") and isinstance(v, str)]
    return " ".join([args.verb, *subs])


def main(argv: Sequence[str] | None = None) -> int:
    """Run one verb; returns its exit code (see spectratac.cli.exit_codes)."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        # Before any verb imports torch (training, sim servers, benchmarks): see threads.py.
        threads.apply()
    except SpectraTacError as exc:
        print(f"spectratac: error: {exc}", file=sys.stderr)
        return ExitCode.USAGE
    if not hasattr(args, "func"):
        parser.print_help()
        return ExitCode.USAGE
    try:
        with warnings.catch_warnings():
            warnings.showwarning = _one_line  # a SpectraTac warning says what to do: no file:line
            return int(args.func(args))
    except SpectraTacError as exc:
        print(f"spectratac {command(args)}: error: {exc}", file=sys.stderr)
        return exit_code_for(exc)
    except KeyboardInterrupt as exc:
        return exit_code_for(exc)


if __name__ == "__main__":
    sys.exit(main())
