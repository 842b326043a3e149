"""A failed soak says which device or recording failed and how, on stderr and with exit 1
(the CI log once showed only "exited 1"). Fast: the tallies are made up, the report is real."""

from __future__ import annotations

import sys

import pytest

from tools.bench import reliability as rel


def failing_soak() -> rel.Soak:
    url = "sim://?seed=1003"
    soak = rel.Soak(seconds=1.0)
    soak.devices = [
        rel.DeviceTally("sim://?seed=1000", sent=100, delivered=100),
        rel.DeviceTally(
            url, sent=100, delivered=90, sample_gaps=7, lost_at_unplug=1, unplugs=2, reconnects=2
        ),
        rel.DeviceTally("sim://?seed=1004", sent=50, delivered=50, stuck=True),
        rel.DeviceTally(
            "sim://?seed=1005", sent=60, delivered=60, error="RuntimeError: would not stop"
        ),
    ]
    soak.recording = rel.RecordingTally(
        frames=10,
        read_frames=9,
        samples=8,
        read_samples=8,
        ft_samples=5,
        read_ft_samples=5,
        dataset_samples=3,
    )
    return soak


def test_every_failure_is_named_with_how(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setattr(rel, "run", lambda devices, seconds, seed: failing_soak())
    monkeypatch.setattr(sys, "argv", ["reliability", "--json"])
    assert rel.main() == 1
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 4  # the three failed devices and the recording; the healthy one not
    assert err[0] == (
        "soak FAILED: device sim://?seed=1003: 2 samples unaccounted (sent 100 = delivered 90 "
        "+ gaps 7 + overflows 0 + lost at unplug 1 + 2; 2 unplugs, 2 reconnects)"
    )
    assert err[1] == (
        "soak FAILED: device sim://?seed=1004: stuck: no new sample for 15 s of wall time"
    )
    assert err[2].endswith("seed=1005: ending its stream raised RuntimeError: would not stop")
    assert err[3] == "soak FAILED: recording: incomplete: frames 9 read back of 10 written"


def test_a_recording_that_raised_is_reported(monkeypatch: pytest.MonkeyPatch) -> None:
    def broken(seconds: float, seed: int, out: object) -> rel.RecordingTally:
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(rel, "soak_devices", lambda n, seconds, seed: [])
    monkeypatch.setattr(rel, "soak_recording", broken)
    lines = rel.problems(rel.run(0, 1.0, 1).summary())
    assert lines == ["recording: incomplete: raised OSError: [Errno 28] No space left on device"]


def test_a_passing_soak_reports_nothing() -> None:
    soak = failing_soak()
    soak.devices = soak.devices[:1]
    soak.recording = rel.RecordingTally(frames=1, read_frames=1, complete=True)
    assert rel.problems(soak.summary()) == []
