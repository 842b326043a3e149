"""Fault injection on the byte stream: untouched frames all survive, corrupted ones never pass.

A frame counts as untouched when its own bytes, its delimiter and the delimiter before it are
intact; damage that removes a delimiter merges two frames, so both are lost (and counted).
"""

from __future__ import annotations

import itertools
import random
from dataclasses import dataclass

from hypothesis import given, settings
from hypothesis import strategies as st
from spectratac.protocol import StreamDecoder, encode_frame
from spectratac.protocol.generated import messages

from .strategies import any_message, same


@dataclass(frozen=True)
class Damage:
    op: str  # "none", "flip", "insert", "delete", "truncate"
    where: float  # position as a fraction of the frame's length
    value: int  # the bit to flip or the byte to insert

    def apply(self, wire: bytes) -> tuple[bytes, bool]:
        """The damaged bytes, and whether the frame's trailing delimiter is gone."""
        n = len(wire)
        if self.op == "flip":
            i = min(int(self.where * n), n - 1)
            return wire[:i] + bytes([wire[i] ^ (1 << (self.value % 8))]) + wire[i + 1 :], i == n - 1
        if self.op == "insert":
            # strictly inside the body: a 0x00 next to a delimiter is idle filler, not damage
            i = min(max(int(self.where * n), 1), n - 2)
            return wire[:i] + bytes([self.value]) + wire[i:], False
        if self.op == "delete":
            i = min(int(self.where * n), n - 1)
            return wire[:i] + wire[i + 1 :], i == n - 1
        if self.op == "truncate":
            return wire[: min(max(int(self.where * n), 1), n - 1)], True
        return wire, False


damage = st.builds(
    Damage,
    st.sampled_from(["none", "none", "none", "flip", "insert", "delete", "truncate"]),
    st.floats(0, 1, exclude_max=True),
    st.integers(0, 255),
)


def corrupt_stream(frames: list[bytes], damages: list[Damage]) -> tuple[bytes, list[int]]:
    """The damaged stream and the indices of frames that must come out intact."""
    out, survivors, previous_delimiter_lost = [], [], False
    for i, (wire, dmg) in enumerate(zip(frames, damages, strict=True)):
        damaged, delimiter_lost = dmg.apply(wire)
        if dmg.op == "none" and not previous_delimiter_lost:
            survivors.append(i)
        out.append(damaged)
        previous_delimiter_lost = delimiter_lost
    return b"".join(out), survivors


def decode_in_chunks(stream: bytes, cuts: list[int]) -> tuple[list, StreamDecoder]:
    decoder = StreamDecoder()
    frames = []
    bounds = [0, *sorted(cuts), len(stream)]
    for a, b in itertools.pairwise(bounds):
        frames += decoder.feed(stream[a:b])
    return frames, decoder


@settings(max_examples=300)
@given(
    st.lists(st.tuples(any_message, damage), min_size=1, max_size=25),
    st.lists(st.integers(0, 10_000), max_size=12),
)
def test_untouched_frames_survive_corrupted_never_accepted(items: list, cuts: list[int]) -> None:
    # an undamaged last frame shows whether damage to the one before it ate its delimiter
    msgs = [msg for msg, _ in items] + [messages.Stop()]
    frames = [encode_frame(msg, seq=i) for i, msg in enumerate(msgs)]
    stream, survivors = corrupt_stream(frames, [d for _, d in items] + [Damage("none", 0, 0)])
    got, decoder = decode_in_chunks(stream, [c % (len(stream) + 1) for c in cuts])
    decoded = [(f.seq, f.message) for f in got]
    # Nothing fabricated: every accepted frame is an original one, in order. (Damage can cancel
    # out, e.g. a truncated frame's first byte standing in for the next frame's deleted one; the
    # resulting bytes are then the original frame's and accepting it is right.)
    assert all(same(msgs[seq], msg) for seq, msg in decoded)
    assert [seq for seq, _ in decoded] == sorted({seq for seq, _ in decoded})
    # Nothing lost: every untouched frame comes out.
    assert {i for i in survivors} <= {seq for seq, _ in decoded}
    # Every loss is counted: as a dropped frame, or as a sequence gap. Frames lost before the
    # first accepted one leave neither when damage cancels out so that no bytes remain of them
    # (a frame truncated to the one byte the next frame lost): the stream's start is unknowable.
    seqs = {seq for seq, _ in decoded}
    if any(i not in seqs for i in range(min(seqs, default=len(frames)), len(frames))):
        assert decoder.stats.dropped > 0 or decoder.stats.seq_gaps > 0
    elif len(decoded) < len(frames):
        assert decoder.stats.dropped > 0 or min(seqs) > 0


def test_long_stream_with_one_in_ten_frames_damaged() -> None:
    rng = random.Random(20261121)
    ops = ["flip", "insert", "delete", "truncate"]
    msgs = [
        messages.Sample(sample_seq=i, counts=((rng.randrange(65536),) * 5,) * 3)
        for i in range(5000)
    ]
    damages = [
        Damage(rng.choice(ops) if rng.random() < 0.1 else "none", rng.random(), rng.randrange(256))
        for _ in msgs
    ]
    frames = [encode_frame(msg, seq=i & 0xFFFF) for i, msg in enumerate(msgs)]
    stream, survivors = corrupt_stream(frames, damages)
    cuts = [rng.randrange(len(stream)) for _ in range(2000)]
    got, decoder = decode_in_chunks(stream, cuts)
    assert [f.message.sample_seq for f in got] == survivors
    assert len(survivors) > 4000
    assert decoder.stats.seq_gaps == len(frames) - len(survivors) - (
        len(frames) - 1 - survivors[-1]
    )
