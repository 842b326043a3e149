"""The benchmarks of issue 26 (quiet and beside busy loops) run end to end on a small scale
(no timing asserted), and benchlib's busy loops really run and really stop."""

from __future__ import annotations

import pytest

from tools.bench import benchlib


def test_busy_loops_spin_while_measuring_and_are_gone_after() -> None:
    with benchlib.busy_loops(2) as procs:
        assert len(procs) == 2 and all(p.poll() is None for p in procs)
    assert all(p.returncode is not None for p in procs)
    with benchlib.busy_loops(0) as none:
        assert none == []


@pytest.mark.train
def test_training_bench_json(run_bench) -> None:
    figures = run_bench("training", "--epochs", "1", "--rounds", "1", "--busy", "1")
    quiet, loaded = figures["MLP training, quiet"], figures["MLP training, 1 busy loops"]
    assert quiet["value"] > 0 and quiet["extra"]["threads"] >= 1
    assert loaded["reference_value"] == quiet["value"]
    assert loaded["ratio"] == pytest.approx(loaded["value"] / quiet["value"])


@pytest.mark.train
@pytest.mark.slow
def test_demo_bench_json(run_bench) -> None:
    figures = run_bench("demo", "--duration", "20", "--epochs", "1")
    quiet = figures["make demo, quiet"]
    assert quiet["reference_value"] == 120.0 and quiet["value"] > 0
    assert {"record_s", "dataset_s", "train_evaluate_s", "total_s", "estimate_s", "cpu_s"} <= set(
        quiet["extra"]
    )
