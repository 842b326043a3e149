"""A damaged chunk inside a recording costs that chunk only: the chunks after it are kept,
and the loss is reported as corruption, with counts, apart from truncation."""

from __future__ import annotations

import warnings
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from spectratac.record.errors import (
    CorruptedRecordingWarning,
    RecordingError,
    TruncatedRecordingWarning,
)
from spectratac.record.format import FRAMES
from spectratac.record.reader import read_recording
from spectratac.record.writer import RecordingWriter

CHUNKS, PER_CHUNK = 4, 25


def frame(i: int) -> bytes:
    return bytes([1, 0, 0x84, i % 256, i // 256]) + bytes(range(i % 7, i % 7 + 20))


def write(path: Path) -> list[tuple[int, int]]:
    """A recording of CHUNKS flushed chunks of PER_CHUNK frames; the (start, end) byte range
    of each chunk's frames."""
    spans = []
    with RecordingWriter(path, {}, unix_minus_monotonic_ns=0) as w:
        for c in range(CHUNKS):
            w.flush()
            start = w.bytes_written
            w.frames([(frame(i), float(i)) for i in range(c * PER_CHUNK, (c + 1) * PER_CHUNK)])
            w.flush()
            spans.append((start, w.bytes_written))
    return spans


def read(path: Path) -> tuple[object, list[warnings.WarningMessage]]:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        rec = read_recording(path)
    return rec, caught


@pytest.fixture
def recording(tmp_path: Path) -> tuple[Path, list[tuple[int, int]]]:
    path = tmp_path / "s.mcap"
    return path, write(path)


def flip(path: Path, at: int, mask: int = 0x10) -> None:
    data = bytearray(path.read_bytes())
    data[at] ^= mask
    path.write_bytes(bytes(data))


def test_a_flipped_bit_in_a_chunk_costs_that_chunk_only(recording) -> None:
    path, spans = recording
    start, end = spans[1]
    flip(path, start + (end - start) // 3)  # inside the compressed frames of chunk 2
    rec, caught = read(path)
    frames = [frame(i) for i in range(CHUNKS * PER_CHUNK) if not PER_CHUNK <= i < 2 * PER_CHUNK]
    assert rec.frames == frames
    assert not rec.truncated
    assert rec.corrupted_chunks == 1 and rec.lost_messages == {FRAMES: PER_CHUNK}
    assert [w.category for w in caught] == [CorruptedRecordingWarning]
    assert "1 damaged chunk(s) skipped; messages lost: 25 " + FRAMES in str(caught[0].message)
    assert caught[0].message.lost == {FRAMES: PER_CHUNK}


def test_a_garbled_record_header_is_skipped_to_the_next_chunk(recording) -> None:
    path, spans = recording
    flip(path, spans[2][0] + 3, 0xFF)  # the length field of chunk 3's record header
    rec, caught = read(path)
    assert len(rec.frames) == (CHUNKS - 1) * PER_CHUNK and rec.frames[-1] == frame(99)
    assert rec.corrupted_chunks == 1 and not rec.truncated
    assert CorruptedRecordingWarning in [w.category for w in caught]


def test_truncation_is_still_truncation_not_corruption(recording) -> None:
    path, spans = recording
    path.write_bytes(path.read_bytes()[: spans[2][0] + 30])
    rec, caught = read(path)
    assert rec.truncated and rec.corrupted_chunks == 0 and len(rec.frames) == 2 * PER_CHUNK
    assert [w.category for w in caught] == [TruncatedRecordingWarning]


def records(raw: bytes) -> list[tuple[int, int]]:
    """(offset, opcode) of every top-level record of an intact MCAP file."""
    out, pos = [], 8
    while pos + 9 <= len(raw) - 8:
        out.append((pos, raw[pos]))
        pos += 9 + int.from_bytes(raw[pos + 1 : pos + 9], "little")
    return out


def test_a_message_index_hit_in_its_opcode_is_not_read_as_a_frame(recording) -> None:
    # found by the property below: one bit turned a message index (0x07) into a message
    # (0x05), whose "data" (the index's time/offset pairs) came back as a 101st frame
    path, _ = recording
    indexes = [at for at, op in records(path.read_bytes()) if op == 0x07]
    assert len(indexes) >= CHUNKS
    for at in indexes:
        flip(path, at, 0x02)
        rec, _ = read(path)
        assert rec.frames == [frame(i) for i in range(CHUNKS * PER_CHUNK)], at
        flip(path, at, 0x02)  # mended for the next


@settings(
    max_examples=150,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
@given(data=st.data())
def test_any_damage_gives_a_typed_error_or_an_ordered_subset(tmp_path: Path, data) -> None:
    path = tmp_path / "fuzz.mcap"
    if not path.exists():
        write(path)
    raw = bytearray(path.read_bytes())
    for _ in range(data.draw(st.integers(1, 6))):
        raw[data.draw(st.integers(0, len(raw) - 1))] ^= data.draw(st.integers(1, 255))
    if data.draw(st.booleans()):
        del raw[data.draw(st.integers(0, len(raw) - 1)) :]
    damaged = tmp_path / "damaged.mcap"
    damaged.write_bytes(bytes(raw))
    try:
        rec, _ = read(damaged)
    except RecordingError:
        return
    written = [frame(i) for i in range(CHUNKS * PER_CHUNK)]
    positions = [written.index(f) for f in rec.frames]  # every frame read was written ...
    assert positions == sorted(set(positions))  # ... once, in order
    assert len(rec.frames) + rec.lost_messages.get(FRAMES, 0) <= len(written)
