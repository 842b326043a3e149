"""Shared recordings: one short accelerated simulated session with simulated Bota F/T."""

from __future__ import annotations

import warnings
from pathlib import Path

import pytest
from spectratac.record import Recording, RecordingSummary, RecordOptions, read_recording, record_url

TOUR_FT = "sim://?scene=tour&seed=1&speed=10&ft=bota"


def record_short(url: str, path: Path, **options: object) -> RecordingSummary:
    return record_url(url, path, RecordOptions(**options))  # type: ignore[arg-type]


@pytest.fixture(scope="package")
def tour_session(tmp_path_factory: pytest.TempPathFactory) -> tuple[RecordingSummary, Recording]:
    """25 scene seconds of the region tour (~2.5 s of wall time), F/T at 1 kHz scene time."""
    path = tmp_path_factory.mktemp("tour") / "tour.mcap"
    summary = record_short(TOUR_FT, path, duration_s=25.0, sync_every_s=1.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a finished recording reads without any warning
        rec = read_recording(path)
    return summary, rec
