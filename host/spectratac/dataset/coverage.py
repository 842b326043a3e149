"""How well a session's reference F/T covers its optical windows, checked after every build:
a reference that covers few windows, or lands far more F/T samples in each window than its
rate allows (its clock compressed onto the host's: a bag mapped at the wrong scale), gives
targets that look plausible and are wrong, so it is never silent.

Below COVERAGE_MIN of the rows with a target, or a mean count per window beyond
COUNT_RATIO_MAX times what the F/T's rate and the window's length imply: a CoverageWarning
(`dataset build` prints it and exits 1, the dataset written). No row at all: DatasetError
(exit 3), since the reference does not belong to the recording.

In a truncated recording (a killed `record`) the two streams were flushed at different
moments, so the optical windows after the reference's last sample are the cut, not a gap in
the reference: they are counted apart (`cut_windows`) and left out of the coverage.
"""

from __future__ import annotations

import warnings

import numpy as np

from spectratac.dataset.schema import DatasetError

COVERAGE_MIN = 0.95
COUNT_RATIO_MAX = 2.0


class CoverageWarning(UserWarning):
    """The reference F/T covers the session's windows too little or implausibly densely."""


def check_coverage(
    where: str,
    ft: np.ndarray | None,
    t_start: np.ndarray,
    t_end: np.ndarray,
    valid: np.ndarray,
    count: np.ndarray,
    scale: float,
    truncated: bool = False,
) -> dict[str, float]:
    """The coverage figures of one session (rows with a target, F/T samples per window,
    expected); warns or raises as the module says. No reference F/T: nothing to check."""
    if ft is None or not len(ft) or not len(valid):
        return {}
    cut = 0
    if truncated:
        inside = t_end <= float(ft["host_time"][-1])
        cut = int(np.count_nonzero(~inside))
        t_start, t_end, valid, count = t_start[inside], t_end[inside], valid[inside], count[inside]
    n = len(valid)
    if not n:
        return {"coverage": 0.0, "cut_windows": float(cut)}
    fraction = float(np.count_nonzero(valid)) / n
    steps = np.diff(ft["sensor_time"])
    steps = steps[steps > 0]
    rate = 1.0 / float(np.median(steps)) if len(steps) else 0.0  # per F/T-clock second
    window = float(np.median(t_end - t_start)) * scale  # host s back to the sensors' seconds
    expected = rate * window
    mean = float(np.mean(count[valid])) if fraction else 0.0
    figures = {"coverage": fraction, "ft_per_window": mean, "ft_per_window_expected": expected}
    if truncated:
        figures["cut_windows"] = float(cut)
    if fraction == 0:
        span = f"{float(ft['host_time'][0]):.3f}..{float(ft['host_time'][-1]):.3f} s"
        raise DatasetError(
            f"{where}: the reference F/T covers none of the {n} optical windows (its "
            f"{len(ft)} samples span host times {span}, the windows "
            f"{float(t_start[0]):.3f}..{float(t_end[-1]):.3f} s): it was not recorded with "
            f"this session, or its clock does not map onto the session's; give the F/T "
            f"recorded beside this session"
        )
    if fraction < COVERAGE_MIN:
        warnings.warn(
            CoverageWarning(
                f"{where}: only {fraction:.1%} of the {n} optical windows have a reference "
                f"F/T target (fewer than {COVERAGE_MIN:.0%}): the reference has gaps (see "
                f"--max-gap-ms) or covers only part of the session"
            ),
            stacklevel=2,
        )
    if expected > 0 and mean > COUNT_RATIO_MAX * expected + 1:
        warnings.warn(
            CoverageWarning(
                f"{where}: each optical window averages {mean:.0f} F/T samples, where the "
                f"F/T's rate ({rate:.0f} Hz) and the window ({window * 1e3:.0f} ms) imply "
                f"{expected:.0f}: the F/T's times are compressed onto the session's (a "
                f"reference on another clock scale); its targets are not trustworthy"
            ),
            stacklevel=2,
        )
    return figures
