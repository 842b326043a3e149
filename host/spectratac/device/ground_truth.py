"""Ground truth a transport may carry: what really touched the sensor, by device time.

A real sensor's link carries bytes only. A simulated device also knows the scene it plays,
so its transport has a `ground_truth` attribute that answers the `GroundTruth` protocol;
the recorder asks for it with `ground_truth_of` and stores it in the recording (FORMAT.md),
so a recording carries its labels and needs nothing else to become a dataset.

>>> ground_truth_of(object()) is None
True
>>> rows = np.zeros(2, CONTACT_TRUTH)
>>> rows.dtype.names
('region', 'in_contact', 'press', 'position_mm', 'force_n')
"""

from __future__ import annotations

from typing import Any, Protocol, runtime_checkable

import numpy as np

#: The truth at one moment. region: 1..9 on a firm contact inside the active area, -1
#: elsewhere; press: index of the press under way (-1 between presses); position_mm: the
#: contact's (x, y) in board axes (0, 0 without contact); force_n: the load the indenter
#: applies (Fx, Fy, normal), N.
CONTACT_TRUTH = np.dtype(
    [
        ("region", "i1"),
        ("in_contact", "?"),
        ("press", "<i4"),
        ("position_mm", "<f8", (2,)),
        ("force_n", "<f8", (3,)),
    ]
)


@runtime_checkable
class GroundTruth(Protocol):
    """The ground truth of a simulated session. Device time = the truth's clock (s)."""

    @property
    def duration_s(self) -> float | None:
        """Device time at which the session's script ends (None: open-ended)."""
        ...

    def describe(self) -> dict[str, Any]:
        """JSON naming where the truth comes from (scene, seed, speed, epoch...); stored in
        the recording's session message."""
        ...

    def contact(self, t_device_s: np.ndarray) -> np.ndarray:
        """CONTACT_TRUTH rows at device times `t_device_s` (s)."""
        ...

    def label_events(self) -> list[dict[str, Any]]:
        """One label event per press, in time order (LABELS.md: source "scene")."""
        ...


def ground_truth_of(transport: object) -> GroundTruth | None:
    """The transport's ground truth, or None for a link that carries none (real hardware)."""
    truth = getattr(transport, "ground_truth", None)
    return truth if isinstance(truth, GroundTruth) else None
