"""Per-sample region, contact and press labels of a recorded session.

Simulated sessions (labels "scene"): the scene is rebuilt from the session message and its
truth evaluated at each window's centre on the device clock (a simulated device's clock is
the scene clock): region (ContactState.region: 1..9 on firm contacts, -1 elsewhere),
in_contact, and the press under way. Guided sessions (labels "guided"): a sample inside a
prompt's hold span takes the prompted region when the reference F/T confirms a firm contact
(|F| >= LABEL_MIN_NORMAL_N), else -1; in_contact is |F| >= `contact_n`. Without labels,
region and press are -1 and in_contact comes from the F/T.

>>> t = np.array([0.5, 1.5, 2.5, 3.5])
>>> events = [{"index": 0, "region": 4, "t_start": 1.0, "t_end": 3.0}]
>>> force = np.array([[0, 0, 0.0], [0, 0, -2.0], [0, 0, -0.4], [0, 0, -3.0]])
>>> region, press = guided_labels(events, t, force)
>>> region.tolist(), press.tolist()
([-1, 4, -1, -1], [-1, 0, 0, -1])
"""

from __future__ import annotations

from typing import Any

import numpy as np

from spectratac.dataset.from_twin import press_ids
from spectratac.twin.scene import LABEL_MIN_NORMAL_N, Scene

CONTACT_N = 0.5  # |F| above which the reference says something touches the skin


def rebuild_scene(sim: dict[str, Any]) -> Scene:
    """The scene a sim:// session played, from its session message."""
    from spectratac.sim.scenes import make_scene
    from spectratac.sim.world import DEVICE_PARAMS

    params = {k: v for k, v in sim.get("params", {}).items() if k not in DEVICE_PARAMS}
    return make_scene(sim["scene"], seed=str(sim["seed"]), **params)


def scene_labels(
    scene: Scene, t_mid_scene: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(region, in_contact, press) from the scene's truth at scene times `t_mid_scene`."""
    contact = scene.contact(t_mid_scene)
    return contact.region, contact.in_contact, press_ids(scene, t_mid_scene)


def spans(events: list[dict[str, Any]], t: np.ndarray) -> np.ndarray:
    """Index into `events` of the span (t_start <= t < t_end) holding each time; -1 if none."""
    out = np.full(t.shape, -1, dtype=np.int64)
    for i, e in enumerate(events):
        if e.get("t_start") is None or e.get("t_end") is None:
            continue
        out[(t >= e["t_start"]) & (t < e["t_end"])] = i
    return out


def guided_labels(
    events: list[dict[str, Any]], t_mid_host: np.ndarray, force: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """(region, press) for guided label events; `force` is (N, 3) F/T force, NaN unknown."""
    which = spans(events, t_mid_host)
    press = np.where(which >= 0, [events[i]["index"] if i >= 0 else -1 for i in which], -1)
    prompted = np.array([events[i]["region"] if i >= 0 else -1 for i in which], dtype=np.int8)
    with np.errstate(invalid="ignore"):
        firm = np.linalg.norm(force, axis=1) >= LABEL_MIN_NORMAL_N
    region = np.where((which >= 0) & firm, prompted, np.int8(-1)).astype(np.int8)
    return region, press.astype(np.int32)


def ft_contact(force: np.ndarray, contact_n: float = CONTACT_N) -> np.ndarray:
    """in_contact from the F/T force (N, 3); unknown (NaN) counts as no contact."""
    with np.errstate(invalid="ignore"):
        return np.linalg.norm(force, axis=1) >= contact_n
