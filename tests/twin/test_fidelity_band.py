"""The full fidelity report (the paper's recipe on a 50-minute twin session, 30 epochs) stays
inside the calibration band on the built layer stack: what `spectratac twin report` prints."""

from __future__ import annotations

import pytest
from spectratac.studies.twin_fidelity import PAPER, ReportConfig, band, fidelity_report

pytestmark = [pytest.mark.train, pytest.mark.slow]


def test_full_report_is_inside_the_band() -> None:
    rep = fidelity_report(ReportConfig(seed=0, oracle_samples=200))
    rnd = rep["splits"]["random"]["recipe"]
    for axis in ("Fx", "Fy", "Fz"):
        low, high = band(PAPER["mae"][axis])
        assert low <= rnd["axes"][axis]["mae"] <= high, (axis, rnd["axes"][axis])
    assert rep["checks"]["r2_above_0.91_all_six"], {a: v["r2"] for a, v in rnd["axes"].items()}
    assert rep["checks"]["region_accuracy_at_least_99pct"], rnd["region_accuracy"]
