"""The ground truth of a simulated world: the scene it plays, evaluated at device times.

A simulated device's clock is its scene's clock, so the truth at a sample is the scene's
contact at the sample's device time. `SceneTruth` answers spectratac.device's `GroundTruth`
protocol; a sim:// transport carries one, and the recorder writes it into the recording.

>>> from spectratac.twin.scene_model import Scene
>>> truth = SceneTruth(Scene.single_press(x=0.0, normal_n=5.0), {"scene": "press"})
>>> rows = truth.contact(np.array([0.2, 1.5]))
>>> rows["region"].tolist(), rows["in_contact"].tolist(), rows["press"].tolist()
([-1, 5], [False, True], [-1, 0])
>>> [(e["region"], e["scene_start"], e["t_start"]) for e in truth.label_events()]
[(5, 0.5, None)]
>>> events = scene_label_events(Scene.single_press(x=0.0), epoch=100.0, speed=10.0)
>>> round(events[0]["t_start"], 6)  # host time: 100 + 0.5 / 10
100.05
"""

from __future__ import annotations

from typing import Any

import numpy as np

from spectratac.device.ground_truth import CONTACT_TRUTH
from spectratac.twin.geometry import region_of
from spectratac.twin.scene_model import Scene


def scene_label_events(
    scene: Scene, epoch: float | None = None, speed: float | None = None
) -> list[dict[str, Any]]:
    """Every press of `scene` as a label event (LABELS.md); host times when the scene is
    paced (scene time = (host - epoch) x speed), else null."""
    p = scene.presses
    regions = region_of(p.x, p.y)
    end = p.end
    paced = epoch is not None and speed is not None
    events = []
    for i in range(len(p)):
        s0, s1 = float(p.start[i]), float(end[i])
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


class SceneTruth:
    """`scene`'s truth. `description`: the session message's "sim" block (scene name,
    seed, speed, epoch...); its epoch and speed give label events host times when paced."""

    def __init__(self, scene: Scene, description: dict[str, Any]) -> None:
        self.scene = scene
        self.description = dict(description)

    @property
    def duration_s(self) -> float:
        return self.scene.duration_s

    def describe(self) -> dict[str, Any]:
        return dict(self.description)

    def contact(self, t_device_s: np.ndarray) -> np.ndarray:
        t = np.asarray(t_device_s, dtype=np.float64)
        state = self.scene.contact(t)
        out = np.empty(t.shape, CONTACT_TRUTH)
        out["region"] = state.region
        out["in_contact"] = state.in_contact
        out["press"] = self.scene.press_index(t)
        out["position_mm"] = np.stack([state.x, state.y], axis=-1)
        out["force_n"] = np.stack([state.fx, state.fy, state.normal], axis=-1)
        return out

    def label_events(self) -> list[dict[str, Any]]:
        epoch = self.description.get("epoch")
        speed = self.description.get("speed")
        paced = epoch is not None and isinstance(speed, (int, float))
        return scene_label_events(
            self.scene, epoch if paced else None, float(speed) if paced else None
        )
