"""tools/bench/generalisation.py end to end on a tiny population (no figure is asserted)."""

from __future__ import annotations

import math

import pytest

pytestmark = [pytest.mark.train, pytest.mark.slow]

TINY = ["--quick", "--units", "2", "--sessions-per-unit", "2", "--session-s", "30"]
TINY += ["--full-cal-s", "60", "--test-s", "30", "--minutes", "0.5", "--epochs", "1"]
TINY += ["--best-epochs", "1", "--no-progress"]


def test_generalisation_bench_tiny(run_bench) -> None:
    by = run_bench("generalisation.py", *TINY)
    own = "paper on the new unit's own 1 min calibration"
    for recipe in ("paper", "best", "ridge"):
        a = by[f"(a) held-out unit: {recipe}"]
        assert a["reference_name"] == own and math.isfinite(a["ratio"]) and a["value"] > 0
        b = by[f"(b) held-out session: {recipe}"]
        assert b["reference_name"].startswith(recipe) and b["extra"]["n"] == 600
    for mode in ("scaler", "head", "first", "full"):
        assert by[f"(c) 0.5 min fine-tune {mode}"]["extra"]["mode"] == mode
    assert "(c) 0.5 min paper from scratch" in by
    base = by["(c) 0 min: population model, no recalibration"]
    assert base["value"] == by["(a) held-out unit: paper"]["value"]
    target = by["target: 0.5 min fine-tune (" + _best_mode(by) + ") vs full calibration"]
    assert target["reference_value"] == 1.3 and isinstance(target["extra"]["met"], bool)
    assert target["extra"]["config"]["units"] == 2


def _best_mode(by: dict) -> str:
    modes = {k: v["ratio"] for k, v in by.items() if k.startswith("(c) 0.5 min fine-tune")}
    return min(modes, key=modes.__getitem__).rsplit(" ", 1)[-1]
