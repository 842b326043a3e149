"""Hand-written base for the generated message classes: field metadata, validation, dict form.

Generated classes (messages.py) supply fast `pack`/`unpack`; everything that can be written once
from the field metadata (range checks with helpful messages, JSON-friendly dicts) lives here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, ClassVar

from spectratac.errors import SpectraTacError

_INT_RANGE: dict[str, tuple[int, int]] = {
    "u8": (0, 0xFF),
    "u16": (0, 0xFFFF),
    "u32": (0, 0xFFFF_FFFF),
    "u64": (0, 0xFFFF_FFFF_FFFF_FFFF),
    "i8": (-0x80, 0x7F),
    "i16": (-0x8000, 0x7FFF),
    "i32": (-0x8000_0000, 0x7FFF_FFFF),
}


class FieldValueError(SpectraTacError, ValueError):
    """A message field holds a value the protocol does not allow (raised before encoding)."""


@dataclass(frozen=True, slots=True)
class FieldSpec:
    """Wire metadata of one field, generated from hardware/definitions/messages.toml."""

    name: str
    type: str  # u8 u16 u32 u64 i8 i16 i32 f32 char bytes
    shape: tuple[int, ...]
    unit: str
    doc: str
    allowed: tuple[int, ...] | None = None
    min: int | None = None
    max: int | None = None
    bits_mask: int | None = None
    error: str | None = None  # NACK error code name a device answers a violation with

    @property
    def count(self) -> int:
        return math.prod(self.shape)


def fit_payload(payload: bytes, size: int) -> bytes:
    """Apply the minor-version rule to a payload already checked against
    Message.required_size: ignore unknown trailing bytes, zero-fill the fields newer than the
    sender."""
    if len(payload) > size:
        return payload[:size]
    return payload + bytes(size - len(payload))


def _flatten(value: Any, depth: int) -> list[Any]:
    if depth == 0:
        return [value]
    if not isinstance(value, (tuple, list)):
        raise TypeError("expected a sequence")
    out: list[Any] = []
    for item in value:
        out.extend(_flatten(item, depth - 1))
    return out


class Message:
    """Base of every generated message class."""

    __slots__ = ()
    TYPE_ID: ClassVar[int]
    NAME: ClassVar[str]
    DIRECTION: ClassVar[str]
    PAYLOAD_SIZE: ClassVar[int]
    SINCE: ClassVar[int] = 0  # the protocol minor version that added the message
    LAYOUT_SIZES: ClassVar[tuple[int, ...]]
    FIELDS: ClassVar[tuple[FieldSpec, ...]]

    @classmethod
    def required_size(cls, minor: int) -> int:
        """The fewest payload bytes a sender of protocol minor version `minor` may send: every
        field it knows. Only fields newer than the sender are zero-filled; a shorter payload
        is malformed (SPEC.md, compatibility rules).

        >>> from spectratac.protocol.generated.messages import Sample
        >>> Sample.required_size(0) == Sample.PAYLOAD_SIZE, Sample.required_size(7) > 0
        (True, True)
        """
        sizes = cls.LAYOUT_SIZES
        return sizes[min(minor, len(sizes) - 1)]

    def pack(self) -> bytes:  # overridden by every generated class
        raise TypeError(f"{type(self).__name__} is not a generated message class")

    @classmethod
    def unpack(cls, payload: bytes) -> Message:  # overridden by every generated class
        raise TypeError(f"{cls.__name__} is not a generated message class")

    def validate(self) -> None:
        """Raise FieldValueError naming the first field whose value the protocol forbids."""
        for spec in self.FIELDS:
            value = getattr(self, spec.name)
            where = f"{self.NAME}.{spec.name}"
            if spec.type in ("char", "bytes"):
                _check_text(where, spec, value)
                continue
            try:
                items = _flatten(value, len(spec.shape))
            except TypeError:
                raise FieldValueError(
                    f"{where} must be nested sequences of shape {spec.shape}, got {value!r}"
                ) from None
            if len(items) != spec.count:
                raise FieldValueError(
                    f"{where} must hold {spec.count} values (shape {spec.shape}), got {len(items)}"
                )
            for item in items:
                _check_number(where, spec, item)

    def to_dict(self) -> dict[str, Any]:
        """JSON-friendly form: arrays as nested lists, text as str, octets as hex."""
        out: dict[str, Any] = {"type": self.NAME}
        for spec in self.FIELDS:
            value = getattr(self, spec.name)
            if spec.type == "bytes":
                out[spec.name] = bytes(value).hex()
            elif spec.shape and spec.type != "char":
                out[spec.name] = _to_lists(value)
            else:
                out[spec.name] = value
        return out

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> Message:
        """Inverse of to_dict; missing fields keep their defaults (zero)."""
        kwargs: dict[str, Any] = {}
        for spec in cls.FIELDS:
            if spec.name not in data:
                continue
            value = data[spec.name]
            if spec.type == "bytes":
                value = bytes.fromhex(value)
            elif spec.shape and spec.type != "char":
                value = _to_tuples(value)
            kwargs[spec.name] = value
        return cls(**kwargs)


def _to_lists(value: Any) -> Any:
    return [_to_lists(v) for v in value] if isinstance(value, (tuple, list)) else value


def _to_tuples(value: Any) -> Any:
    return tuple(_to_tuples(v) for v in value) if isinstance(value, (tuple, list)) else value


def _check_text(where: str, spec: FieldSpec, value: Any) -> None:
    if spec.type == "char":
        if not isinstance(value, str) or not value.isascii() or "\x00" in value:
            raise FieldValueError(f"{where} must be ASCII text without NUL, got {value!r}")
        size = len(value.encode("ascii"))
    else:
        if not isinstance(value, (bytes, bytearray)):
            raise FieldValueError(f"{where} must be bytes, got {type(value).__name__}")
        size = len(value)
    if size > spec.count:
        raise FieldValueError(f"{where} holds at most {spec.count} bytes, got {size}")
    if spec.type == "bytes" and size != spec.count:
        raise FieldValueError(f"{where} must be exactly {spec.count} bytes, got {size}")


def _check_number(where: str, spec: FieldSpec, item: Any) -> None:
    if spec.type == "f32":
        if not isinstance(item, (int, float)) or isinstance(item, bool):
            raise FieldValueError(f"{where} must be a number, got {item!r}")
        return
    if not isinstance(item, int) or isinstance(item, bool):
        raise FieldValueError(f"{where} must be an integer, got {item!r}")
    lo, hi = _INT_RANGE[spec.type]
    if not lo <= item <= hi:
        raise FieldValueError(f"{where} = {item} does not fit {spec.type} ({lo}..{hi})")
    if spec.allowed is not None and item not in spec.allowed:
        allowed = ", ".join(str(a) for a in spec.allowed)
        raise FieldValueError(f"{where} = {item} is not allowed; allowed values: {allowed}")
    if (spec.min is not None and item < spec.min) or (spec.max is not None and item > spec.max):
        raise FieldValueError(
            f"{where} = {item} is out of range; allowed: {spec.min}..{spec.max}"
            + (f" {spec.unit}" if spec.unit else "")
        )
    if spec.bits_mask is not None and item & ~spec.bits_mask:
        raise FieldValueError(
            f"{where} = 0x{item:X} sets reserved bits; allowed mask: 0x{spec.bits_mask:X}"
        )
