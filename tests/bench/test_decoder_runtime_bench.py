"""The decoder runtime benchmark runs end to end on a small scale (no timing is asserted)."""

from __future__ import annotations

import pytest

pytestmark = pytest.mark.train


def test_decoder_runtime_bench_json(run_bench) -> None:
    figures = run_bench("decoder_runtime", "--calls", "200", "--samples", "1000", "--epochs", "1"
    )
    p99 = figures["paper decoder single sample p99 (NumPy)"]
    assert p99["extra"]["torch_imported"] is False and p99["extra"]["params"] == 106_383
    assert p99["value"] > 0 and p99["reference_value"] > 0
    live = figures["paper decoder live sample p99 (assembly + network)"]
    assert live["extra"]["torch_imported"] is False and live["value"] > 0
    train = figures["paper recipe training, 1000 samples x 1 epochs"]
    assert train["extra"]["samples"] == 1000 and train["ratio"] > 0
