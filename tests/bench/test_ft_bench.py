"""The F/T benchmark runs end to end on a small scale (no timing is asserted)."""

from __future__ import annotations


def test_ft_bench_json(run_bench) -> None:
    figures = run_bench("ft", "--records", "2000", "--seconds", "0.3", "--rounds", "1")
    assert {"bota driver parse", "bota driver over pty", "netft driver parse"} <= set(figures)
    assert {n for n in figures if n.startswith("sim ")} == {
        f"sim {k}+driver CPU, speed {s}" for k in ("netft", "bota") for s in ("1", "10")
    }
    for f in figures.values():
        assert f["value"] > 0 and f["ratio"] == f["value"] / f["reference_value"]
