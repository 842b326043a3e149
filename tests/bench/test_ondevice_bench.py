"""The on-device decoding benchmark runs end to end on a few samples (no timing is asserted):
it trains the paper's and best() models briefly, runs them in QEMU and prints every figure."""

from __future__ import annotations

import pytest

pytestmark = [pytest.mark.qemu, pytest.mark.firmware, pytest.mark.train, pytest.mark.slow]


def test_ondevice_bench_json(run_bench) -> None:
    figures = run_bench("ondevice", "--samples", "5")
    for recipe in ("paper (resmlp 128x3", "best (resmlp 128x2"):
        for weights in ("f32", "f16", "i8"):
            label = f"{recipe}, {weights})"
            for what in ("QEMU instructions", "cycle model", "time at 96 MHz"):
                f = figures[f"decode {label}: {what}"]
                assert f["value"] > 0 and f["ratio"] == f["value"] / f["reference_value"]
                # the device's estimates match Python's on those samples
                assert f["extra"]["max_abs_error_vs_python"] < 1e-3
                assert f["extra"]["flags_disagree"] == 0
            assert figures[f"model image {label}"]["extra"]["fits"]  # 448 KiB store
    ram = figures["interpreter static RAM (stac_model_t + state)"]
    assert 0 < ram["value"] < ram["reference_value"]
