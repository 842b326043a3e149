"""The forward-figure benchmark (`python -m tools.bench.forward_figure`) end to end on a small
ageing skin: each recipe's printed figure against the next sessions' error, and the time
estimate against the wall time (no timing or accuracy asserted)."""

from __future__ import annotations

import pytest

pytestmark = [pytest.mark.train, pytest.mark.slow]


def test_forward_figure_bench_json(run_bench) -> None:
    figures = run_bench(
        "forward_figure", "--sessions", "12", "--train", "9", "--session-s", "3",
        "--epochs", "1", "--budget", "5", "--recipes", "paper,auto", "--no-recal",
    )  # fmt: skip
    for recipe in ("paper", "auto"):
        fwd = figures[f"forward figure: {recipe} (quiet)"]
        assert fwd["reference_name"] == "MAE on the next 3 sessions"
        assert fwd["ratio"] == pytest.approx(fwd["value"] / fwd["reference_value"])
        assert fwd["extra"]["expected_text"].startswith("expect on your next session")
        est = figures[f"estimate to wall: {recipe} (quiet)"]
        assert est["value"] > 0 and est["reference_value"] > 0
    assert figures["forward figure: auto (quiet)"]["extra"]["chosen"]
    share = figures["share within 1.5x: forward figure and estimate"]
    assert share["reference_value"] == 4.0 and 0.0 <= share["value"] <= 1.0
