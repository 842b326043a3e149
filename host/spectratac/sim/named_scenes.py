"""The one table of scenes by name: sim:// URLs, `spectratac twin generate` and twin
populations all pick their scene here.

sim://?scene=idle | press | tour | calibration | drift | presses | saturation_ambient | ... &seed=3
Scene parameters (strings, as in a URL): start (s: join the scene this far in, e.g. mid-press;
any scene), duration (s; idle, calibration, drift), press
(region, force), tour (period), presses (order, force, hold, gap: `twin.scripted_presses`),
guided (prompts, hold, rest: a person pressing what `record --guided` prompts,
`sim.guided_person`).
Hard cases have a fixed script and carry the acquisition settings they need.

Idle has no length of its own, so its user says how long it lasts: a simulated device plays
it for an hour of device time (DEVICE_OPEN_ENDED_S), `twin generate` writes 10 s.

>>> named_scene("idle", open_ended_s=10.0).duration_s, make_scene("idle").duration_s
(10.0, 3600.0)
>>> make_scene("press").name, scene_settings("near_dark")["gain"]
('single_press', 0.5)
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

from spectratac.twin import builtin_scenes, scripted_presses
from spectratac.twin.errors import TwinError
from spectratac.twin.scene_model import Scene

#: How long a simulated device plays a scene without a length of its own (device seconds).
DEVICE_OPEN_ENDED_S = 3600.0


class UnknownSceneError(TwinError, ValueError):
    """No scene has this name."""


@dataclass(frozen=True)
class NamedScene:
    """How to build a scene: from its seed, its duration (None: the scene's own) and the rest
    of its parameters (strings)."""

    build: Callable[[int, float | None, Mapping[str, str]], Scene]
    open_ended: bool = False  # no length of its own: the caller's open_ended_s applies
    settings: Mapping[str, Any] | None = None  # acquisition settings the scene needs


def _idle(seed: int, duration_s: float | None, params: Mapping[str, str]) -> Scene:
    return builtin_scenes.idle(*(() if duration_s is None else (duration_s,)))


def _press(seed: int, duration_s: float | None, params: Mapping[str, str]) -> Scene:
    return builtin_scenes.single_press(
        int(params.get("region", "5")), float(params.get("force", "5.0"))
    )


def _tour(seed: int, duration_s: float | None, params: Mapping[str, str]) -> Scene:
    return builtin_scenes.region_tour(float(params.get("period", "1.111")))


def _calibration(seed: int, duration_s: float | None, params: Mapping[str, str]) -> Scene:
    cal_s = builtin_scenes.CAL_DURATION_S if duration_s is None else duration_s
    return builtin_scenes.calibration_session(seed, cal_s)


def _drift(seed: int, duration_s: float | None, params: Mapping[str, str]) -> Scene:
    return builtin_scenes.drift_session(*(() if duration_s is None else (duration_s,)))


def _presses(seed: int, duration_s: float | None, params: Mapping[str, str]) -> Scene:
    return scripted_presses.from_url_params(**params)  # order=up,left,5&force=2.0


def _guided(seed: int, duration_s: float | None, params: Mapping[str, str]) -> Scene:
    from spectratac.sim import guided_person  # the person follows the recorder's schedule

    return guided_person.from_url_params(seed, params)  # prompts=9&hold=3&rest=2


SCENES: dict[str, NamedScene] = {
    "idle": NamedScene(_idle, open_ended=True),
    "press": NamedScene(_press),
    "tour": NamedScene(_tour),
    "calibration": NamedScene(_calibration),
    "drift": NamedScene(_drift),
    "presses": NamedScene(_presses),
    "guided": NamedScene(_guided),
}
#: Scenes a twin population records: their length is the session length it asks for.
POPULATION_SCENES = ("calibration", "idle", "drift")


def _hard(name: str) -> NamedScene | None:
    case = builtin_scenes.hard_cases().get(name)
    if case is None:
        return None
    return NamedScene(lambda *_: case.scene, settings=case.settings)


def scene_names() -> list[str]:
    return sorted(SCENES) + sorted(builtin_scenes.hard_cases())


def _entry(name: str) -> NamedScene:
    entry = SCENES.get(name) or _hard(name)
    if entry is None:
        raise UnknownSceneError(f"unknown scene {name!r}; choose one of {', '.join(scene_names())}")
    return entry


def named_scene(
    name: str,
    seed: int = 0,
    duration_s: float | None = None,
    params: Mapping[str, str] | None = None,
    *,
    open_ended_s: float,
) -> Scene:
    """The scene called `name`; `duration_s` None means the scene's own length, or
    `open_ended_s` for a scene without one (idle)."""
    entry = _entry(name)
    if duration_s is None and entry.open_ended:
        duration_s = open_ended_s
    return entry.build(seed, duration_s, params or {})


def scene_settings(name: str) -> dict[str, Any]:
    """The acquisition settings (`generate_session` keywords) scene `name` needs, if any."""
    return dict(_entry(name).settings or {})


def make_scene(name: str, **params: str) -> Scene:
    """The scene of a sim:// URL: `params` are its other query values (strings), such as
    seed, duration and the scene's own."""
    seed = int(params.pop("seed", "0"))
    duration = params.pop("duration", None)
    start = float(params.pop("start", "0"))
    scene = named_scene(
        name,
        seed,
        None if duration is None else float(duration),
        params,
        open_ended_s=DEVICE_OPEN_ENDED_S,
    )
    return scene.starting_at(start) if start else scene
