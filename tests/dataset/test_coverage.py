"""`dataset build`'s coverage check (`spectratac.dataset.coverage`): a reference that covers
few windows, none, or lands far more samples in each than its rate allows is never silent.
Before, a bag mapped at the wrong clock scale gave 6.5 % of the rows targets averaged over
~750 F/T samples each (50 expected), with exit code 0."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from spectratac.dataset.coverage import CoverageWarning, check_coverage
from spectratac.dataset.schema import DatasetError
from spectratac.ft import FT_RECORD
from spectratac.fusion import window_average

N = 200  # 50-ms windows back to back: 10 s


def case(
    compress: float, covered: float, truncated: bool = False
) -> tuple[list[str], dict[str, float]]:
    """A 1-kHz F/T (its own clock) on the host clock squeezed `compress` times, starting at
    the session's start, and covering its first `covered` fraction."""
    t_start = np.arange(N) * 0.05
    t_end = t_start + 0.05
    ft = np.zeros(int(10_000 * covered), FT_RECORD)
    ft["sensor_time"] = np.arange(len(ft)) * 1e-3
    ft["host_time"] = ft["sensor_time"] / compress
    _, valid, count = window_average(ft["host_time"], ft["wrench"], t_start, t_end)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        figures = check_coverage("s.mcap", ft, t_start, t_end, valid, count, 1.0, truncated)
    return [str(w.message) for w in caught if w.category is CoverageWarning], figures


def test_a_reference_that_fits_says_nothing() -> None:
    said, figures = case(1.0, 1.0)
    assert not said and figures["coverage"] > 0.95
    assert figures["ft_per_window"] == pytest.approx(50, abs=1)


def test_a_compressed_reference_is_named() -> None:
    said, _ = case(15.0, 1.0)
    assert any("averages 750 F/T samples" in s and "imply 50" in s for s in said), said
    assert any("only 6.5%" in s for s in said), said


def test_a_partial_reference_is_named() -> None:
    said, figures = case(1.0, 0.5)
    assert figures["coverage"] == pytest.approx(0.5, abs=0.01)
    assert len(said) == 1 and "of the 200 optical windows have a reference" in said[0]


def test_a_truncated_recording_s_cut_is_not_a_gap() -> None:
    """A killed `record` flushed its F/T and its frames at different moments (CI at load 10:
    the reference ended 25 % of the windows before the frames, and the build exited 1)."""
    said, figures = case(1.0, 0.75, truncated=True)  # the last sample at 7.499 s: 51 windows after
    assert not said and figures["coverage"] > 0.95 and figures["cut_windows"] == 51
    said, figures = case(1.0, 0.75)  # the same reference in a whole recording: a gap
    assert figures["coverage"] == pytest.approx(0.75, abs=0.01) and len(said) == 1


def test_a_gap_before_a_truncation_is_still_named() -> None:
    t_start = np.arange(N) * 0.05
    ft = np.zeros(10_000, FT_RECORD)
    ft["sensor_time"] = ft["host_time"] = np.arange(10_000) * 1e-3
    ft = ft[(ft["host_time"] < 2.0) | (ft["host_time"] > 7.0)]  # 5 s missing, then the cut
    _, valid, count = window_average(ft["host_time"], ft["wrench"], t_start, t_start + 0.05)
    with pytest.warns(CoverageWarning, match="the reference has gaps"):
        check_coverage("s.mcap", ft, t_start, t_start + 0.05, valid, count, 1.0, True)


def test_no_coverage_is_an_error() -> None:
    t = np.arange(N) * 0.05
    ft = np.zeros(100, FT_RECORD)
    ft["sensor_time"] = ft["host_time"] = 1000 + np.arange(100) * 1e-3
    with pytest.raises(DatasetError, match="covers none of the 200 optical windows"):
        check_coverage("s.mcap", ft, t, t + 0.05, np.zeros(N, bool), np.zeros(N, int), 1.0)
