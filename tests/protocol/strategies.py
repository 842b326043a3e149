"""Hypothesis strategies that build any valid message from the generated field metadata."""

from __future__ import annotations

import struct
from typing import Any

from hypothesis import strategies as st
from spectratac.protocol.generated import messages
from spectratac.protocol.schema import FieldSpec, Message

_BOUNDS = {
    "u8": (0, 0xFF),
    "u16": (0, 0xFFFF),
    "u32": (0, 0xFFFF_FFFF),
    "u64": (0, 0xFFFF_FFFF_FFFF_FFFF),
    "i8": (-0x80, 0x7F),
    "i16": (-0x8000, 0x7FFF),
    "i32": (-0x8000_0000, 0x7FFF_FFFF),
}

_QUIET_NAN = 0x7FC0_0000  # exponent all ones, quiet bit set; SPEC.md: senders send quiet NaNs


def _f32_from_bits(bits: int) -> float:
    return float(struct.unpack("<f", bits.to_bytes(4, "little"))[0])


#: Quiet NaNs of either sign with any payload: they survive float32 -> float64 -> float32 bit for
#: bit, so a round trip can be checked bitwise (signalling NaNs are quietened by the conversion).
quiet_nans: st.SearchStrategy[float] = st.builds(
    lambda sign, payload: _f32_from_bits(sign << 31 | _QUIET_NAN | payload),
    st.integers(0, 1),
    st.integers(0, 0x3F_FFFF),
)

#: Every float32 a sender may put on the wire: finite values, both infinities, quiet NaNs.
f32_values: st.SearchStrategy[float] = st.one_of(st.floats(width=32, allow_nan=False), quiet_nans)


def _scalar(spec: FieldSpec) -> st.SearchStrategy[Any]:
    if spec.type == "f32":
        return f32_values
    if spec.allowed is not None:
        return st.sampled_from(spec.allowed)
    if spec.bits_mask is not None:
        return st.integers(0, spec.bits_mask).map(lambda v: v & spec.bits_mask)
    lo, hi = _BOUNDS[spec.type]
    lo = spec.min if spec.min is not None else lo
    hi = spec.max if spec.max is not None else hi
    return st.integers(lo, hi)


def _shaped(inner: st.SearchStrategy[Any], shape: tuple[int, ...]) -> st.SearchStrategy[Any]:
    for n in reversed(shape):
        inner = st.tuples(*([inner] * n))
    return inner


def field_values(spec: FieldSpec) -> st.SearchStrategy[Any]:
    if spec.type == "char":
        alphabet = st.characters(min_codepoint=1, max_codepoint=127)
        return st.text(alphabet, max_size=spec.count)
    if spec.type == "bytes":
        return st.binary(min_size=spec.count, max_size=spec.count)
    return _shaped(_scalar(spec), spec.shape)


def message_of(cls: type[Message]) -> st.SearchStrategy[Message]:
    return st.builds(cls, **{f.name: field_values(f) for f in cls.FIELDS})


def same(a: Message | None, b: Message | None) -> bool:
    """Messages are equal bit for bit (`==` fails on NaN floats, which never equal themselves)."""
    if a is None or b is None:
        return a is b
    return type(a) is type(b) and a.pack() == b.pack()


any_message: st.SearchStrategy[Message] = st.one_of(*(message_of(cls) for cls in messages.MESSAGES))
