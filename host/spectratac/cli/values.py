"""One place checks every option's value: finite, in its documented range, text that is UTF-8
and of a sane length. Verbs declare `type=float`/`int`/`Path` or nothing as argparse does;
`check_values(parser)` then puts the checker of `RANGES` (by spelling: one spelling has one
meaning across verbs, tests/meta/test_cli_convention.py) on every option of the tree and shows
the range in --help. A value outside is a usage error (exit code 2) naming the range, before
any device opens or any file is written.

>>> p = argparse.ArgumentParser(prog="spectratac x")
>>> _ = p.add_argument("--timeout", type=float, default=2.0)
>>> check_values(p)
>>> p.parse_args(["--timeout", "0.5"]).timeout
0.5
>>> seconds(0.0, 3600.0, above=True)("inf")
Traceback (most recent call last):
...
argparse.ArgumentTypeError: inf is not a finite number of seconds in (0, 3600]
"""

from __future__ import annotations

import argparse
import dataclasses
import math
from dataclasses import dataclass
from pathlib import Path

#: Longest text (a path, a URL, a name) an option takes; longer is a mistake (PATH_MAX is 4096).
MAX_TEXT = 4096
#: Seconds no wait of the toolkit exceeds: a timer that long is a mistake (threading's own
#: limit, TIMEOUT_MAX, is ~292 years and overflows beyond).
MAX_SECONDS = 1e7  # ~116 days


def _show(x: float) -> str:
    return str(int(x)) if x == int(x) and abs(x) < 1e15 else f"{x:g}"


@dataclass(frozen=True)
class Number:
    """A float or int type for argparse: finite, in [lo, hi] (`above`: lo excluded), and,
    when `inf_ok`, also `inf` (a wait that lasts until Ctrl-C); when `off_ok`, also the word
    `off` (a watch switched off), which reads as inf."""

    lo: float
    hi: float
    integer: bool = False
    above: bool = False
    inf_ok: bool = False
    off_ok: bool = False
    unit: str = ""

    @property
    def __name__(self) -> str:  # argparse names the type in its messages
        return "integer" if self.integer else "number"

    def describe(self) -> str:
        left = "(" if self.above else "["
        extra = " or inf" if self.inf_ok else " or off" if self.off_ok else ""
        return f"{left}{_show(self.lo)}, {_show(self.hi)}]{extra}"

    def __call__(self, text: str) -> float | int:
        kind = "an integer" if self.integer else "a finite number"
        unit = f" of {self.unit}" if self.unit else ""
        msg = f"{_clip(text)} is not {kind}{unit} in {self.describe()}"
        if self.inf_ok and text.strip().lower() in ("inf", "+inf", "infinity"):
            return math.inf
        if self.off_ok and text.strip().lower() == "off":
            return math.inf
        try:
            value: float | int = int(text) if self.integer else float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(msg) from None
        in_range = value > self.lo if self.above else value >= self.lo
        if not (math.isfinite(value) and in_range and value <= self.hi):
            raise argparse.ArgumentTypeError(msg)
        return value


def seconds(
    lo: float = 0.0,
    hi: float = MAX_SECONDS,
    *,
    above: bool = False,
    inf_ok: bool = False,
    off_ok: bool = False,
) -> Number:
    return Number(lo, hi, above=above, inf_ok=inf_ok, off_ok=off_ok, unit="seconds")


def finite_float(lo: float, hi: float, *, above: bool = False) -> Number:
    return Number(lo, hi, above=above)


def integer(lo: int, hi: int) -> Number:
    return Number(lo, hi, integer=True)


port = integer(0, 65535)
positive_int = integer(1, 10**9)
SEED = integer(0, 2**32 - 1)


def text(value: str) -> str:
    """Any text option: at most MAX_TEXT characters and UTF-8 (undecodable bytes from the
    command line arrive as surrogate escapes that no file, URL or message can carry)."""
    if len(value) > MAX_TEXT:
        raise argparse.ArgumentTypeError(
            f"{_clip(value)} has {len(value)} characters; at most {MAX_TEXT}"
        )
    try:
        value.encode("utf-8")
    except UnicodeEncodeError:
        raise argparse.ArgumentTypeError(f"{_clip(value)} is not UTF-8 text") from None
    return value


def path(value: str) -> Path:
    return Path(text(value))


def speed(value: str) -> str:
    """A simulated device's time scale: 'max' or a number in spectratac.sim.url.SPEED_RANGE
    (kept as text: it goes into a sim:// URL)."""
    from spectratac.sim.url import SPEED_RANGE

    if value == "max":
        return value
    try:
        Number(*SPEED_RANGE)(value)  # the same range as sim://?speed=
    except argparse.ArgumentTypeError as exc:
        raise argparse.ArgumentTypeError(f"{exc}, or max") from None
    return value


def _clip(value: str) -> str:
    shown = value if len(value) <= 40 else value[:40] + "..."
    return shown.encode("utf-8", "backslashreplace").decode("utf-8")


#: The range of every numeric option, by spelling; "VERB --option" overrides for one verb.
RANGES: dict[str, Number] = {
    "--timeout": seconds(0.0, 3600.0, above=True),
    "--stall-timeout": seconds(0.0, 86400.0, above=True, off_ok=True),  # off: no stall watch
    "--dfu-wait": seconds(0.0, 600.0, above=True),
    "--duration": seconds(),
    "--soak": seconds(0.0, 3600.0),
    "live --duration": seconds(inf_ok=True),  # inf: until Ctrl-C, as 0 and leaving it out
    "--count": integer(0, 10**9),
    "--port": port,
    "--foxglove": port,
    "--tcp": port,
    "--seed": SEED,
    "--game-seed": SEED,
    "--guided-seed": SEED,
    "--split-seed": SEED,
    "--epochs": integer(1, 100_000),
    "--oracle-samples": integer(0, 10**7),  # 0: no oracle
    "--every": integer(1, 10**6),
    "--integration-ms": integer(1, 1000),
    "--duty": finite_float(0, 1000),
    "--gain": finite_float(0.125, 8.0),
    "--digital-gain": integer(1, 4),
    "--threshold": finite_float(0.0, 1000.0),
    "--hysteresis": finite_float(0.0, 1000.0),
    "--confirm": integer(1, 1000),
    "--tick": seconds(0.01, 60.0),
    "--guided": integer(1, 10_000),
    "--guided-hold": seconds(0.1, 3600.0),
    "--guided-rest": seconds(0.0, 3600.0),
    "--sync-every": seconds(0.1, 3600.0),
    "--replug-after": seconds(0.0, 3600.0),
    "--rate": finite_float(1.0, 100_000.0),
    "--loss": finite_float(0.0, 0.999),
    "--offset": finite_float(-1e6, 1e6),
    "--drift": finite_float(-0.01, 0.01),
    "--max-gap-ms": finite_float(0.0, 1e7, above=True),
    "--history": seconds(1.0, 3600.0),
    "--context": integer(1, 100_000),
    "--gain-jitter": finite_float(0.0, 0.99),
    "--batch-size": integer(1, 10**7),
    "--lr": finite_float(0.0, 10.0, above=True),
    "--hidden": integer(1, 100_000),
    "--blocks": integer(1, 1000),
    "--val-fraction": finite_float(0.0, 0.99),
    "--degree": integer(1, 3),
    "--threads": integer(1, 1024),
    "--workers": integer(1, 1024),
    "--sessions": integer(1, 100_000),
}

#: Text options with a check of their own, by spelling.
TEXT_CHECKS = {"--speed": speed}
_BUILTIN = {float: "number", int: "integer"}


def range_of(verb: str, action: argparse.Action) -> Number | None:
    """The declared range of a numeric option of `verb` (None: not in RANGES)."""
    for spelling in action.option_strings:
        found = RANGES.get(f"{verb} {spelling}") or RANGES.get(spelling)
        if found is not None:
            return found
    return None


def check_values(parser: argparse.ArgumentParser, verb: str = "") -> None:
    """Put the checker of every option of `parser` and its sub-verbs in place: numbers get
    their RANGES entry (a numeric option without one is a programming error: add it), text
    and paths the text check. The range is appended to the option's help."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, child in action.choices.items():
                check_values(child, f"{verb} {name}".strip())
            continue
        kind = action.type
        if kind in _BUILTIN:
            checker = range_of(verb, action)
            if checker is None:
                raise LookupError(f"{verb} {action.option_strings}: no range in cli.values.RANGES")
            if kind is int and not checker.integer:  # the same range, in whole units
                checker = dataclasses.replace(checker, integer=True)
            action.type = checker
            if action.help is not argparse.SUPPRESS and not action.choices:
                shown = f"range {checker.describe()}"
                action.help = f"{action.help} ({shown})" if action.help else shown
        elif kind is None and action.nargs != 0 and _takes_text(action):
            special = [TEXT_CHECKS[o] for o in action.option_strings if o in TEXT_CHECKS]
            action.type = special[0] if special else text
        elif kind is Path:
            action.type = path


def _takes_text(action: argparse.Action) -> bool:
    return not isinstance(
        action,
        (
            argparse._StoreTrueAction,
            argparse._StoreFalseAction,
            argparse._StoreConstAction,
            argparse._CountAction,
            argparse._HelpAction,
            argparse._VersionAction,
        ),
    )
