"""`python -m tools.bench.generalisation` end to end on a tiny population (no figure asserted)."""

from __future__ import annotations

import math

import pytest

pytestmark = [pytest.mark.train, pytest.mark.slow]

TINY = ["--quick", "--units", "2", "--sessions-per-unit", "2", "--session-s", "30"]
TINY += ["--full-cal-s", "60", "--test-s", "30", "--minutes", "0.5", "--epochs", "1"]
TINY += ["--best-epochs", "1", "--budget", "5", "--no-progress"]


def test_generalisation_bench_tiny(run_bench) -> None:
    by = run_bench("generalisation", *TINY)
    for recipe in ("paper", "best", "linear", "poly2", "auto"):
        a = by[f"(a) held-out unit: {recipe}"]
        assert a["reference_name"] == "(a) paper" and math.isfinite(a["ratio"]) and a["value"] > 0
        b = by[f"(b) held-out sessions: {recipe}"]
        assert b["reference_name"] == "(b) paper" and b["extra"]["n"] > 500  # last sessions
    assert by["(a) held-out unit: paper"]["ratio"] == 1.0
    assert by["(a) held-out unit: auto"]["extra"]["chosen"]
    for study in ("(a) held-out unit", "(b) held-out sessions"):
        paper = by[f"target {study}: auto / paper"]
        assert paper["reference_value"] == 0.8 and isinstance(paper["extra"]["met"], bool)
        assert any(k.startswith(f"target {study}: auto / best classical") for k in by)
    for mode in ("first", "full"):
        assert by[f"(c) 0.5 min fine-tune {mode} of best"]["extra"]["mode"] == mode
    assert "(c) 0.5 min paper from scratch" in by
    base = by["(c) 0 min: population model of best, no recalibration"]
    assert base["value"] == by["(a) held-out unit: best"]["value"]
    own = "best on the new unit's own 1 min calibration"
    assert base["reference_name"] == own
    assert by["(c) paper on the new unit's own 1 min calibration"]["reference_name"] == own
    target = next(v for k, v in by.items() if k.startswith("target: 0.5 min fine-tune of best"))
    assert target["reference_value"] == 1.3 and isinstance(target["extra"]["met"], bool)
    assert target["extra"]["config"]["units"] == 2
