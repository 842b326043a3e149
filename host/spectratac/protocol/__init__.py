"""The SpectraTac wire protocol on the host: generated messages plus framing and decoders.

See protocol/SPEC.md for the contract; `spectratac.protocol.generated.messages` (the message
classes, enums and limits) is generated from hardware/definitions/messages.toml.
"""

from spectratac.protocol.bulk import SAMPLE_DTYPE, BulkResult, decode_samples, payload_dtype
from spectratac.protocol.framing import (
    CobsError,
    CrcError,
    Frame,
    FrameError,
    OversizeError,
    ShortPayloadError,
    TooShortError,
    UnknownTypeError,
    VersionMismatchError,
    crc32c,
    decode_frame,
    encode_frame,
    encode_raw,
)
from spectratac.protocol.schema import FieldValueError, Message
from spectratac.protocol.stream import DecoderStats, StreamDecoder

__all__ = [
    "SAMPLE_DTYPE",
    "BulkResult",
    "CobsError",
    "CrcError",
    "DecoderStats",
    "FieldValueError",
    "Frame",
    "FrameError",
    "Message",
    "OversizeError",
    "ShortPayloadError",
    "StreamDecoder",
    "TooShortError",
    "UnknownTypeError",
    "VersionMismatchError",
    "crc32c",
    "decode_frame",
    "decode_samples",
    "encode_frame",
    "encode_raw",
    "payload_dtype",
]
