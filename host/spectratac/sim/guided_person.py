"""The simulated person of a guided session (`sim://?scene=guided`): presses what the
recorder prompts, as a person at the terminal does.

How the prompts reach the person: the guided protocol's timeline is fixed before a session
starts and published (`spectratac.record.guided.schedule`: the order from the default seed,
countdown, hold and rest on the sensor's clock from the first sample). The recorder shows
that schedule; the person follows the same one, like a person who reads the terminal: no
message passes between them, and nothing the person does is known to the recorder beyond
what the sensor reads. Like a person, this one is late and imprecise: it reacts 0.3-0.7 s
after PRESS, rises and lets go over 0.3-0.6 s, releases 0.2-0.5 s after "release", presses
with 1.5-4 N of a fingertip (3.5-6.5 mm), a small tremor and a little shear, somewhere
inside the prompted region (aimed at its representative point). The recorder's labels are
its prompts; the scene's own truth is recorded beside them, for scoring only.

Record with the protocol's defaults (`--guided N`, the same N as `prompts`, default hold and
rest, no `--guided-seed`), or give the scene the same `hold` and `rest`.

>>> scene = guided_scene(seed=1)
>>> from spectratac.twin.geometry import region_of
>>> [int(r) for r in region_of(scene.presses.x, scene.presses.y)] == [
...     p.region for p in schedule(9)]
True
>>> bool(all(p.go < s for p, s in zip(schedule(9), scene.presses.start)))
True
>>> round(scene.duration_s)
73
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from spectratac.record.guided import COUNTDOWN_S, HOLD_S, REST_S, schedule
from spectratac.twin.builtin_scenes import sample_in_region
from spectratac.twin.errors import TwinError
from spectratac.twin.scene_model import Environment, Presses, Scene

DEFAULT_PROMPTS = 9
REACT_S = (0.3, 0.7)  # PRESS shown -> the finger starts down
EDGE_S = (0.3, 0.6)  # rise and fall of a fingertip press
LET_GO_S = (0.2, 0.5)  # "release" shown -> the finger starts up
FORCE_N = (1.5, 4.0)  # a firm press, as people press a button
FINGER_MM = (3.5, 6.5)  # fingertip contact radius
SHEAR_N = 0.4  # a finger pushes a little sideways
TAIL_S = 1.0  # the scene lasts this long after the last prompt's rest


def guided_scene(
    seed: int = 0,
    prompts: int = DEFAULT_PROMPTS,
    hold_s: float = HOLD_S,
    rest_s: float = REST_S,
) -> Scene:
    """The person's presses for `prompts` prompts of the published schedule."""
    if prompts < 1 or hold_s <= 0 or rest_s < 0:
        raise TwinError("guided scene: prompts >= 1, hold > 0 s and rest >= 0 s")
    plan = schedule(prompts, hold_s=hold_s, rest_s=rest_s)
    n = len(plan)
    rng = np.random.default_rng([int(seed), 0x6D1DED])
    go = np.array([p.go for p in plan])
    release = np.array([p.release for p in plan])
    start = go + rng.uniform(*REACT_S, n)
    rise = rng.uniform(*EDGE_S, n)
    fall = rng.uniform(*EDGE_S, n)
    hold = np.maximum(release + rng.uniform(*LET_GO_S, n) - start - rise, 0.1)
    regions = np.array([p.region for p in plan])
    x, y = sample_in_region(rng, regions)
    presses = Presses(
        start=start,
        rise=rise,
        hold=hold,
        fall=fall,
        x=x,
        y=y,
        normal_peak=rng.uniform(*FORCE_N, n),
        normal_mod_depth=rng.uniform(0.0, 0.1, n),
        normal_mod_hz=rng.uniform(0.3, 1.0, n),
        normal_mod_phase=rng.uniform(0, 2 * np.pi, n),
        shear_amp=rng.uniform(-SHEAR_N, SHEAR_N, (n, 2)),
        shear_hz=rng.uniform(0.1, 0.3, n),
        shear_phase=rng.uniform(0, 2 * np.pi, (n, 2)),
        indenter_radius_mm=rng.uniform(*FINGER_MM, n),
    )
    period = COUNTDOWN_S + hold_s + rest_s
    return Scene("guided", float(n * period + TAIL_S), presses, Environment())


def from_url_params(seed: int, params: Mapping[str, str]) -> Scene:
    """The scene of a sim:// URL's query values (strings): prompts, hold, rest."""
    try:
        prompts = int(params.get("prompts", str(DEFAULT_PROMPTS)))
        hold_s = float(params.get("hold", str(HOLD_S)))
        rest_s = float(params.get("rest", str(REST_S)))
    except ValueError as exc:
        raise TwinError(f"guided scene: {exc}; example: prompts=9&hold=3&rest=2") from None
    return guided_scene(seed, prompts, hold_s, rest_s)
