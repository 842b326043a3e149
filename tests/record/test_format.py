"""The recording file itself: round trips, truncation at any point, bad files named."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from spectratac.ft import FT_RECORD
from spectratac.record import (
    RecordingError,
    RecordingWriter,
    TruncatedRecordingWarning,
    read_recording,
)
from spectratac.record.format import LABELS, dtype_from_json, dtype_to_json

frames_st = st.lists(
    st.tuples(st.binary(min_size=5, max_size=80), st.floats(0, 1e6, allow_nan=False)),
    max_size=60,
)


def ft_rows(n: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    rows = np.zeros(n, dtype=FT_RECORD)
    rows["sensor_time"] = np.arange(n) * 1e-3
    rows["host_time"] = 100.0 + np.arange(n) * 1e-3
    rows["sequence"] = np.arange(n)
    rows["wrench"] = rng.normal(size=(n, 6))
    return rows


@settings(
    max_examples=30,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
@given(frames=frames_st, n_ft=st.integers(0, 50), offset=st.integers(0, 2 * 10**18))
def test_round_trip(
    tmp_path: Path, frames: list[tuple[bytes, float]], n_ft: int, offset: int
) -> None:
    path = tmp_path / "r.mcap"
    rows = ft_rows(n_ft)
    with RecordingWriter(
        path, {"url": "x"}, ft_dtype=FT_RECORD, unix_minus_monotonic_ns=offset
    ) as w:
        w.frames(frames)
        w.ft(rows)
        w.json(LABELS, {"region": 3, "t_start": 1.0}, 2.0)
    rec = read_recording(path)
    assert not rec.truncated and rec.session["url"] == "x"
    assert rec.frames == [raw for raw, _ in frames]
    # host times come back to the nanosecond, whatever the wall-clock shift
    np.testing.assert_allclose(rec.frame_host_times, [t for _, t in frames], atol=1.5e-9, rtol=0)
    assert rec.ft is not None and rec.ft.tobytes() == rows.tobytes()
    assert rec.labels == [{"region": 3, "t_start": 1.0}]


def test_dtype_json_round_trip() -> None:
    assert dtype_from_json(dtype_to_json(FT_RECORD)) == FT_RECORD


def _chunked_file(path: Path, chunks: int = 6, per_chunk: int = 40) -> list[int]:
    """A finished recording whose frames sit in `chunks` flushed chunks; returns the byte
    offset reached after each flush."""
    marks = []
    with RecordingWriter(path, {}, ft_dtype=FT_RECORD, unix_minus_monotonic_ns=0) as w:
        for c in range(chunks):
            w.frames(
                [(bytes([1, 0, 0x84, i & 0xFF, c]) * 4, c + i / 100) for i in range(per_chunk)]
            )
            w.ft(ft_rows(10, c))
            w.flush()
            marks.append(w.bytes_written)
    return marks


@settings(
    max_examples=40,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
@given(cut=st.floats(0.0, 1.0), garbage=st.sampled_from([b"", bytes(4096), b"\xff\x13junk"]))
def test_any_truncation_gives_the_flushed_prefix(
    tmp_path: Path, cut: float, garbage: bytes
) -> None:
    full = tmp_path / "full.mcap"
    marks = _chunked_file(full)
    whole = read_recording(full)
    data = full.read_bytes()
    end = int(marks[0] + cut * (len(data) - marks[0]))  # the session chunk always survives
    cut_path = tmp_path / "cut.mcap"
    cut_path.write_bytes(data[:end] + garbage)  # e.g. a file system's zero-filled tail
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        rec = read_recording(cut_path)
    complete = sum(1 for m in marks if m <= end)  # chunks wholly on disk
    assert len(rec.frames) >= 40 * complete
    assert rec.frames == whole.frames[: len(rec.frames)]  # a prefix, nothing invented
    assert rec.ft is not None and len(rec.ft) >= 10 * complete
    if end < len(data):
        assert rec.truncated and rec.end is None
        warned = [w for w in caught if issubclass(w.category, TruncatedRecordingWarning)]
        assert len(warned) == 1 and "readable prefix" in str(warned[0].message)
    else:  # a whole file, even with junk after its closing magic, reads completely
        assert rec.frames == whole.frames


def test_bad_files_are_named(tmp_path: Path) -> None:
    junk = tmp_path / "junk.mcap"
    junk.write_bytes(b"this is not an mcap file at all")
    with pytest.raises(RecordingError, match="not a readable SpectraTac recording"):
        read_recording(junk)
    with pytest.raises(RecordingError, match="cannot open"):
        read_recording(tmp_path / "missing.mcap")
    with pytest.raises(RecordingError, match="cannot create"):
        RecordingWriter(tmp_path / "no" / "such" / "dir.mcap", {})
    newer = tmp_path / "newer.mcap"
    with RecordingWriter(newer, {"version": 99}):
        pass
    with pytest.raises(RecordingError, match="update spectratac"):
        read_recording(newer)
    other = tmp_path / "other.mcap"
    with RecordingWriter(other, {"format": "someone.else"}):
        pass
    with pytest.raises(RecordingError, match="not a SpectraTac recording"):
        read_recording(other)


def test_ft_rows_of_another_layout_are_refused(tmp_path: Path) -> None:
    with (
        RecordingWriter(tmp_path / "a.mcap", {}) as w,
        pytest.raises(RecordingError, match="FT_RECORD"),
    ):
        w.ft(ft_rows(3))
