"""Bulk decoding: a buffer holding many frames to one NumPy structured array of samples.

For recordings and high-rate links: COBS and CRC run per frame in C, then a single
``np.frombuffer`` turns all sample frames into columns without a Python object per sample.

    >>> from spectratac.protocol.generated import messages as m
    >>> from spectratac.protocol.framing import encode_frame
    >>> wire = b"".join(encode_frame(m.Sample(sample_seq=i), seq=i) for i in range(3))
    >>> result = decode_samples(wire)
    >>> result.samples["sample_seq"].tolist(), result.samples["counts"].shape
    ([0, 1, 2], (3, 3, 5))
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from cobs import cobs

from spectratac.protocol.framing import (
    CRC_RESIDUE,
    HEADER,
    MAX_DECODED,
    MAX_ENCODED,
    MIN_FRAME,
    crc32c,
)
from spectratac.protocol.generated import messages as m
from spectratac.protocol.schema import FieldSpec, Message
from spectratac.protocol.stream import DecoderStats

_NUMPY_TYPES = {
    "u8": "u1",
    "u16": "<u2",
    "u32": "<u4",
    "u64": "<u8",
    "i8": "i1",
    "i16": "<i2",
    "i32": "<i4",
    "f32": "<f4",
}


def _field_dtype(spec: FieldSpec) -> tuple[str, str] | tuple[str, str, tuple[int, ...]]:
    if spec.type in ("char", "bytes"):
        return (spec.name, f"S{spec.count}")
    if spec.shape:
        return (spec.name, _NUMPY_TYPES[spec.type], spec.shape)
    return (spec.name, _NUMPY_TYPES[spec.type])


def payload_dtype(message: type[Message]) -> np.dtype:
    """Packed structured dtype matching a message's payload byte for byte."""
    return np.dtype([_field_dtype(f) for f in message.FIELDS])


SAMPLE_DTYPE = payload_dtype(m.Sample)
#: a whole decoded sample frame: header, payload, CRC
_FRAME_DTYPE = np.dtype(
    [("major", "u1"), ("minor", "u1"), ("type", "u1"), ("seq", "<u2")]
    + [_field_dtype(f) for f in m.Sample.FIELDS]
    + [("crc", "<u4")]
)
_SAMPLE_FRAME = _FRAME_DTYPE.itemsize


@dataclass
class BulkResult:
    samples: np.ndarray  # read-only; SAMPLE_DTYPE fields plus "seq" (frame sequence number)
    other: int  # good frames of other message types, skipped
    stats: DecoderStats
    tail: bytes  # bytes after the last delimiter (an incomplete frame)


def decode_samples(data: bytes) -> BulkResult:
    """Decode every complete frame in `data`; return the SAMPLE frames as one array."""
    stats = DecoderStats(bytes_in=len(data))
    parts = data.split(b"\x00")
    tail = parts.pop()
    decode = cobs.decode
    size = _SAMPLE_FRAME
    kept: list[bytes] = []
    keep = kept.append
    other = 0
    for part in parts:
        if not part:
            continue
        try:
            raw = decode(part)
        except cobs.DecodeError:
            stats.bad_cobs += 1
            continue
        n = len(raw)
        if n == size and raw[2] == 0x84 and raw[0] == 1 and crc32c(raw) == CRC_RESIDUE:
            keep(raw)  # fast path: a current-version sample
            continue
        kind = _classify(raw, len(part))
        if kind == "sample":
            keep(_fit_sample(raw))
        elif kind == "other":
            other += 1
        else:
            setattr(stats, kind, getattr(stats, kind) + 1)
            if kind == "version_mismatch":
                stats.remote_version = (raw[0], raw[1])
    frames = np.frombuffer(b"".join(kept), dtype=_FRAME_DTYPE)
    stats.frames_ok = len(frames) + other
    # a view (no copy) that hides the header bytes and the CRC
    return BulkResult(frames[["seq", *(SAMPLE_DTYPE.names or ())]], other, stats, tail)


def _classify(raw: bytes, encoded_len: int) -> str:
    """Slow path for anything that is not a current-size sample frame."""
    if encoded_len > MAX_ENCODED or len(raw) > MAX_DECODED:
        return "oversize"
    if len(raw) < MIN_FRAME:
        return "too_short"
    if crc32c(raw) != CRC_RESIDUE:
        return "bad_crc"
    major, minor, type_id, _seq = HEADER.unpack_from(raw)
    if major != m.PROTOCOL_MAJOR:
        return "version_mismatch"
    cls = m.MESSAGES_BY_ID.get(type_id)
    if cls is None:
        return "unknown_type"
    if len(raw) - MIN_FRAME < cls.required_size(minor):
        return "short_payload"
    return "sample" if cls is m.Sample else "other"


def _fit_sample(raw: bytes) -> bytes:
    """Minor-version rule on a sample frame that holds its sender's fields: cut unknown
    trailing bytes, zero-fill the fields newer than the sender."""
    body = raw[HEADER.size : -4]
    payload = m.Sample.unpack(body).pack()
    return raw[: HEADER.size] + payload + raw[-4:]
