"""The Unix-minus-monotonic offset every clock conversion uses (spectratac.host_clock): read
in the tightest of several brackets, so that a thread descheduled between two clock reads
does not move every converted time by as long as it waited."""

from __future__ import annotations

from pathlib import Path

import pytest
from spectratac import host_clock


def test_the_offset_is_read_in_the_tightest_bracket(monkeypatch: pytest.MonkeyPatch) -> None:
    # one `time.time() - time.monotonic()` with the thread descheduled between the two reads
    # put every live estimate's stamp 50 ms off at load 20, and a ROS 2 bag's receive times
    # 50 µs off on a CI worker beside two busy loops
    ms = 1_000_000
    mono = iter([0, 50 * ms, 1000 * ms, 1000 * ms + 100_000, 2000 * ms, 2020 * ms])
    unix = iter([10**12 + 49 * ms, 10**12 + 1000 * ms + 50_000, 10**12 + 2019 * ms])
    monkeypatch.setattr(host_clock.time, "monotonic_ns", lambda: next(mono))
    monkeypatch.setattr(host_clock.time, "time_ns", lambda: next(unix))
    assert host_clock.unix_minus_monotonic_ns(tries=3) == 10**12


def test_the_live_page_and_recordings_convert_with_it(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    from spectratac.apps.live import latency
    from spectratac.record.writer import RecordingWriter

    offset_ns = 7 * 10**9
    monkeypatch.setattr(
        host_clock.time, "time_ns", lambda: host_clock.time.monotonic_ns() + offset_ns
    )
    monkeypatch.setattr(latency, "_offset_s", None)
    assert latency.unix_ms(1.0) == pytest.approx(8000.0, abs=0.01)
    with RecordingWriter(tmp_path / "r.mcap", {}) as w:
        assert abs(w.clock.unix_minus_monotonic_ns - offset_ns) < 10_000
