"""Exit codes of every `spectratac` verb, and which errors map to which.

    0 ok, 1 a check failed, 2 usage, 3 an error (bad input, missing device, an output that
    already exists without --force), 130 Ctrl-C

>>> int(ExitCode.ERROR), exit_code_for(UsageError("-o/--output is required"))
(3, <ExitCode.USAGE: 2>)
"""

from __future__ import annotations

from enum import IntEnum

from spectratac.errors import SpectraTacError


class ExitCode(IntEnum):
    OK = 0
    FAILURE = 1  # the command ran but its check failed (e.g. a conformance test)
    USAGE = 2  # bad arguments (argparse's own convention)
    ERROR = 3  # a SpectraTacError: bad input, device problem; the message says what to do
    INTERRUPTED = 130  # Ctrl-C (128 + SIGINT, as shells report it)


class UsageError(SpectraTacError):
    """Bad arguments found after parsing (e.g. a required option given only by its old name
    being absent); reported like argparse's own usage errors, with exit code 2."""


def exit_code_for(exc: BaseException) -> ExitCode:
    """The exit code for an error a verb raised: a missing device, an unreachable F/T sensor
    or bad input are all SpectraTacErrors (3), bad arguments 2, Ctrl-C 130."""
    if isinstance(exc, UsageError):
        return ExitCode.USAGE
    if isinstance(exc, KeyboardInterrupt):
        return ExitCode.INTERRUPTED
    if isinstance(exc, SpectraTacError):
        return ExitCode.ERROR
    raise TypeError(f"no exit code for {type(exc).__name__}: let it propagate") from exc
