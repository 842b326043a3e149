"""URL query options of an F/T driver: each driver lists its options in a table of
`spectratac.url_schemes.Param`s (kind, range, meaning), the one checker every URL scheme
uses; `Options` parses a URL's query by that table at once, refusing an unknown name (with
the known ones) or a value out of its range, and hands out typed values or defaults.

>>> table = {"cpf": Param("number", 1.0, 1e9, "per N"), "cpt": Param("number", 1.0, 1e9)}
>>> opts = Options("netft://h?cpf=1e6", {"cpf": "1e6"}, table)
>>> opts.number("cpf"), opts.number("cpt", 2.0)
(1000000.0, 2.0)
>>> Options("netft://h?cpf=1e6&x=1", {"cpf": "1e6", "x": "1"}, table)
Traceback (most recent call last):
...
spectratac.ft.errors.FTURLError: netft://h?cpf=1e6&x=1: unknown parameter x; known: cpf, cpt
>>> Options("netft://h?cpf=nan", {"cpf": "nan"}, table)
Traceback (most recent call last):
...
spectratac.ft.errors.FTURLError: netft://h?cpf=nan: cpf=nan must be a finite number in [1, ...
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, overload

from spectratac.ft.errors import FTURLError
from spectratac.url_schemes import Param, parse_params

__all__ = ["RATE", "REALTIME", "SPEED", "Options", "Param"]

#: Options several drivers share.
RATE = Param("number", 0.01, 1e6, "sample rate, Hz, when the sensor does not say")
REALTIME = Param("flag", meaning="replay at the recorded pace")
SPEED = Param("number", 0.01, 1000.0, "replay pace: 2 twice as fast")


class Options:
    """A URL's options parsed by the driver's table; typed access with defaults."""

    def __init__(self, url: str, values: Mapping[str, Any], table: Mapping[str, Param]) -> None:
        self.url = url
        # options given in code (FTSensor.open(url, realtime=True)) are checked like text
        raw = {name: value if isinstance(value, str) else _text(value)
               for name, value in values.items()}  # fmt: skip
        self._values = parse_params(url, raw, table, FTURLError)

    def _get(self, name: str, default: Any) -> Any:
        value = self._values.get(name)
        return default if value is None else value

    @overload
    def text(self, name: str, default: str) -> str: ...
    @overload
    def text(self, name: str, default: None = None) -> str | None: ...
    def text(self, name: str, default: str | None = None) -> str | None:
        value: str | None = self._get(name, default)
        return value

    @overload
    def number(self, name: str, default: float) -> float: ...
    @overload
    def number(self, name: str, default: None = None) -> float | None: ...
    def number(self, name: str, default: float | None = None) -> float | None:
        value = self._get(name, default)
        return None if value is None else float(value)

    @overload
    def integer(self, name: str, default: int) -> int: ...
    @overload
    def integer(self, name: str, default: None = None) -> int | None: ...
    def integer(self, name: str, default: int | None = None) -> int | None:
        value = self._get(name, default)
        return None if value is None else int(value)

    def flag(self, name: str, default: bool = False) -> bool:
        return bool(self._get(name, default))


def _text(value: object) -> str:
    if isinstance(value, bool):
        return "1" if value else "0"
    return repr(value) if isinstance(value, float) else str(value)
