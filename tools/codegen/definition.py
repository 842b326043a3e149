"""Load and check hardware/definitions/messages.toml; compute the definition hash.

The hash covers only what affects bytes on the wire (names, ids, types, shapes, constraints,
enum values), not documentation, so that a doc fix does not make host and firmware disagree.

Facts of a part on the board are not repeated here: messages.toml names part definitions in
`[parts]` (paths relative to it) and refers to a CONF field's values as `allowed = "part.FIELD"`
in a field, or as `{part.FIELD}` (the values joined by ", ") in any text.
"""

from __future__ import annotations

import hashlib
import json
import math
import re
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from . import part as part_definition

SCALARS: dict[str, tuple[str, str, int, bool]] = {
    # type: (C type, struct code, size, signed)
    "u8": ("uint8_t", "B", 1, False),
    "u16": ("uint16_t", "H", 2, False),
    "u32": ("uint32_t", "I", 4, False),
    "u64": ("uint64_t", "Q", 8, False),
    "i8": ("int8_t", "b", 1, True),
    "i16": ("int16_t", "h", 2, True),
    "i32": ("int32_t", "i", 4, True),
    "f32": ("float", "f", 4, True),
    "char": ("char", "s", 1, False),
    "bytes": ("uint8_t", "s", 1, False),
}


class DefinitionError(ValueError):
    """messages.toml breaks a rule of the protocol definition."""


@dataclass(frozen=True)
class Field:
    name: str
    type: str
    shape: tuple[int, ...]
    unit: str
    doc: str
    enum: str | None
    allowed: tuple[int, ...] | None
    min: int | None
    max: int | None
    bits: str | None
    error: str | None
    since: int = 0  # the protocol minor version that appended this field

    @property
    def count(self) -> int:
        return math.prod(self.shape)

    @property
    def size(self) -> int:
        return SCALARS[self.type][2] * self.count

    @property
    def is_text(self) -> bool:
        return self.type in ("char", "bytes")


@dataclass(frozen=True)
class Message:
    name: str
    id: int
    direction: str
    doc: str
    fields: tuple[Field, ...]
    since: int = 0  # the protocol minor version that added this message

    @property
    def payload_size(self) -> int:
        return sum(f.size for f in self.fields)

    def size_at(self, minor: int) -> int:
        """Payload bytes a sender of protocol minor `minor` sends: the fields it knows.
        A payload shorter than this is malformed; fields after it are zero-filled."""
        return sum(f.size for f in self.fields if f.since <= minor)


@dataclass(frozen=True)
class EnumValue:
    name: str
    value: int
    doc: str
    action: str = ""


@dataclass(frozen=True)
class Definition:
    protocol: dict[str, int]
    enums: dict[str, tuple[str, tuple[EnumValue, ...]]]  # name -> (doc, values)
    flags: dict[str, tuple[str, tuple[EnumValue, ...]]]  # name -> (doc, values with value=bit)
    messages: tuple[Message, ...]
    hash: int = field(default=0)


def _field(raw: dict[str, Any], where: str) -> Field:
    ftype = raw["type"]
    if ftype not in SCALARS:
        raise DefinitionError(f"{where}: unknown type {ftype!r}; use one of {sorted(SCALARS)}")
    shape = tuple(raw.get("shape", ()))
    if ftype in ("char", "bytes") and len(shape) != 1:
        raise DefinitionError(f"{where}: {ftype} needs a one-dimensional shape")
    has_constraint = any(k in raw for k in ("allowed", "min", "max", "enum", "bits"))
    if "error" in raw and not has_constraint:
        raise DefinitionError(f"{where}: 'error' given without a constraint")
    allowed = raw.get("allowed")
    return Field(
        name=raw["name"],
        type=ftype,
        shape=shape,
        unit=raw.get("unit", ""),
        doc=raw.get("doc", ""),
        enum=raw.get("enum"),
        allowed=tuple(allowed) if allowed is not None else None,
        min=raw.get("min"),
        max=raw.get("max"),
        bits=raw.get("bits"),
        error=raw.get("error"),
        since=raw.get("since", 0),
    )


def _values(raw: dict[str, Any], key: str) -> tuple[EnumValue, ...]:
    return tuple(
        EnumValue(v["name"], v[key], v.get("doc", ""), v.get("action", "")) for v in raw["values"]
    )


REFERENCE = re.compile(r"\{(\w+)\.(\w+)\}")


def _resolve(raw: Any, parts: dict[str, part_definition.Part], key: str = "") -> Any:
    """Replace references to part facts by their values (see the module docstring)."""

    def values(part: str, name: str) -> tuple[int | float, ...]:
        if part not in parts:
            raise DefinitionError(
                f"unknown part {part!r} in a reference; [parts] has {sorted(parts)}"
            )
        try:
            return part_definition.reference(parts[part], name)
        except part_definition.PartError as e:
            raise DefinitionError(str(e)) from None

    if isinstance(raw, dict):
        return {k: _resolve(v, parts, k) for k, v in raw.items()}
    if isinstance(raw, list):
        return [_resolve(v, parts, key) for v in raw]
    if isinstance(raw, str) and key == "allowed":
        match = REFERENCE.fullmatch("{" + raw + "}")
        if match is None:
            raise DefinitionError(f"allowed = {raw!r}: give a list or a 'part.FIELD' reference")
        return list(values(match[1], match[2]))
    if isinstance(raw, str):
        return REFERENCE.sub(lambda m: ", ".join(str(v) for v in values(m[1], m[2])), raw)
    return raw


def load(path: Path) -> Definition:
    raw = tomllib.loads(path.read_text(encoding="utf-8"))
    parts = {
        name: part_definition.load((path.parent / rel).resolve())
        for name, rel in raw.pop("parts", {}).items()
    }
    raw = _resolve(raw, parts)
    enums = {n: (e.get("doc", ""), _values(e, "value")) for n, e in raw.get("enums", {}).items()}
    flags = {n: (e.get("doc", ""), _values(e, "bit")) for n, e in raw.get("flags", {}).items()}
    by_name: dict[str, Message] = {}
    ids: set[int] = set()
    for m in raw["messages"]:
        fields = [_field(f, f"{m['name']}.{f['name']}") for f in m.get("fields", [])]
        if "include" in m:
            fields += list(by_name[m["include"]].fields)
        msg = Message(
            m["name"], m["id"], m["direction"], m.get("doc", ""), tuple(fields), m.get("since", 0)
        )
        if not 0 <= msg.since <= raw["protocol"]["minor"]:
            raise DefinitionError(
                f"{msg.name}: 'since' values must be minor versions 0..protocol.minor "
                f"({raw['protocol']['minor']}); the message says {msg.since}"
            )
        if msg.id in ids:
            raise DefinitionError(f"{msg.name}: duplicate type id 0x{msg.id:02X}")
        if msg.direction not in ("host_to_device", "device_to_host"):
            raise DefinitionError(f"{msg.name}: direction must be host_to_device/device_to_host")
        if (msg.id >= 0x80) != (msg.direction == "device_to_host"):
            raise DefinitionError(f"{msg.name}: device-to-host ids are 0x80..0xFF, others below")
        if msg.payload_size > raw["protocol"]["max_payload"]:
            raise DefinitionError(f"{msg.name}: payload {msg.payload_size} B > max_payload")
        since = [f.since for f in msg.fields]
        if since != sorted(since) or any(not 0 <= v <= raw["protocol"]["minor"] for v in since):
            raise DefinitionError(
                f"{msg.name}: field 'since' values must be minor versions 0..protocol.minor, "
                f"in field order (a minor version only appends fields)"
            )
        for f in msg.fields:
            if f.enum and f.enum not in enums:
                raise DefinitionError(f"{msg.name}.{f.name}: unknown enum {f.enum!r}")
            if f.bits and f.bits not in flags:
                raise DefinitionError(f"{msg.name}.{f.name}: unknown flags {f.bits!r}")
            if f.error and f.error not in {v.name for v in enums["error"][1]}:
                raise DefinitionError(f"{msg.name}.{f.name}: unknown error {f.error!r}")
        ids.add(msg.id)
        by_name[msg.name] = msg
    proto = raw["protocol"]
    overhead = proto["header_size"] + proto["crc_size"]
    worst = overhead + proto["max_payload"]
    if worst + math.ceil(worst / 254) + 1 > proto["max_frame"]:
        raise DefinitionError("max_frame cannot hold a max_payload frame after COBS")
    definition = Definition(proto, enums, flags, tuple(by_name.values()))
    return Definition(proto, enums, flags, definition.messages, wire_hash(definition))


def wire_hash(d: Definition) -> int:
    """First 4 bytes (little-endian) of SHA-256 over the wire-relevant content, canonical JSON."""
    canon = {
        "protocol": d.protocol,
        "enums": {n: [(v.name, v.value) for v in vals] for n, (_, vals) in d.enums.items()},
        "flags": {n: [(v.name, v.value) for v in vals] for n, (_, vals) in d.flags.items()},
        "messages": [
            [m.name, m.id, m.direction]
            + ([["since", m.since]] if m.since else [])  # 1.0 messages: the hash 1.0 always had
            + [
                [f.name, f.type, list(f.shape), f.enum, f.allowed, f.min, f.max, f.bits, f.error]
                + ([f.since] if f.since else [])  # 1.0 fields: the hash 1.0 always had
                for f in m.fields
            ]
            for m in d.messages
        ],
    }
    blob = json.dumps(canon, sort_keys=True, separators=(",", ":")).encode()
    return int.from_bytes(hashlib.sha256(blob).digest()[:4], "little")


def allowed_values(d: Definition, f: Field) -> tuple[int, ...] | None:
    """The explicit set of values a field accepts, if it has one (allowed list or enum)."""
    if f.allowed is not None:
        return f.allowed
    if f.enum and f.error:
        return tuple(v.value for v in d.enums[f.enum][1])
    return None


def bits_mask(d: Definition, f: Field) -> int | None:
    if not f.bits:
        return None
    return sum(1 << v.value for v in d.flags[f.bits][1])
