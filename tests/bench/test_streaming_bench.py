"""The streaming benchmark runs end to end on a small scale (no timing is asserted)."""

from __future__ import annotations


def test_streaming_bench_json(run_bench) -> None:
    figures = run_bench("streaming",
        "--frames",
        "50",
        "--samples",
        "200",
        "--devices",
        "2",
        "--seconds",
        "1",
        "--rounds",
        "1",
    )
    assert figures["frame-to-user latency p99"]["extra"]["frames"] == 50
    assert figures["samples/s at speed=max"]["extra"]["lost"] == 0
    cpu = figures["CPU, 2 devices at 20 Hz"]
    assert cpu["extra"]["samples"] >= 0.8 * cpu["extra"]["expected"]
    assert cpu["reference_name"] == "raw reads, one selector thread"
    assert cpu["extra"]["raw_bytes"] > 0  # the reference really read the devices' streams
