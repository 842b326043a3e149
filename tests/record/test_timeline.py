"""Recordings on the sensor's clock (`spectratac.record.timeline`): a session recorded at
`sim://?speed=15` spans as many seconds of log_time as the sensor measured, on every channel
that carries device-timed rows, while publish_time keeps the host's arrival (what the reader
and the dataset builder use). Before, log_time was the arrival: 15x compressed."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from mcap.reader import make_reader
from spectratac.record import RecordOptions, record_url
from spectratac.record.reader import read_recording
from spectratac.record.timeline import LiveClock, Timeline


@pytest.fixture(scope="module")
def fast(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("fast") / "s.mcap"
    record_url("sim://?scene=tour&seed=1&speed=15&ft=bota", path, RecordOptions(duration_s=9))
    return path


def times(path: Path) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """topic -> (log_time, publish_time) ns, in file order."""
    out: dict[str, tuple[list[int], list[int]]] = {}
    with open(path, "rb") as f:
        for _, channel, msg in make_reader(f).iter_messages(log_time_order=False):
            lt, pt = out.setdefault(channel.topic, ([], []))
            lt.append(msg.log_time)
            pt.append(msg.publish_time)
    return {k: (np.array(a), np.array(b)) for k, (a, b) in out.items()}


def test_a_fast_session_spans_its_sensor_seconds(fast: Path) -> None:
    rec = read_recording(fast)
    assert rec.ft is not None
    t = times(fast)
    sensor_s = 9.0
    ft_s = float(np.ptp(rec.ft["sensor_time"]))  # the F/T runs a little longer
    spans = {"/spectratac/counts": sensor_s, "/ft/wrench": ft_s, "/ft/samples": ft_s}
    for topic, want in spans.items():
        log, pub = t[topic]
        log_span, host_span = np.ptp(log) / 1e9, np.ptp(pub) / 1e9
        # /ft/samples: one message per batch, at its last row
        assert log_span == pytest.approx(want, abs=2.0 if topic == "/ft/samples" else 1.0)
        assert host_span < log_span / 5, topic  # 15x the host's span
    # the F/T and the optical sensor on one timeline: a moment of the scene (the simulated
    # F/T declares its clock against the device's) has one log_time on both, within the live
    # fits' error (a few ms of host latency, times 15)
    declared = rec.truth["ft_clock"]
    lag = {}
    for topic, key in (("/spectratac/counts", "t_end_us"), ("/ft/wrench", "sensor_time")):
        with open(fast, "rb") as f:
            found = [(m.log_time, json.loads(m.data)[key])
                     for _, _, m in make_reader(f).iter_messages(topics=[topic])]  # fmt: skip
        log, own = np.array(found, dtype=np.float64).T
        scene = (
            own / 1e6
            if key == "t_end_us"
            else (own - declared["offset_s"]) / (1 + declared["drift"])
        )
        lag[topic] = float(np.median(log / 1e9 - scene))
    assert abs(lag["/spectratac/counts"] - lag["/ft/wrench"]) < 0.25, lag
    # each SAMPLE frame where its decoded row is (other frames: at their arrival, scaled)
    frames_log = set(t["/spectratac/frames"][0].tolist())
    assert set(t["/spectratac/counts"][0].tolist()) <= frames_log
    # the host's arrival is kept: the reader's frame times are publish_time
    frames_pub = t["/spectratac/frames"][1]
    np.testing.assert_array_equal(rec.frame_host_times, rec.clock.monotonic_array(frames_pub))
    timeline = Timeline.from_dict(rec.session["timeline"])
    assert timeline.scale == 15.0


@settings(max_examples=12, deadline=None)
@given(
    scale=st.sampled_from([1.0, 15.0]),
    drift=st.floats(-1e-3, 1e-3),
    seed=st.integers(0, 2**16),
)
def test_the_live_clock_follows_a_drifting_device(scale: float, drift: float, seed: int) -> None:
    """Arrivals = true host time + a heavy-tailed latency >= 0.5 ms, in 20-ms batches; after
    a few seconds the mapped time sits within a few ms of the truth, and never before it by
    more than the fit's error (a latency is never negative)."""
    rng = np.random.default_rng(seed)
    clock = LiveClock(scale)
    host = np.arange(0, 60, 0.002)
    device = (host * (1 + drift) + 7.0) * scale  # the device's seconds (scene time)
    arrival = host + 0.5e-3 + rng.lognormal(np.log(1e-3), 1.0, host.size)
    errors = []
    for k in range(0, host.size, 20):
        mapped = clock.to_host(device[k : k + 20], arrival[k : k + 20])
        # the map is host = offset + device / scale: compare against the true host time
        # through the best constant (the device's own offset is unknowable without a sync)
        errors.append(mapped - host[k : k + 20])
    err = np.concatenate(errors)
    late = err[len(err) // 4 :] - np.median(err[len(err) // 4 :])
    assert np.abs(late).max() < 5e-3


def test_a_timeline_inverts(tmp_path: Path) -> None:
    tl = Timeline(1_700_000_000 * 10**9, 100.0, 15.0)
    h = np.array([99.0, 100.0, 100.5, 130.25])
    np.testing.assert_allclose(tl.host(tl.ns_array(h)), h, atol=1e-9)
    assert tl.ns(101.0) - tl.ns(100.0) == 15 * 10**9


@settings(max_examples=15, deadline=None)
@given(back_s=st.floats(0.001, 5.0), rows=st.integers(1, 40), jitter_s=st.floats(0.0, 0.01))
def test_log_time_never_steps_back_within_a_channel_when_a_refit_moves_the_fit_back(
    back_s: float, rows: int, jitter_s: float, tmp_path_factory: pytest.TempPathFactory
) -> None:
    """Every live clock refit is forced to move the fit `back_s` earlier (the provisional fit
    may; the page's axis only advances): the written file's log_time, read by the mcap
    reader in file order, never decreases on any channel, and Lichtblick opens every channel."""
    from types import SimpleNamespace

    from spectratac.ft import FT_RECORD
    from spectratac.record import timeline
    from spectratac.record.writer import RecordingWriter

    from tests.lichtblick_rules import check_mcap

    def back(xs: np.ndarray, hs: np.ndarray) -> SimpleNamespace:
        return SimpleNamespace(sensor_ref=float(xs[-1]), host_ref=float(hs[-1]) - back_s,
                               drift=0.0)  # fmt: skip

    path = tmp_path_factory.mktemp("refit") / "r.mcap"
    real_fit = timeline.fit_clock
    timeline.fit_clock = back  # type: ignore[assignment]
    try:
        session = {"link": {"clock_scale": 1.0}}
        with RecordingWriter(path, session, ft_dtype=FT_RECORD, unix_minus_monotonic_ns=0) as w:
            rng = np.random.default_rng(rows)
            t = 100.0
            for _ in range(3 * 64):  # three refits
                batch = np.zeros(rows, FT_RECORD)
                batch["sensor_time"] = t + np.arange(rows) * 1e-3
                batch["host_time"] = batch["sensor_time"] + 0.002 + rng.uniform(0, jitter_s, rows)
                batch["sequence"] = np.arange(rows)
                w.ft(batch)
                t += rows * 1e-3
    finally:
        timeline.fit_clock = real_fit
    per_channel = times(path)
    assert {"/ft/samples", "/ft/wrench"} <= set(per_channel)
    for topic, (log, _) in per_channel.items():
        assert (np.diff(log) >= 0).all(), f"{topic}: log_time steps back"
    assert check_mcap(path)["/ft/wrench"] > 0


def test_a_frame_arriving_inside_a_samples_lag_does_not_part_it_from_its_row(
    tmp_path: Path,
) -> None:
    """A LOG that arrives after the next sample's window has ended, but before that sample
    does, is written at its arrival: later than the sample's window end. FRAMES only advances,
    so it moves that SAMPLE frame forward; the decoded COUNTS row must move with it (CI at
    load 10: one row 8 ms from its frame, which Foxglove shows as two moments)."""
    from spectratac.protocol.framing import crc32c
    from spectratac.protocol.generated import messages as m
    from spectratac.record.writer import RecordingWriter

    def frame(type_id: int, payload: bytes) -> bytes:
        body = bytes([m.PROTOCOL_MAJOR, m.PROTOCOL_MINOR, type_id, 0, 0]) + payload
        return body + crc32c(body).to_bytes(4, "little")

    path = tmp_path / "lag.mcap"
    frames: list[tuple[bytes, float]] = []
    for k in range(40):  # a window every 50 ms, arriving 1 or 5 ms after it ends
        end_s = 0.05 * (k + 1)
        sample = m.Sample(sample_seq=k, t_start_us=round(end_s * 1e6) - 50_000,
                          t_end_us=round(end_s * 1e6)).pack()  # fmt: skip
        lag = 0.001 if k % 5 == 2 else 0.005  # the fastest arrivals set the clock fit
        frames.append((frame(m.Sample.TYPE_ID, sample), 100.0 + end_s + lag))
        if k % 5 == 4:  # a LOG 2 ms after the next window ends, 3 ms before it arrives
            log = m.Log(text="hello").pack()
            frames.append((frame(m.Log.TYPE_ID, log), 100.0 + end_s + 0.052))
    with RecordingWriter(path, {"link": {"clock_scale": 1.0}}, unix_minus_monotonic_ns=0) as w:
        for i in range(0, len(frames), 7):
            w.frames(frames[i : i + 7])
    t = times(path)
    counts = t["/spectratac/counts"][0]
    assert len(counts) == 40
    assert set(counts.tolist()) <= set(t["/spectratac/frames"][0].tolist())
    for log, _ in t.values():
        assert (np.diff(log) >= 0).all()
