"""The compact channels' bytes as protobuf messages of one `bytes data = 1` field, so that
Foxglove (any player that decodes `protobuf`) opens them instead of raising an alert.

A message is the compact payload behind a two-to-six-byte prefix (field tag, varint length):
exact bytes, no copy of any value, written and read without the protobuf library. The
channel's schema is a `FileDescriptorSet` holding that one message type, built here by hand
(tests/record check it with the protobuf library and with Lichtblick's parse rules).

>>> unwrap(wrap(b"abc")) == b"abc", wrap(b"abc")[:2]
(True, b'\\n\\x03')
"""

from __future__ import annotations

ENCODING = "protobuf"  # message encoding and schema encoding (MCAP well-known)
PACKAGE = "spectratac"
_TAG = 0x0A  # field 1, wire type 2 (length-delimited)


def _varint(n: int) -> bytes:
    out = bytearray()
    while n > 0x7F:
        out.append(n & 0x7F | 0x80)
        n >>= 7
    out.append(n)
    return bytes(out)


def _field(number: int, value: bytes | str | int) -> bytes:
    if isinstance(value, int):
        return _varint(number << 3) + _varint(value)
    data = value.encode() if isinstance(value, str) else value
    return _varint(number << 3 | 2) + _varint(len(data)) + data


def wrap(data: bytes) -> bytes:
    """`data` as the message `{data: data}`."""
    n = len(data)
    return (bytes((_TAG, n)) if n < 0x80 else bytes((_TAG,)) + _varint(n)) + data


def unwrap(message: bytes) -> bytes:
    """The `data` field of a wrapped message (ValueError if it is not one)."""
    if len(message) >= 2 and message[0] == _TAG and message[1] == len(message) - 2 < 0x80:
        return bytes(message[2:])  # the common case: a frame shorter than 128 bytes
    if not message or message[0] != _TAG:
        raise ValueError("not a wrapped compact message (no field-1 bytes tag)")
    n, shift, i = 0, 0, 1
    while True:
        if i >= len(message) or shift > 63:
            raise ValueError("a wrapped compact message's length is cut")
        byte = message[i]
        n |= (byte & 0x7F) << shift
        i += 1
        if not byte & 0x80:
            break
        shift += 7
    if i + n != len(message):
        raise ValueError(f"a wrapped compact message says {n} bytes but holds {len(message) - i}")
    return bytes(message[i:])


def schema(name: str) -> tuple[str, bytes]:
    """(full name, FileDescriptorSet bytes) of `message <name> { bytes data = 1; }` in
    package `spectratac` (file `spectratac/<name>.proto`)."""
    field_descriptor = (
        _field(1, "data")  # name
        + _field(3, 1)  # number
        + _field(4, 1)  # LABEL_OPTIONAL
        + _field(5, 12)  # TYPE_BYTES
        + _field(10, "data")  # json_name
    )
    message = _field(1, name) + _field(2, field_descriptor)
    file_descriptor = (
        _field(1, f"spectratac/{name}.proto")
        + _field(2, PACKAGE)
        + _field(4, message)
        + _field(12, "proto3")
    )
    return f"{PACKAGE}.{name}", _field(1, file_descriptor)
