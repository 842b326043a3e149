"""What a page may send the live server, parsed and checked before anything acts on it.

Every WebSocket message is one of::

    {"type": "latency", "values": [ms, ...]}   # receipt latencies, at most MAX_LATENCY_VALUES
                                               # (optional "handle", "redraw": the page's own
                                               # work per batch of estimates and per redraw, ms;
                                               # "bare": the probes' one-way latencies, ms)
    {"type": "pong", "id": n}                  # echo of the server's ping n
    {"type": "snake_restart"}
    {"type": "tare"}                           # zero the drift baseline (nothing touches the skin)

Anything else (not JSON, NaN/Infinity, ``1e999``, huge integers, deep nesting, wrong types,
too long, a binary message: `refuse_binary`) raises `BadMessage`, which the server answers with
``{"type": "refused", "code": ..., "message": ...}`` instead of acting on it. Only a
benchmark's page sends ``latency`` and ``pong`` (`LiveSession(benchmark=True)`); another
server refuses them (code ``not_measuring``).

>>> parse('{"type": "pong", "id": 3}')
Pong(id=3)
>>> parse('{"type": "pong", "id": "abc"}')
Traceback (most recent call last):
...
spectratac.apps.live.inbound.BadMessage: pong: "id" must be an integer ping number, not 'abc'
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from typing import Any, NoReturn

from spectratac.errors import SpectraTacError

MAX_MESSAGE_BYTES = 64 * 1024  # the page sends ~1 s of latencies: well under 2 KB
MAX_LATENCY_VALUES = 4096
MAX_LATENCY_MS = 1e6  # receipt latencies beyond 1000 s are not latencies
MAX_PING_ID = 2**53  # exact in the page's JavaScript numbers


class BadMessage(SpectraTacError):
    """A client message the server will not act on; `code` names the kind of fault."""

    def __init__(self, message: str, code: str = "bad_message") -> None:
        super().__init__(message)
        self.code = code


@dataclass(frozen=True)
class Latency:
    values: tuple[float, ...]
    handle: tuple[float, ...] = ()
    redraw: tuple[float, ...] = ()
    bare: tuple[float, ...] = ()


@dataclass(frozen=True)
class Pong:
    id: int


@dataclass(frozen=True)
class SnakeRestart:
    pass


@dataclass(frozen=True)
class Tare:
    pass


ClientMessage = Latency | Pong | SnakeRestart | Tare


def parse(text: str) -> ClientMessage:
    if len(text) > MAX_MESSAGE_BYTES:
        raise BadMessage(
            f"message of {len(text)} characters: at most {MAX_MESSAGE_BYTES}", "too_large"
        )
    try:
        msg = json.loads(text, parse_constant=_no_constant)
    except (ValueError, RecursionError) as exc:  # bad JSON, huge integer literal, deep nesting
        raise BadMessage(f"not a JSON message: {str(exc)[:120]}") from None
    if not isinstance(msg, dict):
        raise BadMessage(f"a message is a JSON object with a type, not {type(msg).__name__}")
    kind = msg.get("type")
    if kind == "latency":
        return Latency(
            _latencies(msg.get("values")),
            _latencies(msg.get("handle", []), "handle"),
            _latencies(msg.get("redraw", []), "redraw"),
            _latencies(msg.get("bare", []), "bare"),
        )
    if kind == "pong":
        return Pong(_ping_id(msg.get("id")))
    if kind == "snake_restart":
        return SnakeRestart()
    if kind == "tare":
        return Tare()
    raise BadMessage(
        f"unknown message type {_show(kind)}: send latency, pong, snake_restart or tare"
    )


def refuse_binary(size: int) -> NoReturn:
    """A binary WebSocket message: the page sends only JSON text."""
    raise BadMessage(
        f"a binary message of {size} bytes: send JSON text messages (latency, pong, "
        "snake_restart or tare)",
        "binary",
    )


def _show(v: Any) -> str:
    """A short, safe description of what a client sent (never a deep or huge repr)."""
    if isinstance(v, list | dict):
        return f"a JSON {'list' if isinstance(v, list) else 'object'}"
    return repr(v)[:40]


def _no_constant(name: str) -> Any:
    raise ValueError(f"{name} is not a number a page sends")


def _number(v: Any) -> float | None:
    """`v` as a finite float, or None (bools, strings, non-finite, out-of-range integers)."""
    if isinstance(v, bool) or not isinstance(v, int | float):
        return None
    if isinstance(v, int) and abs(v) > MAX_LATENCY_MS:
        return None
    f = float(v)
    return f if math.isfinite(f) and abs(f) <= MAX_LATENCY_MS else None


def _latencies(values: Any, key: str = "values") -> tuple[float, ...]:
    if not isinstance(values, list):
        raise BadMessage(f'latency: "{key}" must be a list of milliseconds')
    if len(values) > MAX_LATENCY_VALUES:
        raise BadMessage(
            f"latency: {len(values)} {key} in one message: send at most {MAX_LATENCY_VALUES}",
            "too_large",
        )
    out = []
    for v in values:
        f = _number(v)
        if f is None:
            raise BadMessage(
                f"latency: {_show(v)} is not a finite number of milliseconds "
                f"within ±{MAX_LATENCY_MS:g}"
            )
        out.append(f)
    return tuple(out)


def _ping_id(v: Any) -> int:
    if isinstance(v, bool) or not isinstance(v, int) or not 0 <= v <= MAX_PING_ID:
        raise BadMessage(f'pong: "id" must be an integer ping number, not {_show(v)}')
    return v


@dataclass(frozen=True)
class SaveRequest:
    seconds: float
    format: str


def parse_save(body: bytes) -> SaveRequest:
    """``POST /api/save``'s body: ``{"seconds": 10, "format": "mcap"}`` (both optional)."""
    try:
        req = json.loads(body, parse_constant=_no_constant)
    except (ValueError, RecursionError):
        req = None
    if not isinstance(req, dict):
        raise BadMessage('give JSON {"seconds": 10, "format": "mcap"}')
    seconds = _number(req.get("seconds", 10))
    fmt = req.get("format", "mcap")
    if seconds is None or not isinstance(fmt, str):
        raise BadMessage('give JSON {"seconds": 10, "format": "mcap"}: a number and a name')
    return SaveRequest(seconds, fmt[:40])
