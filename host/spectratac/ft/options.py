"""URL query options: parsed once, typed per driver, unknown names refused by name.

>>> opts = Options("netft://h?cpf=1e6&x=1", {"cpf": "1e6", "x": "1"})
>>> opts.number("cpf"), opts.number("cpt", 2.0)
(1000000.0, 2.0)
>>> opts.done()
Traceback (most recent call last):
...
spectratac.ft.errors.FTURLError: netft://h?cpf=1e6&x=1: unknown option(s) x; known: cpf, cpt
"""

from __future__ import annotations

import math
from typing import Any, overload

from spectratac.ft.errors import FTURLError


class Options:
    """Typed access to a URL's options; done() refuses any the driver did not ask for."""

    def __init__(self, url: str, values: dict[str, Any]) -> None:
        self.url = url
        self._values = dict(values)
        self._asked: list[str] = []

    def _raw(self, name: str) -> Any:
        self._asked.append(name)
        return self._values.get(name)

    @overload
    def text(self, name: str, default: str) -> str: ...
    @overload
    def text(self, name: str, default: None = None) -> str | None: ...
    def text(self, name: str, default: str | None = None) -> str | None:
        raw = self._raw(name)
        return default if raw is None else str(raw)

    @overload
    def number(self, name: str, default: float) -> float: ...
    @overload
    def number(self, name: str, default: None = None) -> float | None: ...
    def number(self, name: str, default: float | None = None) -> float | None:
        raw = self._raw(name)
        if raw is None:
            return default
        try:
            value = float(raw)
        except (TypeError, ValueError):
            raise FTURLError(f"{self.url}: option {name}={raw!r} is not a number") from None
        if not math.isfinite(value):  # nan slips through every `<= 0` check; inf never ends
            raise FTURLError(f"{self.url}: option {name}={raw!r} must be a finite number")
        return value

    @overload
    def integer(self, name: str, default: int) -> int: ...
    @overload
    def integer(self, name: str, default: None = None) -> int | None: ...
    def integer(self, name: str, default: int | None = None) -> int | None:
        raw = self._raw(name)
        if raw is None:
            return default
        try:
            return int(raw)
        except (TypeError, ValueError):
            raise FTURLError(f"{self.url}: option {name}={raw!r} is not an integer") from None

    def flag(self, name: str, default: bool = False) -> bool:
        raw = self._raw(name)
        if raw is None:
            return default
        if isinstance(raw, bool):
            return raw
        word = str(raw).lower()
        if word in ("1", "true", "yes", "on"):
            return True
        if word in ("0", "false", "no", "off"):
            return False
        raise FTURLError(f"{self.url}: option {name}={raw!r}: use 1 or 0")

    def done(self) -> None:
        unknown = sorted(set(self._values) - set(self._asked))
        if unknown:
            known = ", ".join(dict.fromkeys(self._asked))
            raise FTURLError(f"{self.url}: unknown option(s) {', '.join(unknown)}; known: {known}")
