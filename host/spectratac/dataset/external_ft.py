"""A reference F/T recorded apart from the optical sensor (`dataset build --ft URL`): a
`ros2 bag record` or a CSV log running beside `spectratac record` on the same machine.

The file's rows replace the recording's F/T. Their host times must be on the recording's
host clock: a ROS 2 bag's receive times are wall-clock times, which the rosbag:// replay put
on this process's monotonic clock (its `unix_minus_monotonic_ns`), so they are shifted onto
the recording's (FORMAT.md: the session's `unix_minus_monotonic_ns`); a CSV's host_time
column is taken as already on it. The builder then fits the F/T's own clock to those host
times as it does for any recorded F/T.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import numpy as np

from spectratac.dataset.schema import DatasetError
from spectratac.ft import FT_RECORD, FTSensor
from spectratac.ft.replay import ReplayFTSensor


@dataclass(frozen=True)
class ExternalFT:
    """FT_RECORD rows from `url`; host times on the monotonic clock of a process whose wall
    clock ran `unix_minus_monotonic_ns` ahead (None: already on the recording's clock)."""

    url: str
    rows: np.ndarray
    unix_minus_monotonic_ns: int | None
    #: rows the reader dropped, by reason (rosbag://: not finite, beyond range, stamp jumps)
    dropped: dict[str, int] = field(default_factory=dict)

    def on_clock(self, recording_unix_minus_monotonic_ns: int) -> np.ndarray:
        """The rows with their host times on a recording's host clock."""
        rows = self.rows.copy()
        if self.unix_minus_monotonic_ns is not None:
            shift = self.unix_minus_monotonic_ns - recording_unix_minus_monotonic_ns
            rows["host_time"] += shift / 1e9
        return rows


def load_external_ft(url: str, timeout: float = 10.0) -> ExternalFT:
    """Every row of a replayed F/T file (csv://, rosbag://). DatasetError for a live sensor
    or a replay that would stamp rows with the time they are read."""
    with FTSensor.open(url, timeout=timeout) as ft:
        if not isinstance(ft, ReplayFTSensor):
            raise DatasetError(
                f"--ft {url}: a live sensor cannot supply a finished recording's reference; "
                f"give a file (rosbag://BAG?topic=…, or csv://FILE with a host_time column)"
            )
        if not ft.keeps_file_times:
            raise DatasetError(
                f"--ft {url}: the replay would stamp rows with the time they are read, not "
                f"when they were recorded; use rosbag://…&host_time=bag or a CSV with host_time"
            )
        parts = []
        while True:
            batch = ft.read(1 << 16, timeout=timeout)
            if not len(batch):
                break
            parts.append(batch)
        umm = ft.info.extra.get("unix_minus_monotonic_ns")
        dropped = {k: int(v) for k, v in (ft.info.extra.get("dropped") or {}).items() if v}
    rows = np.concatenate(parts) if parts else np.zeros(0, dtype=FT_RECORD)
    if dropped:
        what = ", ".join(f"{v} {_REASONS.get(k, k)}" for k, v in dropped.items())
        warnings.warn(
            DroppedFTWarning(f"--ft {url}: rows dropped: {what} ({len(rows)} kept)"),
            stacklevel=2,
        )
    return ExternalFT(url, rows, None if umm is None else int(umm), dropped)


_REASONS = {
    "not_finite": "not finite",
    "beyond_range": "beyond any F/T sensor's range",
    "stamp_jumps": "with a header stamp off the line of the others",
}


class DroppedFTWarning(UserWarning):
    """Rows of a reference F/T file the reader could not trust (counted by reason)."""
