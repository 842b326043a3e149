"""A recorded session to build datasets from: the region tour with simulated Bota F/T."""

from __future__ import annotations

from pathlib import Path

import pytest
from spectratac.record import RecordOptions, record_url

TOUR_FT = "sim://?scene=tour&seed=1&speed=10&ft=bota"


@pytest.fixture(scope="package")
def tour_mcap(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """500 samples (~25 scene seconds, ~2.5 s of wall time): about 22 presses over all nine
    regions. A sample count, not a wall-clock duration, so a loaded machine records the same."""
    path = tmp_path_factory.mktemp("tour") / "tour.mcap"
    record_url(TOUR_FT, path, RecordOptions(samples=500, sync_every_s=1.0))
    return path


@pytest.fixture(scope="package")
def quick_mcaps(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """Short recordings without F/T at speed=max: two configurations, plus a repeat."""
    folder = tmp_path_factory.mktemp("quick")
    out = {}
    for name, ms in (("a50", 50), ("b50", 50), ("c100", 100)):
        out[name] = folder / f"{name}.mcap"
        record_url(
            "sim://?scene=press&speed=max", out[name], RecordOptions(samples=40, integration_ms=ms)
        )
    return out
