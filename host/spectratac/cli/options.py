"""The options several verbs share, spelled once: a device URL with its --timeout, the output
path (-o/--output) with its --force, and the row formats of the streaming verbs.

A verb never overwrites what a user may care about: an existing output file, or an output
folder that already holds files, is refused (OutputExistsError, exit code 3) unless --force,
and --force replaces only what the verb wrote (spectratac.cli.outputs).

>>> p = argparse.ArgumentParser(prog="spectratac x")
>>> add_output(p, help="file to write")
>>> p.parse_args(["-o", "a.npz"]).output
'a.npz'
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from spectratac.cli.exit_codes import UsageError
from spectratac.cli.outputs import Kind, check_output

DEVICE_URL_HELP = "serial port, socket://host:port, rfc2217://…, or sim://…"
DEFAULT_TIMEOUT_S = 2.0
ROW_FORMATS = ("table", "csv", "jsonl")


def add_output(
    parser: argparse.ArgumentParser,
    *,
    help: str,
    required: bool = False,
    default: Any = None,
    type: Any = None,
) -> None:
    """-o/--output: where a verb writes its file or folder (the one spelling for every verb),
    and --force to overwrite it (check with refuse_overwrite before writing anything)."""
    parser.add_argument(
        "-o", "--output", required=required, default=default, type=type, metavar="PATH", help=help
    )
    add_force(parser)


def add_force(parser: argparse._ActionsContainer) -> None:
    """--force: let a verb overwrite its existing output (see refuse_overwrite)."""
    parser.add_argument(
        "--force",
        action="store_true",
        help="replace the output if it exists and this verb wrote it (never an input, never a "
        "folder holding other files)",
    )


def refuse_overwrite(
    paths: Path | str | Sequence[Path | str],
    force: bool,
    *,
    verb: str = "this verb",
    inputs: Sequence[Path | str | None] = (),
    kind: Kind | None = None,
) -> None:
    """check_output for each of a verb's output files (spectratac.cli.outputs): raise
    OutputExistsError for an existing one unless `force`, and always for one that is an
    input or an existing directory.

    >>> import tempfile
    >>> folder = Path(tempfile.mkdtemp())
    >>> _ = (folder / "model.stac").write_text("weights")
    >>> refuse_overwrite(folder / "model.stac", force=False)
    Traceback (most recent call last):
    ...
    spectratac.cli.outputs.OutputExistsError: file ... already exists; pass --force to ...
    """
    for path in [paths] if isinstance(paths, (str, Path)) else paths:
        check_output(path, force, verb=verb, inputs=inputs, kind=kind)


def column_names(text: str | None) -> list[str] | None:
    """A comma list of names (--inputs Fx,Fy), or None when not given or empty.

    >>> column_names(" a, b,,c"), column_names("")
    (['a', 'b', 'c'], None)
    """
    return [t.strip() for t in text.split(",") if t.strip()] if text else None


def npz_name(path: Path | str) -> Path:
    """The file NumPy's savez (and Dataset.save) writes for `path`: .npz is appended unless
    the name ends in it."""
    path = Path(path)
    return path if path.suffix == ".npz" else path.with_name(path.name + ".npz")


def add_device_url(
    parser: argparse.ArgumentParser,
    help: str = DEVICE_URL_HELP,
    waits_for: str = "the device",
    *,
    stalls: bool = False,
) -> None:
    """The device URL positional and --timeout, which every verb that opens a device takes
    (`waits_for` names what the timeout bounds, e.g. also a reference F/T sensor); with
    `stalls` (the streaming verbs) also --stall-timeout."""
    parser.add_argument("url", help=help)
    parser.add_argument(
        "--timeout",
        type=float,
        default=DEFAULT_TIMEOUT_S,
        metavar="S",
        help=f"seconds to wait for {waits_for} (default {DEFAULT_TIMEOUT_S:g})",
    )
    if stalls:
        parser.add_argument(
            "--stall-timeout",
            type=float,
            default=None,
            metavar="S",
            help="end with an error (exit code 3) when a streaming device sends nothing for "
            "S seconds; what came before is kept (default: ten LED-sequence periods, at "
            "least 5 s; off: wait for ever, e.g. a device paused on a debugger)",
        )


def add_decoding_checks(parser: argparse.ArgumentParser) -> None:
    """--keep-config, --unit, --strict-unit and --tare of the verbs that decode a live sensor
    (decode, live, snake)."""
    parser.add_argument(
        "--keep-config",
        action="store_true",
        help="do not configure the sensor; decode only if its configuration matches",
    )
    add_unit_checks(parser)
    parser.add_argument(
        "--tare",
        action="store_true",
        help="zero the drift baseline on the first sample (nothing may touch the skin then); "
        "without it the baseline finds rest itself and flags estimates (no_rest) until it has",
    )


def add_unit_checks(parser: argparse.ArgumentParser) -> None:
    """--unit and --strict-unit: the verbs that put a model to work on a sensor (decode, live,
    snake, model upload) compare the model's unit with the sensor's."""
    parser.add_argument(
        "--unit",
        help="unit id of the sensor (warns if the model is another unit's); the sensor's own "
        "unique id is compared on open anyway",
    )
    parser.add_argument(
        "--strict-unit",
        action="store_true",
        help="refuse (exit code 3) to decode a sensor that is another unit than the model's",
    )


def load_decoder(args: argparse.Namespace) -> Any:
    """The decoder of a decoding verb, set up from add_decoding_checks' options."""
    from spectratac.decode import Decoder

    decoder = Decoder.load(args.model)
    if given_unit_differs(decoder.unit_id, args):
        decoder.unit_policy = "off"  # said once is enough
    if args.strict_unit:
        decoder.unit_policy = "strict"
    if args.tare:
        decoder.tare()  # no stream runs yet: the next one zeroes on its first sample
    return decoder


def given_unit_differs(model_unit: str | None, args: argparse.Namespace) -> bool:
    """Compare the user's --unit with the model's before any device is opened: a warning
    (True: said), or DecoderUnitError with --strict-unit."""
    from spectratac.decode.unit_check import unit_mismatch

    msg = None if args.unit is None else unit_mismatch(model_unit, (args.unit,))
    if msg is not None and args.strict_unit:
        from spectratac.decode.errors import DecoderUnitError

        raise DecoderUnitError(msg + " (or drop --strict-unit to go on anyway)")
    if msg is not None:
        warn(msg)
    return msg is not None


def warn(message: str) -> None:
    """A warning for the person at the terminal: one line on stderr."""
    print(f"spectratac: warning: {message}", file=sys.stderr, flush=True)


def add_row_format(parser: argparse.ArgumentParser) -> None:
    """--format table|csv|jsonl of the verbs that stream rows (see output.RowWriter)."""
    parser.add_argument("--format", choices=ROW_FORMATS, default="table", help="row format")


def add_count(parser: argparse._ActionsContainer, default: int | None, help: str) -> None:
    """--count N: how many samples/records/estimates a verb handles before it stops."""
    parser.add_argument("--count", type=int, default=default, metavar="N", help=help)


def add_duration(parser: argparse._ActionsContainer, default: float | None, help: str) -> None:
    """--duration S: how long a verb runs (or how long a scene lasts), in seconds."""
    parser.add_argument("--duration", type=float, default=default, metavar="S", help=help)


def stop_count(count: int | None, duration: float | None, default: int = 20) -> int:
    """The --count a streaming verb stops at (0: none): `default` unless --duration is given.

    >>> stop_count(None, None), stop_count(None, 2.0), stop_count(5, 2.0)
    (20, 0, 5)
    """
    if count is not None and count < 0:
        raise UsageError("--count must be >= 0 (0 streams until interrupted)")
    if duration is not None and not duration > 0:
        raise UsageError("--duration must be > 0 seconds")
    if count is None:
        return 0 if duration is not None else default
    return count


#: Actions whose default says nothing a user chooses (flags, help, sub-verbs).
_NO_DEFAULT_SHOWN = (
    argparse._StoreTrueAction,
    argparse._StoreFalseAction,
    argparse._StoreConstAction,
    argparse._HelpAction,
    argparse._VersionAction,
    argparse._SubParsersAction,
)


def shows_default(action: argparse.Action) -> bool:
    """Whether `action` has a default a user should see in --help."""
    return not (
        isinstance(action, _NO_DEFAULT_SHOWN)
        or action.default is None
        or action.default is argparse.SUPPRESS
        or action.help is argparse.SUPPRESS
    )


def show_defaults(parser: argparse.ArgumentParser) -> None:
    """Append "(default: X)" to the help of every option of `parser` and its sub-verbs that
    has a default and does not name it already, so `--help` never hides what a verb does when
    the option is left out.

    >>> p = argparse.ArgumentParser(prog="x")
    >>> _ = p.add_argument("--speed", type=float, default=10.0, help="time scale")
    >>> show_defaults(p)
    >>> p._actions[-1].help
    'time scale (default: %(default)s)'
    """
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for child in action.choices.values():
                show_defaults(child)
        elif shows_default(action) and "default" not in (action.help or ""):
            action.help = (
                f"{action.help} (default: %(default)s)" if action.help else "default: %(default)s"
            )
