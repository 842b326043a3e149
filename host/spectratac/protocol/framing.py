"""One frame on the wire: header + payload + CRC-32C, COBS-encoded, 0x00-terminated (SPEC.md).

>>> from spectratac.protocol.generated import messages as m
>>> wire = encode_frame(m.Ack(acked_type=0x02, acked_seq=7, config_id=3), seq=41)
>>> wire[-1]
0
>>> frame = decode_frame(wire[:-1])
>>> frame.seq, frame.message
(41, Ack(acked_type=2, acked_seq=7, config_id=3))
"""

from __future__ import annotations

import struct
from dataclasses import dataclass

import crcmod.predefined
from cobs import cobs

from spectratac.errors import SpectraTacError
from spectratac.protocol.accel import require_extensions
from spectratac.protocol.generated import messages as m
from spectratac.protocol.schema import Message

require_extensions()

#: CRC-32C (Castagnoli): poly 0x1EDC6F41, init 0xFFFFFFFF, reflected in and out,
#: xorout 0xFFFFFFFF, check value 0xE3069283 for b"123456789".
crc32c = crcmod.predefined.mkCrcFun("crc-32c")

#: CRC-32C over a whole frame *including* its little-endian CRC is always this constant
#: (the residue), which lets a decoder check a frame without slicing the CRC off.
CRC_RESIDUE = 0x48674BC7

HEADER = struct.Struct("<BBBH")  # major, minor, type, seq
CRC = struct.Struct("<I")
MIN_FRAME = HEADER.size + CRC.size  # decoded bytes of a frame with an empty payload
MAX_DECODED = HEADER.size + m.MAX_PAYLOAD + CRC.size
MAX_ENCODED = m.MAX_FRAME - 1  # COBS bytes between delimiters


class FrameError(SpectraTacError):
    """A frame could not be decoded; `kind` names the reason (as used in golden vectors)."""

    kind = "frame"


class CobsError(FrameError):
    kind = "bad_cobs"


class CrcError(FrameError):
    kind = "bad_crc"


class OversizeError(FrameError):
    kind = "oversize"


class TooShortError(FrameError):
    kind = "too_short"


class ShortPayloadError(FrameError):
    """A payload shorter than the fields its sender's version has (SPEC.md, section 8)."""

    kind = "short_payload"

    def __init__(self, name: str, got: int, need: int, version: tuple[int, int]) -> None:
        super().__init__(
            f"{name} payload of {got} B from a {version[0]}.{version[1]} sender is shorter "
            f"than the {need} B that version sends; dropped (a sender bug or a damaged frame "
            f"that passed the CRC)"
        )
        self.got = got
        self.need = need


class UnknownTypeError(FrameError):
    kind = "unknown_type"

    def __init__(self, type_id: int, seq: int) -> None:
        super().__init__(f"unknown message type 0x{type_id:02X} (seq {seq}); skipped")
        self.type_id = type_id
        self.seq = seq


class VersionMismatchError(FrameError):
    """The peer speaks another protocol major version; both versions are named."""

    kind = "version_mismatch"

    def __init__(self, remote: tuple[int, int]) -> None:
        super().__init__(
            f"protocol version mismatch: the peer speaks {remote[0]}.{remote[1]}, this host "
            f"speaks {m.PROTOCOL_MAJOR}.{m.PROTOCOL_MINOR}; major versions must agree. Update "
            f"the host library or reflash the firmware so that both speak {m.PROTOCOL_MAJOR}.x"
        )
        self.remote = remote


@dataclass(slots=True)  # not frozen: frozen dataclasses cost 3x more to build per frame
class Frame:
    """A decoded frame: the sender's protocol version and sequence number, the message, and
    the frame's decoded bytes (header, payload, CRC; what a recorder stores verbatim)."""

    version: tuple[int, int]
    seq: int
    message: Message
    raw: bytes = b""


def encode_frame(
    message: Message,
    seq: int,
    version: tuple[int, int] = (m.PROTOCOL_MAJOR, m.PROTOCOL_MINOR),
    *,
    validate: bool = True,
) -> bytes:
    """Encode `message` as wire bytes including the trailing 0x00 delimiter, in the layout of
    `version`: an older minor version's frame carries only the fields that version knows.

    Raises FieldValueError (a ValueError) naming the field when a value is not allowed.
    """
    if validate:
        message.validate()
    if not 0 <= seq <= 0xFFFF:
        raise ValueError(f"seq = {seq} does not fit u16 (0..65535)")
    payload = message.pack()[: type(message).required_size(version[1])]
    raw = HEADER.pack(version[0], version[1], message.TYPE_ID, seq) + payload
    return bytes(cobs.encode(raw + CRC.pack(crc32c(raw)))) + b"\x00"  # cobs is untyped


def encode_raw(type_id: int, payload: bytes, seq: int, version: tuple[int, int] = (1, 0)) -> bytes:
    """Frame arbitrary payload bytes (for tests, vectors and future-version emulation)."""
    raw = HEADER.pack(version[0], version[1], type_id, seq) + payload
    return bytes(cobs.encode(raw + CRC.pack(crc32c(raw)))) + b"\x00"  # cobs is untyped


def unframe(encoded: bytes) -> bytes:
    """COBS-decode and CRC-check one frame (without delimiter); return header + payload."""
    if len(encoded) > MAX_ENCODED:
        raise OversizeError(f"frame of {len(encoded)} B exceeds {MAX_ENCODED} B; dropped")
    try:
        raw: bytes = cobs.decode(encoded)
    except cobs.DecodeError as exc:
        raise CobsError(f"bad COBS encoding: {exc}") from None
    if len(raw) < MIN_FRAME:
        raise TooShortError(f"frame of {len(raw)} B is shorter than the {MIN_FRAME} B minimum")
    if len(raw) > MAX_DECODED:
        raise OversizeError(f"payload exceeds the {m.MAX_PAYLOAD} B maximum; dropped")
    if crc32c(raw) != CRC_RESIDUE:
        raise CrcError("CRC-32C mismatch; frame corrupted in transit")
    return raw[:-4]


def parse_body(body: bytes) -> Frame:
    """Turn a CRC-checked header + payload into a Frame (version and type checked)."""
    major, minor, type_id, seq = HEADER.unpack_from(body)
    if major != m.PROTOCOL_MAJOR:
        raise VersionMismatchError((major, minor))
    cls = m.MESSAGES_BY_ID.get(type_id)
    if cls is None:
        raise UnknownTypeError(type_id, seq)
    need = cls.required_size(minor)
    if len(body) - HEADER.size < need:
        raise ShortPayloadError(cls.NAME, len(body) - HEADER.size, need, (major, minor))
    return Frame(
        (major, minor), seq, cls.unpack(body[HEADER.size :]), body + CRC.pack(crc32c(body))
    )


def decode_frame(encoded: bytes) -> Frame:
    """Decode one frame given without its 0x00 delimiter; raises a FrameError subclass."""
    return parse_body(unframe(encoded))
