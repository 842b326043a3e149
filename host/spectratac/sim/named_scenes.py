"""Scenes a simulated device can play, by the name used in sim:// URLs.

sim://?scene=idle | press | tour | calibration | drift | saturation_ambient | ... &seed=3
Scene parameters: press (region, force), tour (period), calibration (duration, s).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from spectratac.twin import builtin_scenes, scripted_presses
from spectratac.twin.geometry import region_centre
from spectratac.twin.scene_model import Environment, Presses, Scene

LONG_S = 3600.0  # open-ended scenes (idle) last an hour of device time


def region_tour(period_s: float = 10.0 / 9.0, normal_n: float = 4.0, laps: int = 100) -> Scene:
    """Presses region 1, 2, …, 9 in turn, one per `period_s`, repeating `laps` times."""
    n = 9 * laps
    centres = np.array([region_centre(r) for r in range(1, 10)] * laps)
    edge = 0.2 * period_s
    return Scene(
        "tour",
        float(n * period_s),
        Presses.steady(
            start=np.arange(n) * period_s + 0.05 * period_s,
            rise=edge,
            hold=period_s - 2 * edge - 0.1 * period_s,
            fall=edge,
            xy=centres,
            normal_peak=normal_n,
        ),
        Environment(),
    )


def _press(region: str = "5", force: str = "5.0", **_: str) -> Scene:
    return builtin_scenes.single_press(int(region), float(force))


SCENES: dict[str, Callable[..., Scene]] = {
    "idle": lambda **_: builtin_scenes.idle(LONG_S),
    "press": _press,
    "tour": lambda period="1.111", **_: region_tour(float(period)),
    "calibration": lambda seed="0", duration=str(builtin_scenes.CAL_DURATION_S), **_: (
        builtin_scenes.calibration_session(int(seed), float(duration))
    ),
    "drift": lambda **_: builtin_scenes.drift_session(),
    "presses": scripted_presses.from_url_params,  # order=up,left,5&force=2.0
}


def scene_names() -> list[str]:
    return sorted(SCENES) + sorted(builtin_scenes.hard_cases())


def make_scene(name: str, **params: Any) -> Scene:
    """The scene called `name`; params are the URL's other query values (strings)."""
    if name in SCENES:
        return SCENES[name](**params)
    hard = builtin_scenes.hard_cases()
    if name in hard:
        return hard[name].scene
    raise ValueError(f"unknown scene {name!r}; choose one of {', '.join(scene_names())}")
