"""Label events of a link with ground truth, handed to the file as the session goes.

A label event is one JSON object on the ``/labels`` channel (LABELS.md). A simulated link's
ground truth (spectratac.device.GroundTruth) lists its presses' events up front: ``source``
"scene", ``index``, ``region``, ``t_start``/``t_end`` (host monotonic s, or null),
``scene_start``/``scene_end`` (s on the device clock), ``x``, ``y`` (mm), ``normal_peak``
(N). `LabelQueue` releases each once the device clock has passed its end, so a recording
holds the labels of what it recorded.

>>> queue = LabelQueue([{"index": 0, "scene_start": 0.5, "scene_end": 3.5}])
>>> queue.due(1.0), [e["index"] for e in queue.due(4.0)], queue.due(9.0)
([], [0], [])
"""

from __future__ import annotations

from typing import Any


class LabelQueue:
    """Time-ordered label events, released by device time (`scene_start`, `scene_end`)."""

    def __init__(self, events: list[dict[str, Any]]) -> None:
        self.events = list(events)
        self._next = 0

    def due(self, device_now: float) -> list[dict[str, Any]]:
        """Events that ended by device time `device_now` and were not handed out."""
        start = self._next
        events = self.events
        while self._next < len(events) and events[self._next]["scene_end"] <= device_now:
            self._next += 1
        return events[start : self._next]

    def started(self, device_now: float) -> list[dict[str, Any]]:
        """At the end of a recording: the event under way at `device_now`, if any (partial).

        >>> LabelQueue([{"scene_start": 0.5, "scene_end": 3.5}]).started(1.0)
        [{'scene_start': 0.5, 'scene_end': 3.5}]
        """
        start = self._next
        events = self.events
        while self._next < len(events) and events[self._next]["scene_start"] < device_now:
            self._next += 1
        return events[start : self._next]
