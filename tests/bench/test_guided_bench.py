"""The guided-adaptation benchmark runs end to end on one unit (its figures are the log's)."""

from __future__ import annotations

import pytest

pytestmark = [pytest.mark.slow, pytest.mark.train]


def test_guided_bench_json(run_bench) -> None:
    figures = run_bench("guided", "--units", "1", "--epochs", "5")
    right = figures["Snake presses right, adapted"]
    base = figures["Snake presses right, base"]
    assert right["reference_value"] == base["reference_value"] == 9  # one unit's presses
    assert right["extra"]["per_unit"]["1"]["adapted"] == right["value"]
    assert base["value"] == 0  # another unit's estimates: all out of distribution
    assert figures["Fz MAE in contact, adapted"]["reference_name"] == "the base model's"
