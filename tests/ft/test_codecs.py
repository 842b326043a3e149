"""Wire codecs: RDT requests/records round-trip; Bota frames round-trip, the CRC is
CRC-16/X-25, and the parser keeps every undamaged frame around random damage."""

from __future__ import annotations

import crcmod.predefined
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp
from spectratac.ft import FTProtocolError, botaframe, rdt

u32 = st.integers(0, 2**32 - 1)
i32 = st.integers(-(2**31), 2**31 - 1)


@given(command=st.integers(0, 0xFFFF), count=u32)
def test_rdt_request_round_trip(command: int, count: int) -> None:
    wire = rdt.encode_request(command, count)
    assert len(wire) == 8 and wire[:2] == b"\x12\x34"
    assert rdt.decode_request(wire) == (command, count)


def test_rdt_request_rejects_wrong_header_and_size() -> None:
    with pytest.raises(FTProtocolError, match="header"):
        rdt.decode_request(b"\x43\x21" + bytes(6))
    with pytest.raises(FTProtocolError, match="expected 8"):
        rdt.decode_request(bytes(7))


@given(rows=st.lists(st.tuples(u32, u32, u32, st.lists(i32, min_size=6, max_size=6)), max_size=50))
def test_rdt_records_round_trip_big_endian(rows: list) -> None:
    if not rows:
        return
    seq, ft_seq, status, counts = (list(c) for c in zip(*rows, strict=True))
    wire = rdt.encode_records(seq, ft_seq, status, counts)
    assert len(wire) == 36 * len(rows)
    assert int.from_bytes(wire[:4], "big") == seq[0]  # network byte order
    back = rdt.decode_records(wire)
    assert back["rdt_sequence"].tolist() == seq
    assert back["ft_sequence"].tolist() == ft_seq
    assert back["status"].tolist() == status
    assert back["counts"].tolist() == counts
    with pytest.raises(FTProtocolError):
        rdt.decode_records(wire[:-1])


def test_crc_is_x25_with_its_check_value() -> None:
    assert botaframe.crc16_x25(b"123456789") == 0x906E
    ref = crcmod.predefined.mkPredefinedCrcFun("x-25")
    rows = np.random.default_rng(0).integers(0, 256, (200, 34), dtype=np.uint8)
    fast = botaframe.crc16_x25_rows(rows)
    assert fast.tolist() == [ref(r.tobytes()) for r in rows]


def frames_strategy(max_frames: int = 30) -> st.SearchStrategy:
    n = st.integers(1, max_frames)
    return n.flatmap(
        lambda k: st.tuples(
            hnp.arrays(np.uint16, k),
            hnp.arrays(np.float32, (k, 6), elements=st.floats(-1e4, 1e4, width=32)),
            hnp.arrays(np.uint32, k),
        )
    )


@settings(deadline=None)  # a busy machine stretches one example past hypothesis' 200 ms
@given(frames=frames_strategy())
def test_bota_frames_round_trip(frames: tuple) -> None:
    status, forces, ts = frames
    wire = botaframe.encode_frames(status, forces, ts, np.full(len(ts), 25.0))
    assert len(wire) == 37 * len(ts) and wire[0] == 0xAA
    p = botaframe.FrameParser()
    out = p.feed(wire)
    assert out["status"].tolist() == status.tolist()
    np.testing.assert_array_equal(out["forces"], forces)
    assert out["timestamp"].tolist() == ts.tolist()
    assert p.crc_errors == 0 and p.skipped_bytes == 0


damage_kind = st.sampled_from(["flip", "burst", "insert", "delete", "garbage_between"])


@settings(max_examples=150, deadline=None)
@given(
    n=st.integers(2, 60),
    damage=st.lists(
        st.tuples(st.integers(0, 59), damage_kind, st.binary(min_size=1, max_size=40)), max_size=8
    ),
    chunks=st.lists(st.integers(1, 200), min_size=1, max_size=20),
    seed=st.integers(0, 2**32 - 1),
)
def test_parser_keeps_every_undamaged_frame(n: int, damage: list, chunks: list, seed: int) -> None:
    """Damage some frames (bit flips, bursts, inserted/deleted bytes, garbage between
    frames), feed in random chunk sizes: every untouched frame comes out, in order, and
    no damaged frame does."""
    rng = np.random.default_rng(seed)
    ts = np.arange(n, dtype=np.uint32) * 1000 + 7
    forces = rng.normal(size=(n, 6)).astype(np.float32)
    clean = [
        botaframe.encode_frames([0], forces[i : i + 1], ts[i : i + 1], [25.0]) for i in range(n)
    ]
    frames = [bytearray(f) for f in clean]
    prefix: dict[int, bytes] = {}
    for index, kind, blob in damage:
        i = index % n
        f = frames[i]
        at = int(rng.integers(len(f)))
        if kind == "garbage_between":
            prefix[i] = prefix.get(i, b"") + blob  # frame i itself stays intact
        elif kind == "flip":
            f[at] ^= 1 << int(rng.integers(8))
        elif kind == "burst":  # overwrite up to len(blob) bytes in place
            f[at : at + len(blob)] = blob[: len(f) - at]
        elif kind == "insert":
            f[at:at] = blob
        else:
            del f[at : at + 1 + len(blob) % 5]
    # a frame is intact if its original bytes still appear whole (e.g. bytes inserted
    # before its header, or a burst that wrote the same bytes)
    intact = [clean[i] in bytes(frames[i]) for i in range(n)]
    wire = b"".join(prefix.get(i, b"") + bytes(frames[i]) for i in range(n))
    parser = botaframe.FrameParser()
    got: list[int] = []
    pos = 0
    for size in chunks * (len(wire) // max(1, sum(chunks)) + 1):
        if pos >= len(wire):
            break
        got += parser.feed(wire[pos : pos + size])["timestamp"].tolist()
        pos += size
    got += parser.feed(b"")["timestamp"].tolist()
    expected = [int(ts[i]) for i in range(n) if intact[i]]
    # every intact frame is recovered, in order; the only extras allowed are none
    assert [t for t in got if t in expected] == expected
    assert set(got) <= {int(t) for t in ts}
    # damaged frames never come out (a 1-in-65536 CRC collision aside, not at these sizes)
    assert not (set(got) - set(expected))


def _crc_rows_for(data: bytes, monkeypatch: pytest.MonkeyPatch) -> int:
    """CRC rows the parser computes to parse `data` fed in one chunk (its unit of work)."""
    rows = 0
    real = botaframe.crc16_x25_rows

    def counting(block: np.ndarray) -> np.ndarray:
        nonlocal rows
        rows += block.shape[0]
        return real(block)

    monkeypatch.setattr(botaframe, "crc16_x25_rows", counting)
    botaframe.FrameParser().feed(data)
    monkeypatch.setattr(botaframe, "crc16_x25_rows", real)
    return rows


def test_parser_work_is_linear_in_garbage(monkeypatch: pytest.MonkeyPatch) -> None:
    """Garbage dense with false headers: each candidate header costs a bounded check, not a
    check of every frame slot to the end of the buffer (which made a 1 MB chunk take seconds)."""
    rng = np.random.default_rng(3)

    def garbage(size: int) -> bytes:
        noise = rng.integers(0, 256, size, dtype=np.uint8)
        noise[rng.random(size) < 0.05] = botaframe.HEADER
        return noise.tobytes()

    small, large = garbage(20_000), garbage(80_000)
    work_small, work_large = _crc_rows_for(small, monkeypatch), _crc_rows_for(large, monkeypatch)
    headers = large.count(botaframe.HEADER)
    assert work_large <= headers + 2 * len(large) // botaframe.FRAME_SIZE
    assert work_large <= 5 * work_small


def test_parser_work_is_linear_in_good_frames(monkeypatch: pytest.MonkeyPatch) -> None:
    n = 4000
    wire = botaframe.encode_frames(np.zeros(n), np.ones((n, 6)), np.arange(n), np.full(n, 25.0))
    damaged = bytearray(wire)
    for i in range(0, n, 97):  # one damaged frame in a hundred
        damaged[i * botaframe.FRAME_SIZE + 5] ^= 0xFF
    assert _crc_rows_for(wire, monkeypatch) <= 2 * n
    assert _crc_rows_for(bytes(damaged), monkeypatch) <= 4 * n


def test_parser_drops_non_finite_and_out_of_range_values() -> None:
    forces = np.zeros((5, 6), dtype=np.float32)
    forces[1, 0] = 1e35
    forces[2, 3] = np.inf
    forces[3, 5] = 30.0  # 30 N*m against a 20 N*m limit
    temperature = [25.0, 25.0, 25.0, 25.0, np.nan]
    wire = botaframe.encode_frames(np.zeros(5), forces, np.arange(5), temperature)
    bounded = botaframe.FrameParser(limits=[1000, 1000, 1000, 20, 20, 20])
    assert bounded.feed(wire)["timestamp"].tolist() == [0]
    assert bounded.implausible == 4 and bounded.crc_errors == 0 and bounded.frames == 1
    unbounded = botaframe.FrameParser()  # finite values pass whatever their size
    assert unbounded.feed(wire)["timestamp"].tolist() == [0, 1, 3]
    assert unbounded.implausible == 2
    with pytest.raises(ValueError, match="six positive"):
        botaframe.FrameParser(limits=[1, 2, 3])


def test_joining_record_batches_keeps_every_row_in_order() -> None:
    # the F/T queue's join copies batches into one array instead of np.concatenate, which
    # promoted the structured dtype field by field per batch (the live page's F/T read)
    from spectratac.ft.base import _join
    from spectratac.ft.records import FT_RECORD

    @settings(max_examples=60, deadline=None)
    @given(st.lists(st.integers(0, 40), max_size=12), st.integers(0, 2**32 - 1))
    def check(sizes: list[int], seed: int) -> None:
        rng = np.random.default_rng(seed)
        batches = []
        for n in sizes:
            b = np.zeros(n, dtype=FT_RECORD)
            for name in FT_RECORD.names:
                b[name] = rng.normal(size=b[name].shape)
            batches.append(b[1:] if n and rng.random() < 0.3 else b)  # slices too
        joined = _join(batches)
        assert joined.dtype == FT_RECORD
        want = np.concatenate(batches) if batches else np.empty(0, dtype=FT_RECORD)
        assert joined.tobytes() == want.tobytes()
        if batches and len(joined):
            joined["wrench"][0] += 1.0  # a new array: the queue's batches stay as they were
            assert joined.tobytes() != want.tobytes()

    check()
