"""Load and check a part definition (hardware/definitions/<part>.toml): registers and CONF fields.

>>> from pathlib import Path
>>> p = load(Path(__file__).resolve().parents[2] / "hardware/definitions/veml3328.toml")
>>> p.register("ID").address, hex(p.conf_field("IT").mask), p.conf_field("IT").values
(12, '0x30', (50, 100, 200, 400))
>>> hex(p.defined_bits), hex(p.window_bits)
('0xfc7d', '0x7c70')
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any


class PartError(ValueError):
    """A part definition breaks a rule (overlapping bits, unknown names, too many values)."""


@dataclass(frozen=True)
class Register:
    name: str
    address: int
    writable: bool
    doc: str


@dataclass(frozen=True)
class ConfField:
    name: str
    bit: int
    width: int
    values: tuple[int | float, ...]
    unit: str
    window: bool
    alias: str  # a plain name for the values, e.g. INTEGRATION_MS for IT
    doc: str

    @property
    def mask(self) -> int:
        return ((1 << self.width) - 1) << self.bit


@dataclass(frozen=True)
class Part:
    name: str
    source: str  # repository-relative path of the definition, for generated-file headers
    address: int
    id_low: int
    full_scale: int
    registers: tuple[Register, ...]
    conf: tuple[ConfField, ...]
    conf_masks: dict[str, tuple[str, ...]]

    def register(self, name: str) -> Register:
        return next(r for r in self.registers if r.name == name)

    def conf_field(self, name: str) -> ConfField:
        for f in self.conf:
            if f.name == name:
                return f
        raise PartError(f"{self.name} has no CONF field {name!r}; known: {self.conf_names}")

    @property
    def conf_names(self) -> list[str]:
        return [f.name for f in self.conf]

    @property
    def defined_bits(self) -> int:
        """CONF bits that exist (reserved ones read back as 0)."""
        return sum(f.mask for f in self.conf)

    @property
    def window_bits(self) -> int:
        """CONF bits a measurement window's counts depend on."""
        return sum(f.mask for f in self.conf if f.window)

    def named_mask(self, name: str) -> int:
        return sum(self.conf_field(n).mask for n in self.conf_masks[name])


def _conf_field(raw: dict[str, Any], part: str) -> ConfField:
    width = raw.get("width", 1)
    values = tuple(raw.get("values", ()))
    if len(values) > 1 << width:
        raise PartError(f"{part} CONF.{raw['name']}: {len(values)} values do not fit {width} bits")
    return ConfField(
        name=raw["name"],
        bit=raw["bit"],
        width=width,
        values=values,
        unit=raw.get("unit", ""),
        window=raw.get("window", False),
        alias=raw.get("alias", ""),
        doc=raw.get("doc", ""),
    )


def load(path: Path) -> Part:
    raw = tomllib.loads(path.read_text(encoding="utf-8"))
    name = raw["part"]["name"]
    registers = tuple(
        Register(r["name"], r["address"], r.get("writable", False), r.get("doc", ""))
        for r in raw["registers"]
    )
    conf = tuple(_conf_field(f, name) for f in raw["conf"])
    used = 0
    for f in conf:
        if used & f.mask:
            raise PartError(f"{name} CONF.{f.name}: bits 0x{f.mask:04X} overlap another field")
        used |= f.mask
    if len({r.address for r in registers}) != len(registers):
        raise PartError(f"{name}: two registers share an address")
    masks = {k: tuple(v) for k, v in raw.get("conf_masks", {}).items()}
    try:
        source = str(path.resolve().relative_to(Path(__file__).resolve().parents[2]))
    except ValueError:
        source = path.name
    part = Part(
        name=name,
        source=source,
        address=raw["part"]["address"],
        id_low=raw["part"]["id_low"],
        full_scale=raw["part"]["full_scale"],
        registers=registers,
        conf=conf,
        conf_masks=masks,
    )
    for mask in masks:
        part.named_mask(mask)  # every named field exists
    return part


def reference(part: Part, field: str) -> tuple[int | float, ...]:
    """The values of a multi-bit CONF field, for another definition that refers to it."""
    values = part.conf_field(field).values
    if not values:
        raise PartError(f"{part.name} CONF.{field} lists no values to refer to")
    return values
