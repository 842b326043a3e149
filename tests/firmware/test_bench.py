"""The firmware benchmark runs and reports its figures (no timing is asserted)."""

from __future__ import annotations


def test_firmware_bench_json(run_bench, native_build: object) -> None:
    figures = run_bench("firmware", "--no-image")
    encode = next(f for name, f in figures.items() if name.startswith("SAMPLE frame encode"))
    assert encode["value"] > 0 and encode["reference_value"] > 0
    latency = figures["integration end -> frame to UART"]
    assert latency["extra"]["passes"] == 1 and latency["value"] > 0
