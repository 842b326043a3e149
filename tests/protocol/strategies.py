"""Hypothesis strategies that build any valid message from the generated field metadata."""

from __future__ import annotations

from typing import Any

from hypothesis import strategies as st
from spectratac.protocol import messages
from spectratac.protocol.schema import FieldSpec, Message

_BOUNDS = {
    "u8": (0, 0xFF),
    "u16": (0, 0xFFFF),
    "u32": (0, 0xFFFF_FFFF),
    "u64": (0, 0xFFFF_FFFF_FFFF_FFFF),
}


def _scalar(spec: FieldSpec) -> st.SearchStrategy[int]:
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


any_message: st.SearchStrategy[Message] = st.one_of(*(message_of(cls) for cls in messages.MESSAGES))
