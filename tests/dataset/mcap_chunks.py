"""Where in a recording to cut or damage: the middle one of the MCAP chunks that hold frames.
(A fixed share of the file is not: when a loaded host let the F/T run on after the optical
stream, the file's last third, or its middle chunk, held F/T rows alone.)"""

from __future__ import annotations

from pathlib import Path

from mcap.reader import make_reader
from spectratac.record.format import FRAMES


def middle_frame_chunk(path: Path, at_least: int) -> tuple[int, int]:
    """(offset, length) in bytes of the middle chunk that holds frames; asserts the file has
    `at_least` such chunks, so the middle one has others on both sides."""
    with open(path, "rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None, f"{path} has no summary section"
    [frames] = [c.id for c in summary.channels.values() if c.topic == FRAMES]
    chunks = [c for c in summary.chunk_indexes if frames in c.message_index_offsets]
    assert len(chunks) >= at_least, f"{path} holds its frames in {len(chunks)} chunk(s) only"
    middle = chunks[len(chunks) // 2]
    return middle.chunk_start_offset, middle.chunk_length
