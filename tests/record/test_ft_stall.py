"""A reference F/T sensor that goes silent mid-stream: the recorder keeps the optical stream
(no sample lost), says it once naming the sensor and the option, counts it in the summary
and the file's stats, and ends without waiting for a stop the sensor will never confirm.
The fault: the real simulated Bota link, its driver's reads emptied after some rows (the
sensor still sends; the host hears nothing, as with a cut cable)."""

from __future__ import annotations

import threading
from pathlib import Path

import numpy as np
import pytest
from spectratac.device import Sensor
from spectratac.ft import FTSensor
from spectratac.ft.errors import FTStalledError
from spectratac.ft.stall import default_ft_stall_timeout
from spectratac.record import Recorder, RecordOptions, read_recording

URL = "sim://?scene=tour&seed=3&speed=1&ft=bota"
HANG_GUARD_S = 60  # generous: a wait that never ends fails, a slow one does not


def _silent_after(ft: FTSensor, rows: int) -> None:
    """From `rows` records on, the driver hears nothing (fault injection on its reads)."""
    real = ft._poll

    def poll(timeout: float) -> np.ndarray | None:
        batch = real(timeout)
        if batch is not None and ft.stats.received >= rows:
            return batch[:0]
        return batch

    ft._poll = poll  # type: ignore[method-assign]


def test_a_silent_ft_is_said_once_counted_and_the_optical_stream_goes_on(
    tmp_path: Path,
) -> None:
    path = tmp_path / "silent_ft.mcap"
    said: list[str] = []
    with Sensor.open(URL) as sensor, FTSensor.open(URL) as ft:
        ft.stall_timeout = 0.3
        _silent_after(ft, 100)
        options = RecordOptions(duration_s=2.0)
        summary = Recorder(sensor, path, options, ft=ft, warn=said.append).run()
    assert summary.stopped_by == "duration" and summary.error is None
    assert summary.ft_stalls == 1 and summary.as_dict()["ft_stalls"] == 1  # --json has it
    assert len(said) == 1, said  # said once
    assert ft.url in said[0] and "--stall-timeout" in said[0]
    rec = read_recording(path)
    # the optical stream: every sample of the duration, none lost
    assert summary.lost == 0 and len(rec.frame_host_times) >= summary.samples >= 30
    assert rec.ft is not None and 100 <= len(rec.ft) == summary.ft_samples
    assert rec.stats is not None and rec.stats["ft"]["stalls"] == 1


def test_iterating_a_silent_ft_ends_with_the_stall_error() -> None:
    ended: list[BaseException] = []
    seen = [0]

    def iterate(ft: FTSensor) -> None:
        try:
            for _ in ft:  # the old loop waited for ever on a silent live sensor
                seen[0] += 1
        except FTStalledError as exc:
            ended.append(exc)

    with FTSensor.open(URL) as ft:
        ft.stall_timeout = 0.3
        _silent_after(ft, 50)
        worker = threading.Thread(target=iterate, args=(ft,), daemon=True)
        worker.start()
        worker.join(HANG_GUARD_S)
        assert not worker.is_alive(), "iterating a silent F/T sensor never ended"
    assert len(ended) == 1 and "--stall-timeout" in str(ended[0])
    assert seen[0] >= 50 and ft.stats.stalls == 1


def test_the_default_stall_timeout_comes_from_the_rate() -> None:
    with FTSensor.open(URL) as ft:
        assert ft.stall_timeout is None
        assert ft.effective_stall_timeout == default_ft_stall_timeout(ft.info.rate_hz) >= 5.0
        ft.stall_timeout = float("inf")  # --stall-timeout off
        assert ft.effective_stall_timeout == float("inf")


def test_live_says_a_silent_ft_once_and_counts_it(capsys: pytest.CaptureFixture[str]) -> None:
    import time

    from spectratac.apps.live.session import LiveSession

    session = LiveSession(None, "sim://?scene=presses&seed=3&speed=1&ft=bota", timeout=10)
    session.start(lambda message: None)
    try:
        assert session.ft is not None
        session.ft.stall_timeout = 0.3
        _silent_after(session.ft, session.ft.stats.received + 50)
        deadline = time.monotonic() + HANG_GUARD_S
        while session.stats()["ft"]["stalls"] < 1 or "stall timeout" not in (
            err := capsys.readouterr().err
        ):
            assert time.monotonic() < deadline, "the silent F/T was never said"
            time.sleep(0.2)
        time.sleep(1.0)  # quiet on: not said again
        assert err.count("spectratac: warning:") == 1 and session.ft.url in err
        assert "--stall-timeout" in err and "spectratac: warning:" not in capsys.readouterr().err
        assert session.error is None  # decoding goes on
    finally:
        session.stop()
