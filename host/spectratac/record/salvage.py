"""Walk an MCAP file record by record, keeping every intact chunk: a damaged chunk (CRC
mismatch, bad compression, garbled framing) is skipped and counted, and reading resumes at the
next record; a file that simply ends early is reported as truncated, which is a different thing.

Messages lost in damaged chunks are counted per channel from the file's statistics record
(exact, when the summary at the end survived) or else from the message indexes that follow
each damaged chunk. Messages of the topics in `skip_topics` are passed over unparsed (and
counted in `skipped_by_channel`): a reader that ignores them pays only their decompression.

>>> import io
>>> from mcap.writer import CompressionType, Writer
>>> buf = io.BytesIO()
>>> w = Writer(buf, chunk_size=64, compression=CompressionType.NONE)
>>> w.start()
>>> ch = w.register_channel("t", "json", w.register_schema("s", "jsonschema", b"{}"))
>>> for i in range(6):
...     w.add_message(ch, log_time=i, publish_time=i, data=b"%d" % i * 40)
>>> w.finish()
>>> data = bytearray(buf.getvalue())
>>> chunk = data.index(b"3333")  # a byte inside the fourth message's chunk
>>> data[chunk] ^= 0x01
>>> s = salvage(bytes(data))
>>> len(s.messages()), s.corrupted_chunks, dict(s.lost_by_channel), s.truncated
(5, 1, {1: 1}, False)
"""

from __future__ import annotations

import io
import struct
import zlib
from collections import Counter
from dataclasses import dataclass, field

from mcap.data_stream import ReadDataStream
from mcap.exceptions import McapError
from mcap.opcode import Opcode
from mcap.records import (
    Channel,
    Chunk,
    DataEnd,
    Footer,
    Header,
    McapRecord,
    Message,
    MessageIndex,
    Schema,
    Statistics,
)
from mcap.stream_reader import get_chunk_data_stream

# zstandard comes with mcap's writer; its errors are raised by the decompressor, unwrapped
from zstandard import ZstdError
from zstandard import frame_content_size as zstd_frame_content_size

MAGIC = b"\x89MCAP0\r\n"
#: What parsing damaged bytes can raise (a garbled length can ask for absurd sizes).
READ_ERRORS = (McapError, struct.error, ValueError, EOFError, zlib.error, ZstdError, KeyError,
               IndexError, OverflowError, MemoryError)  # fmt: skip
_KNOWN = {int(op) for op in Opcode}
_READERS = {
    Opcode.HEADER: Header.read,
    Opcode.SCHEMA: Schema.read,
    Opcode.CHANNEL: Channel.read,
    Opcode.CHUNK: Chunk.read,
    Opcode.MESSAGE_INDEX: MessageIndex.read,
    Opcode.DATA_END: DataEnd.read,
    Opcode.FOOTER: Footer.read,
    Opcode.STATISTICS: Statistics.read,
}
_COMPRESSIONS = (b"", b"zstd", b"lz4")


@dataclass
class Salvage:
    """What could be read: the data records in file order (chunks opened), and the damage."""

    records: list[McapRecord] = field(default_factory=list)
    summary_channels: list[Channel] = field(default_factory=list)  # repeated after the data
    corrupted_chunks: int = 0  # damaged chunks skipped (a garbled stretch counts as one)
    lost_by_channel: Counter[int] = field(default_factory=Counter)
    skipped_by_channel: Counter[int] = field(default_factory=Counter)  # intact, not parsed
    lost_uncounted: bool = False  # damage whose message count no index or statistics tells
    data_complete: bool = False  # the data section's end was reached
    finished: bool = False  # the footer and the closing magic were reached
    truncated: bool = False
    problem: str = ""  # why reading stopped early

    def messages(self) -> list[Message]:
        return [r for r in self.records if isinstance(r, Message)]

    @property
    def lost_messages(self) -> int:
        return sum(self.lost_by_channel.values())


def salvage(buf: bytes | memoryview, skip_topics: frozenset[str] = frozenset()) -> Salvage:
    """Every intact record of the MCAP file held in `buf` (see the module documentation);
    messages of `skip_topics` are counted, not parsed."""
    out = Salvage()
    topics: dict[int, str] = {}  # channel id -> topic, as the channel records arrive
    n = len(buf)
    if bytes(buf[:8]) != MAGIC:
        out.truncated, out.problem = True, "not an MCAP file (no MCAP magic at its start)"
        return out
    pos, counting, stats = 8, False, None
    in_indexes = False  # after a chunk, where only its message indexes may stand
    while pos < n:
        if n - pos < 9:
            out.problem = "the file ends inside a record header"
            break
        op, length = buf[pos], struct.unpack_from("<Q", buf, pos + 1)[0]
        end = pos + 9 + length
        if op not in _KNOWN or end > n:
            nxt = _resync(buf, pos + 1)
            if nxt is None:  # nothing readable follows: the file ends early
                out.problem = (
                    f"the file ends inside a {Opcode(op).name} record"
                    if op in _KNOWN
                    else f"the file ends in {n - pos} unreadable bytes"
                )
                break
            out.corrupted_chunks += 1
            out.lost_uncounted = True
            pos, counting = nxt, False
            continue
        try:
            stream = ReadDataStream(io.BytesIO(buf[pos + 9 : end]))
            if op == Opcode.MESSAGE and in_indexes:
                # a message index whose opcode was hit (0x07 ^ 0x02 = 0x05): its entries
                # would read as a message of the indexed channel; ignored like any index
                record: McapRecord | None = None
            elif op == Opcode.MESSAGE:  # outside chunks (files from other writers)
                record = Message.read(stream, length)
            elif op == Opcode.MESSAGE_INDEX and not counting:
                record = None  # only a damaged chunk's indexes are read (the costly part)
            else:
                record = _READERS[Opcode(op)](stream)
        except (KeyError, *READ_ERRORS):  # a record this reader has no use for, or damaged
            record = None
        pos = end
        in_indexes = op in (Opcode.CHUNK, Opcode.MESSAGE_INDEX) or (
            in_indexes and op == Opcode.MESSAGE
        )
        if isinstance(record, Footer):
            out.finished = bytes(buf[end : end + 8]) == MAGIC
            break  # only the closing magic follows
        if out.data_complete:  # the summary: channels again, and the message counts
            if isinstance(record, Channel):
                out.summary_channels.append(record)
            elif isinstance(record, Statistics):
                stats = record
            continue
        if isinstance(record, Chunk):
            try:
                _check_chunk_size(record)
                out.records += _breakup_chunk(record, topics, skip_topics, out)
                counting = False
            except READ_ERRORS:
                out.corrupted_chunks += 1
                counting = True  # the message indexes that follow say what it held
        elif op == Opcode.CHUNK:
            out.corrupted_chunks += 1
            out.lost_uncounted = counting = True
        elif isinstance(record, MessageIndex):
            if counting:
                out.lost_by_channel[record.channel_id] += len(record.records)
        elif isinstance(record, DataEnd):
            out.data_complete = True
        elif record is not None:
            if isinstance(record, Channel):
                topics[record.id] = record.topic
            out.records.append(record)
    if not out.finished:
        out.truncated = True
        out.problem = out.problem or "the file ends without an MCAP footer"
        if out.data_complete:
            out.problem += " (after its data section: every message was read)"
    if stats is not None and out.corrupted_chunks:
        read = Counter(m.channel_id for m in out.messages()) + out.skipped_by_channel
        out.lost_by_channel = Counter(
            {c: k - read[c] for c, k in stats.channel_message_counts.items() if k > read[c]}
        )
        out.lost_uncounted = False
    return out


_RECORD = struct.Struct("<BQ")  # opcode, length
_MESSAGE = struct.Struct("<HIQQ")  # channel id, sequence, log time, publish time


def _breakup_chunk(
    chunk: Chunk, topics: dict[int, str], skip_topics: frozenset[str], out: Salvage
) -> list[McapRecord]:
    """The records of a chunk (CRC checked), as mcap's breakup_chunk gives them, except
    that messages of `skip_topics` are counted in `out.skipped_by_channel` unparsed.
    Messages are cut straight from the decompressed bytes (mcap's field-by-field stream
    reads cost several times more)."""
    stream, size = get_chunk_data_stream(chunk, validate_crc=True)
    data = stream.read(size)
    records: list[McapRecord] = []
    skipped: Counter[int] = Counter()
    record_head, message_head = _RECORD, _MESSAGE
    pos = 0
    while pos < size:
        opcode, length = record_head.unpack_from(data, pos)
        body, pos = pos + record_head.size, pos + record_head.size + length
        if pos > size:
            raise McapError(f"a record in a chunk runs {pos - size} bytes past its end")
        if opcode == Opcode.MESSAGE:
            channel_id, sequence, log_time, publish_time = message_head.unpack_from(data, body)
            if topics.get(channel_id) in skip_topics:
                skipped[channel_id] += 1
                continue
            records.append(Message(channel_id=channel_id, sequence=sequence, log_time=log_time,
                                   publish_time=publish_time,
                                   data=data[body + message_head.size : pos]))  # fmt: skip
        elif opcode == Opcode.CHANNEL:
            channel = Channel.read(ReadDataStream(io.BytesIO(data[body:pos])))
            topics[channel.id] = channel.topic
            records.append(channel)
        elif opcode == Opcode.SCHEMA:
            records.append(Schema.read(ReadDataStream(io.BytesIO(data[body:pos]))))
        # other record types do not occur in chunks of this MCAP version: passed over
    out.skipped_by_channel += skipped  # only once the whole chunk is known to be intact
    return records


#: The most a chunk may claim to grow on decompression: far above what zstd gives recorded
#: frames (~1.5x), far below what a damaged size field can ask the decompressor to allocate.
MAX_CHUNK_RATIO = 64
MAX_CHUNK_FLOOR = 16 << 20


def _check_chunk_size(chunk: Chunk) -> None:
    """Refuse (McapError) a chunk whose claimed size cannot be real, before decompressing:
    zstd allocates what the frame header claims, whatever the chunk says (1.4 GB seen from a
    damaged 273-byte chunk)."""
    limit = max(MAX_CHUNK_RATIO * len(chunk.data), MAX_CHUNK_FLOOR)
    claimed = [chunk.uncompressed_size]
    if chunk.compression == "zstd":
        size = zstd_frame_content_size(chunk.data)
        if size >= 0 and size != chunk.uncompressed_size:
            raise McapError(f"zstd frame of {size} bytes in a chunk of {chunk.uncompressed_size}")
        claimed.append(size)
    if max(claimed) > limit:
        raise McapError(f"a chunk of {len(chunk.data)} bytes claims {max(claimed)} uncompressed")


def _resync(buf: bytes | memoryview, start: int) -> int | None:
    """The offset of the next plausible chunk or data-end record at or after `start`."""
    n = len(buf)
    data = buf if isinstance(buf, bytes) else bytes(buf)
    pos = start
    while True:
        chunk = data.find(bytes([Opcode.CHUNK]), pos)
        data_end = data.find(bytes([Opcode.DATA_END]), pos)
        candidates = [c for c in (chunk, data_end) if c >= 0]
        if not candidates:
            return None
        pos = min(candidates)
        if _plausible(data, pos, n):
            return pos
        pos += 1


def _plausible(buf: bytes, pos: int, n: int) -> bool:
    """Whether a well-formed chunk or data-end record, followed by a known record or the end
    of the file, starts at `pos`."""
    if n - pos < 13:
        return False
    length = struct.unpack_from("<Q", buf, pos + 1)[0]
    end = pos + 9 + length
    if end > n or not (end == n or buf[end] in _KNOWN):
        return False
    if buf[pos] == Opcode.DATA_END:
        return length == 4
    header = 8 + 8 + 8 + 4 + 4
    if length < header + 8:
        return False
    comp_len = struct.unpack_from("<I", buf, pos + 9 + header - 4)[0]
    if comp_len > 8 or length < header + comp_len + 8:
        return False
    compression = buf[pos + 9 + header : pos + 9 + header + comp_len]
    records_len = struct.unpack_from("<Q", buf, pos + 9 + header + comp_len)[0]
    return compression in _COMPRESSIONS and records_len == length - header - comp_len - 8
