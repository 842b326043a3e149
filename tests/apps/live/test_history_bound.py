"""The live page's history keeps F/T rows whole up to FT_KEEP_HZ rows per second of host
time and an even, counted subset of a faster stream: its memory is bounded whatever the F/T's
rate (every row of a 10-kHz simulated F/T at speed=10 was kept for 120 s, hundreds of MB),
while a 1-kHz reference, what a recording's /ft/wrench copies whole, stays whole."""

from __future__ import annotations

import time

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from spectratac.apps.live.history import FT_KEEP_HZ, History
from spectratac.ft import FT_RECORD


def _feed(history: History, rate_hz: float, seconds: float, batch_s: float = 0.02) -> int:
    """F/T rows at `rate_hz` of host time for the last `seconds`, in batches; rows sent."""
    end = time.monotonic()
    t = np.arange(int(rate_hz * seconds)) / rate_hz + (end - seconds)
    per = max(1, int(rate_hz * batch_s))
    for at in range(0, len(t), per):
        rows = np.zeros(len(t[at : at + per]), FT_RECORD)
        rows["host_time"] = rows["sensor_time"] = t[at : at + per]
        rows["sequence"] = np.arange(at, at + len(rows))
        history.add_ft(rows)
    return len(t)


@settings(max_examples=10, deadline=None)
@given(rate_hz=st.floats(2 * FT_KEEP_HZ, 100_000.0), seconds=st.floats(2.0, 20.0))
def test_a_fast_ft_stream_is_kept_at_the_cap_and_the_rest_counted(
    rate_hz: float, seconds: float
) -> None:
    history = History(120.0)
    sent = _feed(history, rate_hz, seconds)
    _, ft, _ = history.window(min(seconds + 1, 120.0))
    assert ft is not None
    kept = len(ft)
    assert kept <= FT_KEEP_HZ * (seconds + 1) + 1000  # the cap, plus one second's burst
    assert kept + history.ft_thinned == sent  # every row kept or counted
    assert kept >= 0.5 * FT_KEEP_HZ * seconds  # an even subset over the whole span
    assert (np.diff(ft["sequence"].astype(np.int64)) > 0).all()


def test_a_1khz_reference_is_kept_whole() -> None:
    history = History(120.0)
    sent = _feed(history, FT_KEEP_HZ, 10.0)
    _, ft, _ = history.window(11.0)
    assert ft is not None and len(ft) == sent and history.ft_thinned == 0


def test_the_reference_tracker_keeps_an_even_subset_of_a_fast_stream() -> None:
    """The page's reference (a window's mean wrench) from an even 1-kHz subset of an 80-kHz
    stream: the same mean, a bounded buffer, the rows left out counted."""
    from spectratac.apps.live.alignment import FT_WINDOW_S, TRACK_HZ, LiveClock, ReferenceTracker

    tracker = ReferenceTracker(LiveClock(1.0, window_s=FT_WINDOW_S, background=False))
    rate, seconds, sent = 80_000.0, 12.0, 0
    t0 = 1000.0
    for b in range(int(seconds / 0.02)):
        t = t0 + b * 0.02 + np.arange(int(rate * 0.02)) / rate
        rows = np.zeros(len(t), FT_RECORD)
        rows["sensor_time"], rows["host_time"] = t, t + 0.001
        rows["wrench"][:, 2] = -5.0 + np.sin(t)  # a slow press
        tracker.add_ft(rows)
        sent += len(rows)
    kept = tracker._rows.t.size
    assert kept <= TRACK_HZ * (FT_WINDOW_S + 1) + 2 * seconds / 0.02
    assert tracker.thinned >= sent - TRACK_HZ * seconds - 2 * seconds / 0.02
    start, end = t0 + 11.0, t0 + 11.05
    tracker.add_estimate(1, start + 0.001, end + 0.001, np.zeros(6))
    tracker.add_ft(rows[:0])
    ready = tracker.ready()
    truth = -5.0 + np.sin((start + end) / 2)
    assert len(ready) == 1 and abs(ready[0][2][2] - truth) < 1e-3
