"""The protocol benchmark runs end to end and reports its figures (no timing is asserted)."""

from __future__ import annotations


def test_protocol_bench_json(run_bench) -> None:
    figures = run_bench("protocol", "--frames", "3000", "--corrupt", "20000")
    assert set(figures) >= {"incremental decoder", "bulk decoder", "false accepts"}
    assert figures["false accepts"]["value"] == 0
    assert figures["false accepts"]["extra"]["decoder"]["dropped"] >= 20000
    for f in figures.values():
        assert f["ratio"] == f["value"] / f["reference_value"]
