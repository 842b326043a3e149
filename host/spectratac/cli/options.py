"""The options several verbs share, spelled once: a device URL with its --timeout, the output
path (-o/--output), the row formats of the streaming verbs, and old spellings of renamed
options (hidden, still accepted for one release, with a warning on stderr).

>>> p = argparse.ArgumentParser(prog="spectratac x")
>>> add_output(p, help="file to write", renamed_from=("--out",))
>>> p.parse_args(["-o", "a.npz"]).output
'a.npz'
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from typing import Any

from spectratac.cli.exit_codes import UsageError

DEVICE_URL_HELP = "serial port, socket://host:port, rfc2217://…, or sim://…"
DEFAULT_TIMEOUT_S = 2.0
ROW_FORMATS = ("table", "csv", "jsonl")
# Parser default naming the options that must be given (by either spelling); see require().
REQUIRED_KEY = "required_options"


class RenamedOption(argparse.Action):
    """The old spelling of a renamed option: hidden from --help, stores into the new one's
    dest and says on stderr which spelling to use instead."""

    def __init__(
        self,
        option_strings: Sequence[str],
        dest: str,
        *,
        replacement: str,
        nargs: Any = None,
        const: Any = None,
        **kwargs: Any,
    ) -> None:
        kwargs.setdefault("default", argparse.SUPPRESS)  # the new spelling sets the default
        super().__init__(option_strings, dest, nargs=nargs, const=const, **kwargs)
        self.help = argparse.SUPPRESS
        self.replacement = replacement

    def __call__(
        self,
        parser: argparse.ArgumentParser,
        namespace: argparse.Namespace,
        values: Any,
        option_string: str | None = None,
    ) -> None:
        old = option_string or f"the positional {self.metavar or self.dest}"
        print(
            f"{parser.prog}: warning: {old} is deprecated; use {self.replacement}",
            file=sys.stderr,
        )
        setattr(namespace, self.dest, self.const if self.nargs == 0 else values)


def add_renamed(
    parser: argparse._ActionsContainer, old: str, dest: str, replacement: str, **kwargs: Any
) -> None:
    """Keep `old` working as a hidden alias of the option now spelled `replacement`."""
    parser.add_argument(old, dest=dest, action=RenamedOption, replacement=replacement, **kwargs)


def add_output(
    parser: argparse.ArgumentParser,
    *,
    help: str,
    required: bool = False,
    default: Any = None,
    type: Any = None,
    renamed_from: Sequence[str] = (),
) -> None:
    """-o/--output: where a verb writes its file or folder (the one spelling for every verb).
    Old spellings in `renamed_from` stay accepted; `required` is then checked by require()."""
    parser.add_argument(
        "-o",
        "--output",
        required=required and not renamed_from,
        default=default,
        type=type,
        metavar="PATH",
        help=help,
    )
    for old in renamed_from:
        add_renamed(parser, old, "output", "-o/--output", type=type)
    if required and renamed_from:
        parser.set_defaults(**{REQUIRED_KEY: {"output": "-o/--output"}})


def require(args: argparse.Namespace) -> None:
    """Raise UsageError for a required option given by neither its new nor its old name."""
    for dest, spelling in getattr(args, REQUIRED_KEY, {}).items():
        if getattr(args, dest, None) is None:
            raise UsageError(f"the following arguments are required: {spelling}")


def add_device_url(parser: argparse.ArgumentParser, help: str = DEVICE_URL_HELP) -> None:
    """The device URL positional and --timeout, which every verb that opens a device takes."""
    parser.add_argument("url", help=help)
    parser.add_argument(
        "--timeout",
        type=float,
        default=DEFAULT_TIMEOUT_S,
        metavar="S",
        help=f"seconds to wait for the device (default {DEFAULT_TIMEOUT_S:g})",
    )


def add_row_format(parser: argparse.ArgumentParser) -> None:
    """--format table|csv|jsonl of the verbs that stream rows (see output.RowWriter)."""
    parser.add_argument("--format", choices=ROW_FORMATS, default="table", help="row format")


def add_count(parser: argparse._ActionsContainer, default: int | None, help: str) -> None:
    """--count N: how many samples/records/estimates a verb handles before it stops."""
    parser.add_argument("--count", type=int, default=default, metavar="N", help=help)


def add_duration(parser: argparse._ActionsContainer, default: float | None, help: str) -> None:
    """--duration S: how long a verb runs (or how long a scene lasts), in seconds."""
    parser.add_argument("--duration", type=float, default=default, metavar="S", help=help)
