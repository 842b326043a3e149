"""What every F/T driver produces: FT_RECORD rows, the sensor's FTInfo and link FTStats.

>>> rows = np.zeros(2, dtype=FT_RECORD)
>>> rows["wrench"].shape, FT_RECORD.itemsize
((2, 6), 76)
>>> FTStats(received=3, lost=1).as_dict()["lost"]
1
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from typing import Any, Literal

import numpy as np

from spectratac.hardware.generated import vocabulary as vocab

#: One F/T sample. sensor_time is on the F/T's own clock (s, unwrapped, monotone per sensor
#: stream); host_time is time.monotonic() when its bytes arrived; sequence is the sensor's
#: sample sequence (unwrapped), so a gap of k means k lost samples; wrench is Fx Fy Fz [N],
#: Tx Ty Tz [N*m]; status is the device's status word, 0 = healthy (bits per driver).
FT_RECORD = np.dtype(
    [
        ("sensor_time", "<f8"),
        ("host_time", "<f8"),
        ("sequence", "<u8"),
        ("wrench", "<f8", (6,)),
        ("status", "<u4"),
    ]
)

AXES = vocab.FT_AXES  # the order of FT_RECORD's wrench

FTKind = Literal["netft", "bota", "csv", "rosbag"]


@dataclass
class FTInfo:
    """What the driver knows about the sensor. rate_hz is the nominal record rate (0 when
    unknown); counts_per_* scale raw counts to N and N*m (1.0 for sensors sending floats)."""

    kind: FTKind
    model: str = ""
    serial: str = ""
    rate_hz: float = 0.0
    counts_per_force: float = 1.0
    counts_per_torque: float = 1.0
    extra: dict[str, Any] = field(default_factory=dict)

    def as_dict(self) -> dict[str, Any]:
        return asdict(self)


@dataclass
class FTStats:
    """Link health seen by the host. lost counts samples missing by sequence (a late,
    reordered sample that fills a gap is taken back off lost); gaps counts gap events."""

    received: int = 0  # records delivered into the buffer
    lost: int = 0  # samples missing by sequence number
    gaps: int = 0  # places where the sequence jumped forward
    reordered: int = 0  # records that arrived after a later one
    duplicates: int = 0  # records whose sequence was already delivered (dropped)
    crc_errors: int = 0  # frames with a bad checksum (Bota)
    bad_frames: int = 0  # packets/frames/lines of the wrong size or shape
    implausible: int = 0  # records dropped: non-finite or far beyond the sensor's range
    overflows: int = 0  # records discarded because the buffer was full (oldest first)
    stalls: int = 0  # quiet spells past the stall timeout while streaming (FTSensor)

    def as_dict(self) -> dict[str, int]:
        return asdict(self)
