"""Which definition hash each released minor version of this major has (SPEC.md, section 8).

The hash covers a whole definition, so every minor version has its own. A device that speaks
an older minor version than the host must report that version's hash; once released, a
version's hash never changes, so the table below is frozen data, not generated code.

>>> from spectratac.protocol.generated import messages
>>> expected_definition_hash(messages.PROTOCOL_MINOR) == messages.DEFINITION_HASH
True
>>> hex(expected_definition_hash(0))
'0xa7314832'
>>> expected_definition_hash(messages.PROTOCOL_MINOR + 1) is None
True
"""

from __future__ import annotations

from spectratac.protocol.generated import messages as m

#: Definition hashes of released minor versions older than this library's (protocol 1.x).
RELEASED_DEFINITION_HASHES: dict[int, int] = {
    0: 0xA731_4832,  # protocol 1.0
    1: 0xF8BF_B43E,  # protocol 1.1
    2: 0xA892_72E6,  # protocol 1.2
    3: 0xCBF8_E72A,  # protocol 1.3
}


def expected_definition_hash(minor: int) -> int | None:
    """The hash a device speaking 1.`minor` must report, or None for a minor newer than this
    host (whose definitions the host cannot know)."""
    if minor == m.PROTOCOL_MINOR:
        return m.DEFINITION_HASH
    return RELEASED_DEFINITION_HASHES.get(minor)
