"""The recording benchmark runs end to end on a small scale (no timing is asserted)."""

from __future__ import annotations


def test_recording_bench_json(run_bench) -> None:
    figures = run_bench("recording",
        "--samples",
        "2000",
        "--ft-rate",
        "100",
        "--rounds",
        "1",
        "--live-samples",
        "100",
    )
    assert set(figures) == {
        "recorder write",
        "format 4 write",
        "dataset build",
        "format 4 build",
        "live record, speed=max",
    }
    fmt4 = figures["format 4 write"]  # the decoded copies cost space beside the compact file
    assert fmt4["extra"]["size_ratio"] > 1 and fmt4["ratio"] > 0
    build = figures["dataset build"]
    assert build["extra"]["samples"] == 2000 and build["extra"]["ft_samples"] >= 100 * 99
    assert build["value"] > 0 and build["reference_value"] > 0 and build["ratio"] > 0
    assert figures["live record, speed=max"]["extra"]["lost"] == 0
