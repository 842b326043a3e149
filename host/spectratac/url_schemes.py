"""URL scheme -> opener registries, the plug-in point for links and sensors.

A part that opens things by URL (``spectratac.device`` for optical transports,
``spectratac.ft`` for reference F/T sensors) keeps one `SchemeRegistry`. It knows its
built-in schemes by import path, and finds the others among the installed packages' entry
points of its group (as python-can finds interface plug-ins), loading a plug-in only when its
scheme is first opened; code may also add a scheme at run time with `register`. So a part
never imports the packages that plug into it: ``spectratac.sim`` registers ``sim://`` through
``pyproject.toml``'s entry points, and the device layer stays below the simulator.

>>> registry: SchemeRegistry[str] = SchemeRegistry("example", "spectratac.examples")
>>> registry.register("demo", "opened by demo")
>>> registry.lookup("demo"), registry.lookup("nope"), registry.schemes()
('opened by demo', None, ['demo'])
>>> try:
...     registry.register("demo", "another")
... except SchemeConflictError as exc:
...     print(exc)
example scheme 'demo' is registered already; pass replace=True to replace it

The URL parameters of a scheme are checked in one place too: a scheme lists its keys in a
table of `Param`s (kind, range, meaning) and `parse_params` parses, range-checks and refuses
keys the table does not know, naming the ones it does; `check_url` bounds the URL itself.

>>> table = {"speed": Param("number", 1e-3, 1e3, "time scale"), "seed": Param("integer", 0)}
>>> parse_params("sim://?speed=2", {"speed": "2"}, table, ValueError)
{'speed': 2.0}
>>> parse_params("sim://?colour=red", {"colour": "red"}, table, ValueError)
Traceback (most recent call last):
...
ValueError: sim://?colour=red: unknown parameter colour; known: seed, speed
>>> parse_params("sim://?speed=nan", {"speed": "nan"}, table, ValueError)
Traceback (most recent call last):
...
ValueError: sim://?speed=nan: speed=nan must be a finite number in [0.001, 1000] (time scale)
"""

from __future__ import annotations

import importlib
import math
import threading
from collections.abc import Mapping
from dataclasses import dataclass
from importlib.metadata import entry_points
from typing import Generic, Literal, TypeVar

from spectratac.errors import SpectraTacError

Opener = TypeVar("Opener")


class SchemeConflictError(SpectraTacError):
    """A scheme was registered twice; the message names the scheme."""


class SchemeRegistry(Generic[Opener]):
    """Openers by URL scheme: registered ones, built-ins ("module:attribute" or
    "module:Class.method", imported on first use) and the entry points of `group` (loaded
    on first use of their name)."""

    def __init__(self, kind: str, group: str, builtin: Mapping[str, str] | None = None) -> None:
        self.kind = kind
        self.group = group
        self._builtin = dict(builtin or {})
        self._openers: dict[str, Opener] = {}
        self._lock = threading.Lock()

    def register(self, scheme: str, opener: Opener, *, replace: bool = False) -> None:
        """Open `scheme`:// URLs with `opener` from now on (SchemeConflictError if the scheme
        is taken and `replace` is False)."""
        with self._lock:
            if not replace and (scheme in self._openers or scheme in self._builtin):
                raise SchemeConflictError(
                    f"{self.kind} scheme {scheme!r} is registered already; "
                    f"pass replace=True to replace it"
                )
            self._builtin.pop(scheme, None)
            self._openers[scheme] = opener

    def lookup(self, scheme: str) -> Opener | None:
        """The opener of `scheme`, importing a built-in or loading a plug-in the first time;
        None when nobody provides the scheme."""
        with self._lock:
            opener = self._openers.get(scheme)
            if opener is not None:
                return opener
            target = self._builtin.get(scheme)
            if target is not None:
                module, _, path = target.partition(":")
                opener = importlib.import_module(module)
                for attr in path.split("."):  # "module:Class.method" names a class method
                    opener = getattr(opener, attr)
            else:
                found = entry_points(group=self.group, name=scheme)
                if not found:
                    return None
                opener = next(iter(found)).load()
            self._openers[scheme] = opener
            return opener

    def schemes(self) -> list[str]:
        """Every scheme this registry can open, without loading any plug-in."""
        with self._lock:
            names = set(self._openers) | set(self._builtin)
        names |= {ep.name for ep in entry_points(group=self.group)}
        return sorted(names)


#: Longest URL (and parameter value) any scheme takes: a path or host name is far shorter;
#: a longer one is a mistake, and refusing it early keeps it out of OS calls and messages.
MAX_URL_CHARS = 4096


def check_url(url: str, error: type[Exception]) -> None:
    """Raise `error` for a URL that is too long or not valid UTF-8 text (a surrogate escape
    of undecodable bytes from the command line), before any scheme parses it."""
    if len(url) > MAX_URL_CHARS:
        raise error(
            f"a URL of {len(url)} characters ({url[:40]!r}...): the limit is {MAX_URL_CHARS}"
        )
    try:
        url.encode("utf-8")
    except UnicodeEncodeError:
        raise error(f"{url.encode('utf-8', 'backslashreplace').decode()!r} is not UTF-8 "
                    "text: spell the URL in UTF-8") from None  # fmt: skip


#: How a flag parameter may be spelled (realtime=1, configure=off).
FLAG_WORDS = {"1": True, "true": True, "yes": True, "on": True,
              "0": False, "false": False, "no": False, "off": False}  # fmt: skip


@dataclass(frozen=True)
class Param:
    """One URL parameter: its kind, its range (numbers and integers: inclusive bounds,
    None for none; text: lo/hi unused), the words it may be (kind "choice"), a meaning for
    messages and guides."""

    kind: Literal["number", "numbers", "integer", "text", "choice", "flag"]
    lo: float | None = None
    hi: float | None = None
    meaning: str = ""
    choices: tuple[str, ...] = ()

    def describe(self) -> str:
        """The range in words: [lo, hi], >= lo, one of a|b..."""
        if self.kind == "choice":
            return "one of " + "|".join(self.choices)
        if self.kind == "flag":
            return "1 or 0"
        if self.kind == "text":
            return "text"
        lo, hi = self.lo, self.hi
        if lo is not None and hi is not None:
            return f"[{lo:g}, {hi:g}]"
        if lo is not None:
            return f">= {lo:g}"
        return f"<= {hi:g}" if hi is not None else "any"

    def check(self, url: str, name: str, raw: str, error: type[Exception]) -> object:
        """`raw` parsed and range-checked, else `error` naming the parameter and its range."""
        why = f" ({self.meaning})" if self.meaning else ""
        if len(raw) > MAX_URL_CHARS:
            raise error(f"{url[:60]}...: {name} has {len(raw)} characters; at most {MAX_URL_CHARS}")
        try:
            raw.encode("utf-8")
        except UnicodeEncodeError:  # undecodable bytes from the command line
            raise error(f"{url[:60].encode('utf-8', 'backslashreplace').decode()}: {name} is "
                        "not UTF-8 text: spell it in UTF-8") from None  # fmt: skip
        if self.kind == "text":
            return raw
        if self.kind == "flag":
            word = raw.lower()
            if word not in FLAG_WORDS:
                raise error(f"{url}: {name}={raw} must be 1 or 0{why}")
            return FLAG_WORDS[word]
        if self.kind == "numbers":  # a comma list, each a number in range: force=2,0.5
            items = [t for t in raw.split(",") if t] or [raw]
            one = Param("number", self.lo, self.hi, self.meaning)
            return [one.check(url, name, item, error) for item in items]
        if self.kind == "choice":
            words = [w for w in raw.split(",") if w]
            bad = [w for w in words if w not in self.choices]
            if bad or not words:
                raise error(f"{url}: {name}={raw} must be {self.describe()}{why}")
            return ",".join(words)
        try:
            value: float = int(raw) if self.kind == "integer" else float(raw)
        except ValueError:
            kind = "an integer" if self.kind == "integer" else "a number"
            raise error(f"{url}: {name}={raw} is not {kind}; give {self.describe()}{why}") from None
        try:
            finite = math.isfinite(value)
        except OverflowError:  # an integer beyond any float: out of every range
            finite = False
        if (
            not finite
            or (self.lo is not None and value < self.lo)
            or (self.hi is not None and value > self.hi)
        ):
            what = "a finite number" if self.kind == "number" else "an integer"
            raise error(f"{url}: {name}={raw} must be {what} in {self.describe()}{why}")
        return value


def parse_params(
    url: str, query: Mapping[str, str], table: Mapping[str, Param], error: type[Exception]
) -> dict[str, object]:
    """The parameters of `query` (name -> raw text) parsed by `table`; `error` for an unknown
    name (listing the known ones) or a value out of its range."""
    unknown = sorted(set(query) - set(table))
    if unknown:
        raise error(
            f"{url}: unknown parameter {', '.join(unknown)}; known: {', '.join(sorted(table))}"
        )
    return {name: table[name].check(url, name, raw, error) for name, raw in query.items()}
