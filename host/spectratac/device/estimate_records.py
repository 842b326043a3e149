"""The estimate record the host hands to users: one NumPy structured row per ESTIMATE frame.

An ESTIMATE is decoded on the device (protocol 1.1, SPEC.md section 14). Its `sequence` and
`device_time_us` are those of the SAMPLE it ends with, so estimates pair with SAMPLE_RECORD
rows on (`epoch`, `sequence`) exactly as the device paired them.

>>> rows = to_estimate_array([EstimateRow(5_050_000, 0.5, 1234, 2, 7, 1,
...     (0.5, -1.0, 4.0), (float("nan"),) * 3, 5, 0.875, 812)])
>>> rows["sequence"].tolist(), rows["force"][0].tolist(), bool(np.isnan(rows["torque"]).all())
([1234], [0.5, -1.0, 4.0], True)
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

#: One row per estimate. Device times are unwrapped like SAMPLE_RECORD's (the same clock and
#: epoch); host_time is time.monotonic() in seconds when the frame's bytes were read. Values
#: the model does not give are NaN (SPEC.md: force/torque without such a target or with
#: EST_INVALID, region_prob without a region head; region is then 0).
ESTIMATE_RECORD = np.dtype(
    [
        ("device_time_us", "<u8"),  # t_end_us of the sample the estimate ends with, unwrapped
        ("host_time", "<f8"),
        ("sequence", "<u4"),  # sample_seq of that sample
        ("config_id", "<u2"),
        ("model_id", "<u4"),
        ("flags", "u1"),  # EST_* bits (spectratac.protocol.generated.messages.EstimateFlags)
        ("force", "<f4", (3,)),  # Fx, Fy, Fz in N, board axes
        ("torque", "<f4", (3,)),  # Tx, Ty, Tz in N·m
        ("region", "u1"),  # 1..9, 0 none
        ("region_prob", "<f4"),
        ("decode_us", "<u2"),  # device time spent decoding, saturating at 65535
        ("epoch", "<u2"),
    ]
)


class EstimateRow(NamedTuple):
    """A single estimate, in ESTIMATE_RECORD's field order."""

    device_time_us: int
    host_time: float
    sequence: int
    config_id: int
    model_id: int
    flags: int
    force: tuple[float, ...]
    torque: tuple[float, ...]
    region: int
    region_prob: float
    decode_us: int
    epoch: int = 0


def to_estimate_array(rows: list[EstimateRow]) -> np.ndarray:
    """Estimates as ESTIMATE_RECORD rows."""
    if not rows:
        return np.empty(0, ESTIMATE_RECORD)
    return np.array(rows, dtype=ESTIMATE_RECORD)


class EstimateGaps:
    """Counts estimates lost on the link from ESTIMATE.sample_seq.

    A model that needs a whole multi-step LED cycle sends one estimate per cycle, so
    consecutive estimates are `stride` samples apart; a larger step means lost estimates.

    >>> gaps = EstimateGaps(stride=3)
    >>> for seq in (2, 5, 14, 17):
    ...     gaps.see(seq)
    >>> gaps.lost
    2
    """

    def __init__(self, stride: int = 1) -> None:
        self.stride = max(1, stride)
        self.lost = 0
        self._last: int | None = None

    def restart(self, stride: int | None = None) -> None:
        """A new stream (START, CONFIGURE or a reconnect): sample_seq counts afresh."""
        if stride is not None:
            self.stride = max(1, stride)
        self._last = None

    def see(self, sequence: int) -> None:
        last = self._last
        if last is not None and sequence > last + self.stride:
            self.lost += (sequence - last) // self.stride - 1
        self._last = sequence
