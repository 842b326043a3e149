"""The parts of a decoder that its file (stac_file) and its model image (export.model_image)
hold: runtime, layout, guard and meta. `Decoder` has them; those modules name this protocol,
not the class, so the class imports them and they never import it."""

from __future__ import annotations

from dataclasses import Field
from typing import Any, ClassVar, Protocol

from spectratac.decode.guard import Guard
from spectratac.decode.layout import Layout
from spectratac.decode.runtime import Runtime


class DecoderParts(Protocol):
    """A decoder as its file and its model image see it (a dataclass: `as_stored` copies it
    with other parts)."""

    __dataclass_fields__: ClassVar[dict[str, Field[Any]]]
    runtime: Runtime
    layout: Layout
    guard: Guard
    meta: dict[str, Any]
