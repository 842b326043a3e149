"""Every golden vector decodes to its written meaning, and valid ones re-encode byte for byte.

CRC and COBS are also checked against slow reference implementations written here from the
spec, so that a wrong library parameter cannot make the codec and its vectors agree by accident.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import pytest
from spectratac.protocol import (
    FrameError,
    StreamDecoder,
    crc32c,
    decode_frame,
    encode_raw,
)
from spectratac.protocol.generated import messages

VECTORS = sorted((Path(__file__).resolve().parents[2] / "protocol" / "vectors").glob("*.json"))


def reference_crc32c(data: bytes) -> int:
    """Bitwise CRC-32C: reflected poly 0x82F63B78, init and xorout 0xFFFFFFFF."""
    crc = 0xFFFFFFFF
    for byte in data:
        crc ^= byte
        for _ in range(8):
            crc = (crc >> 1) ^ (0x82F63B78 if crc & 1 else 0)
    return crc ^ 0xFFFFFFFF


def reference_cobs_decode(data: bytes) -> bytes:
    """COBS as published (Cheshire & Baker): code byte n = n-1 data bytes, then a zero if n<255."""
    out = bytearray()
    i = 0
    while i < len(data):
        code = data[i]
        block = data[i + 1 : i + code]
        if code == 0 or len(block) != code - 1:
            raise ValueError("bad COBS")
        out += block
        i += code
        if code < 0xFF and i < len(data):
            out.append(0)
    return bytes(out)


def load(path: Path) -> dict[str, Any]:
    return json.loads(path.read_text(encoding="utf-8"))


def nan_as_text(value: Any) -> Any:
    """Make NaN compare equal to NaN (it never equals itself) by writing it as text."""
    if isinstance(value, float) and math.isnan(value):
        return "NaN"
    if isinstance(value, dict):
        return {k: nan_as_text(v) for k, v in value.items()}
    if isinstance(value, list):
        return [nan_as_text(v) for v in value]
    return value


def test_crc_check_value() -> None:
    assert crc32c(b"123456789") == 0xE3069283 == reference_crc32c(b"123456789")


def test_vector_set_covers_every_message_and_error() -> None:
    vectors = [load(p) for p in VECTORS]
    types = {v["message"]["type"] for v in vectors if v["valid"]}
    assert types == set(messages.MESSAGES_BY_NAME)
    errors = {v["error"] for v in vectors if not v["valid"]}
    expected = {
        "bad_crc",
        "bad_cobs",
        "too_short",
        "oversize",
        "unknown_type",
        "short_payload",
        "version_mismatch",
    }
    assert errors == expected


def test_every_error_code_has_a_nack_vector() -> None:
    nacks = [load(p)["message"] for p in VECTORS if load(p)["valid"]]
    codes = {msg["error"] for msg in nacks if msg["type"] == "NACK"}
    assert codes >= {int(e) for e in messages.Error if e >= messages.Error.MODEL_TOO_LARGE}


def test_each_message_vector_carries_the_minor_version_that_added_it() -> None:
    """1.0 vectors stay 1.0 frames (a 1.1 receiver must read them); 1.1 messages come in 1.1."""
    for path in VECTORS:
        vector = load(path)
        if not vector["valid"] or vector.get("future_minor"):
            continue
        cls = messages.MESSAGES_BY_NAME[vector["message"]["type"]]
        assert vector["message"]["version"][1] >= cls.SINCE, path.name


def test_nan_vectors_hold_the_canonical_quiet_nan() -> None:
    vector = next(load(p) for p in VECTORS if p.stem.endswith("estimate_invalid_nan"))
    frame = decode_frame(bytes.fromhex(vector["hex"])[:-1])
    nan_bytes = (0x7FC0_0000).to_bytes(4, "little")
    assert frame.message.pack()[15:27] == nan_bytes * 3  # force[0..2] after 15 bytes of header
    assert all(math.isnan(v) for v in (*frame.message.force, *frame.message.torque))
    assert math.isnan(frame.message.region_prob)


@pytest.mark.parametrize("path", VECTORS, ids=lambda p: p.stem)
def test_vector(path: Path) -> None:
    vector = load(path)
    wire = bytes.fromhex(vector["hex"])
    assert wire.endswith(b"\x00") and wire.count(0) == 1, "one frame, one delimiter"
    if not vector["valid"]:
        with pytest.raises(FrameError) as info:
            decode_frame(wire[:-1])
        assert info.value.kind == vector["error"]
        decoder = StreamDecoder()
        assert decoder.feed(wire) == []
        assert getattr(decoder.stats, vector["error"]) == 1
        return
    raw = reference_cobs_decode(wire[:-1])
    assert reference_crc32c(raw[:-4]) == int.from_bytes(raw[-4:], "little")
    frame = decode_frame(wire[:-1])
    meaning = dict(vector["message"])
    seq, version = meaning.pop("seq"), tuple(meaning.pop("version"))
    assert (frame.seq, frame.version) == (seq, version)
    decoded = nan_as_text(frame.message.to_dict())
    # Fields newer than the vector's minor version are zero-filled (SPEC section 8).
    newer = {k: v for k, v in decoded.items() if k not in meaning}
    assert {k: decoded[k] for k in meaning} == nan_as_text(meaning)
    assert all(not any(v) if isinstance(v, list) else v == 0 for v in newer.values()), newer
    cls = messages.MESSAGES_BY_NAME[meaning["type"]]
    expected = cls.from_dict(meaning)
    assert frame.message.pack() == expected.pack()  # bit for bit, NaN included
    if not vector.get("future_minor"):
        # A frozen vector is its minor version's layout: the payload ends where that ends.
        assert (
            encode_raw(cls.TYPE_ID, expected.pack()[: cls.required_size(version[1])], seq, version)
            == wire
        )
