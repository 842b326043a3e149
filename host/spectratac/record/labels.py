"""Region-label events from a simulated scene: one per press, with its region and time span.

A label event is one JSON object on the ``/labels`` channel (LABELS.md):
``source`` ("scene" or "guided"), ``index`` (press number), ``region`` (1..9, -1 on the rim),
``t_start``/``t_end`` (host monotonic s, or null when unknown) and, for scene labels,
``scene_start``/``scene_end`` (scene s, equal to the simulated device's clock), ``x``,
``y`` (mm) and ``normal_peak`` (N).

>>> from spectratac.twin.scene import Scene
>>> labeler = SceneLabeler(Scene.single_press(x=0.0, normal_n=5.0), epoch=100.0, speed=10.0)
>>> labeler.due(0.5), len(labeler.due(60.0))
([], 1)
>>> event = labeler.events[0]
>>> event["region"], event["scene_start"], round(event["t_start"], 6)  # 100 + 0.5 / 10
(5, 0.5, 100.05)
"""

from __future__ import annotations

from typing import Any

from spectratac.twin.geometry import region_of
from spectratac.twin.scene import Scene


def scene_label_events(
    scene: Scene, epoch: float | None = None, speed: float | None = None
) -> list[dict[str, Any]]:
    """Every press of `scene` as a label event; host times when the scene is paced
    (scene time = (host − epoch) × speed), else null."""
    p = scene.presses
    regions = region_of(p.x, p.y)
    end = p.end
    events = []
    for i in range(len(p)):
        s0, s1 = float(p.start[i]), float(end[i])
        paced = epoch is not None and speed is not None
        events.append(
            {
                "source": "scene",
                "index": i,
                "region": int(regions[i]),
                "t_start": epoch + s0 / speed if paced else None,
                "t_end": epoch + s1 / speed if paced else None,
                "scene_start": s0,
                "scene_end": s1,
                "x": float(p.x[i]),
                "y": float(p.y[i]),
                "normal_peak": float(p.normal_peak[i]),
            }
        )
    return events


class SceneLabeler:
    """Hands out each press's event once the scene clock has passed the press's end, so a
    recording holds the labels of what it recorded, written as the session goes."""

    def __init__(self, scene: Scene, epoch: float | None = None, speed: float | None = None):
        self.events = scene_label_events(scene, epoch, speed)
        self._next = 0

    def due(self, scene_now: float) -> list[dict[str, Any]]:
        """Events of presses that ended by scene time `scene_now` and were not handed out."""
        start = self._next
        while self._next < len(self.events) and self.events[self._next]["scene_end"] <= scene_now:
            self._next += 1
        return self.events[start : self._next]

    def started(self, scene_now: float) -> list[dict[str, Any]]:
        """At the end of a recording: the press under way at `scene_now`, if any (partial)."""
        start = self._next
        while self._next < len(self.events) and self.events[self._next]["scene_start"] < scene_now:
            self._next += 1
        return self.events[start : self._next]
