"""The simulated device feed benchmark runs end to end on a small scale (no timing asserted)."""

from __future__ import annotations


def test_sim_device_bench_json(run_bench) -> None:
    figures = run_bench("sim_device", "--megabytes", "0.25", "--rounds", "1")
    assert set(figures) == {"sim feed, one call", "sim feed, 4x input", "sim feed vs link"}
    for f in figures.values():
        assert f["value"] > 0 and f["ratio"] == f["value"] / f["reference_value"]
