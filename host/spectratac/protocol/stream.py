"""Incremental stream decoder: arbitrary byte chunks in, decoded frames out.

It never raises on bad input. Every frame is delimited by 0x00, so a damaged frame costs only
itself: the decoder resynchronises at the next delimiter and counts what it dropped.

    >>> from spectratac.protocol.generated import messages as m
    >>> from spectratac.protocol.framing import encode_frame
    >>> wire = b"\\x13garbage\\x00" + encode_frame(m.Start(), seq=1) + encode_frame(m.Stop(), seq=2)
    >>> decoder = StreamDecoder()
    >>> first = decoder.feed(wire[:12])  # chunks may cut frames anywhere
    >>> [f.message.NAME for f in first + decoder.feed(wire[12:])]
    ['START', 'STOP']
    >>> decoder.stats.bad_cobs + decoder.stats.bad_crc + decoder.stats.too_short
    1
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

from cobs import cobs

from spectratac.protocol.framing import (
    CRC_RESIDUE,
    HEADER,
    MAX_DECODED,
    MAX_ENCODED,
    MIN_FRAME,
    Frame,
    crc32c,
)
from spectratac.protocol.generated import messages as m

_SEQ_RESTART = 0x8000  # a backwards jump this large is a sender restart, not 32k lost frames


@dataclass
class DecoderStats:
    """What a decoder saw. Drops are counted per reason; nothing is dropped silently."""

    bytes_in: int = 0
    frames_ok: int = 0
    bad_cobs: int = 0
    bad_crc: int = 0
    too_short: int = 0
    oversize: int = 0
    unknown_type: int = 0
    short_payload: int = 0  # shorter than the fields of the sender's version: not zero-filled
    version_mismatch: int = 0
    seq_gaps: int = 0  # frames missing according to the sender's sequence numbers
    seq_restarts: int = 0  # the sender's sequence jumped back (it restarted)
    #: protocol version of the last frame refused for its major version, for error messages
    remote_version: tuple[int, int] | None = None

    @property
    def dropped(self) -> int:
        return (
            self.bad_cobs
            + self.bad_crc
            + self.too_short
            + self.oversize
            + self.unknown_type
            + self.short_payload
            + self.version_mismatch
        )

    def as_dict(self) -> dict[str, object]:
        return asdict(self) | {"dropped": self.dropped}


class StreamDecoder:
    """Feed bytes as they arrive; get back the frames completed by them, in order."""

    def __init__(self) -> None:
        self.stats = DecoderStats()
        self._pending = b""
        self._discarding = False  # inside an oversize run, waiting for the next delimiter
        self._last_seq: int | None = None

    def feed(self, chunk: bytes) -> list[Frame]:
        stats = self.stats
        stats.bytes_in += len(chunk)
        if self._discarding:  # inside an oversize run (already counted): skip to its delimiter
            end = chunk.find(b"\x00")
            if end < 0:
                return []
            chunk = chunk[end + 1 :]
            self._discarding = False
        parts = (self._pending + chunk).split(b"\x00") if self._pending else chunk.split(b"\x00")
        tail = parts.pop()
        out: list[Frame] = []
        decode = cobs.decode
        by_id = m.MESSAGES_BY_ID
        major = m.PROTOCOL_MAJOR
        last_seq = self._last_seq
        for part in parts:
            if not part:
                continue  # back-to-back delimiters are legal idle filler
            if len(part) > MAX_ENCODED:
                stats.oversize += 1
                continue
            try:
                raw = decode(part)
            except cobs.DecodeError:
                stats.bad_cobs += 1
                continue
            if len(raw) < MIN_FRAME:
                stats.too_short += 1
                continue
            if len(raw) > MAX_DECODED:
                stats.oversize += 1
                continue
            if crc32c(raw) != CRC_RESIDUE:
                stats.bad_crc += 1
                continue
            v_major, v_minor, type_id, seq = HEADER.unpack_from(raw)
            if last_seq is not None:  # inlined sequence tracking: this loop is the hot path
                missing = (seq - last_seq - 1) & 0xFFFF
                if missing >= _SEQ_RESTART:
                    stats.seq_restarts += 1
                else:
                    stats.seq_gaps += missing
            last_seq = seq
            if v_major != major:
                stats.version_mismatch += 1
                stats.remote_version = (v_major, v_minor)
                continue
            cls = by_id.get(type_id)
            if cls is None:
                stats.unknown_type += 1
                continue
            if len(raw) - MIN_FRAME < cls.required_size(v_minor):
                stats.short_payload += 1
                continue
            out.append(Frame((v_major, v_minor), seq, cls.unpack(raw[5:-4]), raw))
        self._last_seq = last_seq
        stats.frames_ok += len(out)
        if len(tail) > MAX_ENCODED:
            stats.oversize += 1
            self._discarding = True
            tail = b""
        self._pending = tail
        return out

    def reset(self) -> None:
        """Forget partial input and the sequence baseline (e.g. after reopening a port)."""
        self._pending = b""
        self._discarding = False
        self._last_seq = None
