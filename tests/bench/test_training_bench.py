"""The training benchmark (`python -m tools.bench.training`): the recipes' throughput quiet
and beside a busy loop, and the paper run beside GEMMs of its FLOPs, end to end on a small
scale (no timing asserted)."""

from __future__ import annotations

import pytest

pytestmark = [pytest.mark.train, pytest.mark.slow]


def test_training_bench_json_for_the_recipes_and_the_paper_run(run_bench) -> None:
    figures = run_bench(
        "training", "--nets", "paper,best", "--epochs", "1", "--rounds", "1", "--busy", "1",
        "--paper-rows", "2000", "--paper-epochs", "2",
    )  # fmt: skip
    for net in ("paper", "best"):
        quiet, loaded = (
            figures[f"{net} recipe training, quiet"],
            figures[f"{net} recipe training, 1 busy loops"],
        )
        assert loaded["reference_value"] == quiet["value"] > 0
        assert quiet["extra"]["cpu_s"] > 0 and loaded["extra"]["target_ratio"] == 0.4
    best = figures["best recipe training, quiet"]["extra"]
    assert best["batch"] == 256 and best["rows"] == 12_000
    paper = figures["paper recipe, 2000 rows x 2 epochs"]
    assert paper["reference_name"] == "torch GEMMs of the same FLOPs"
    assert paper["reference_value"] > 0
    assert paper["ratio"] == pytest.approx(paper["value"] / paper["reference_value"])
    assert paper["extra"]["cpu_s"] > 0 and paper["extra"]["reference_cpu_s"] > 0
