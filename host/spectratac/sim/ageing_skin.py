"""A skin that ages over weeks: one 4-channel unit, many sessions, a gain drift one way.

The same optics as `generic_skin` (four photodiodes under a creeping elastomer, a reference
Fz), recorded in `sessions` sessions a few days apart. What changes from session to session
is what the real skins do over weeks of use:

- the skin's response to a press weakens monotonically (`SENSITIVITY_DECAY` per session:
  the elastomer stiffens and the reflective layer wears), so a decoder trained on earlier
  sessions reads later presses low, by more the later they are: a multiplicative
  under-read that grows with time;
- the LEDs dim (`LED_DECAY` per session), which a ratio to the rest level cancels and the
  press response alone does not;
- now and then (on average every `REMOUNT_EVERY` sessions) the skin is re-mounted: a small step
  in each channel's gain and ambient offset, and a step down in the press response (the clamp
  pre-loads the skin);
- within a session, the LEDs warm up in the first seconds (on shortly before recording).

Each session records its start time (`meta["sessions"][i]["started_unix"]`, two to three
days apart) and what was drawn for it (`sensitivity`, `remounted`), so forward-in-time
checks know the order. Same arguments, same dataset.

>>> ds = ageing_skin(sessions=4, session_s=4.0, seed=1)
>>> ds.input_names, ds.target_names, int(ds.session.max()) + 1
(['pd0', 'pd1', 'pd2', 'pd3'], ['Fz'], 4)
>>> s = [m["sensitivity"] for m in ds.meta["sessions"]]
>>> all(a > b for a, b in zip(s, s[1:])), ds.meta["sessions"][1]["started_unix"] > 0
(True, True)
"""

from __future__ import annotations

import numpy as np

from spectratac.dataset.schema import Dataset, concat
from spectratac.sim.generic_skin import (
    CHANNELS,
    CREEP_S,
    CREEP_SHARE,
    DEPTH,
    F_SAT_N,
    FULL_COUNTS,
    NOISE,
    POSITIONS,
    RATE_HZ,
    REACH_CM,
    _loads,
)
from spectratac.twin.errors import TwinError

SENSITIVITY_DECAY = 0.012  # press response lost per session (relative)
LED_DECAY = 0.0005 # LED output lost per session (relative)
REMOUNT_EVERY = 7.0  # mean sessions between re-mountings
REMOUNT_SENSITIVITY = (0.90, 0.98)  # the press response after a re-mounting, relative
REMOUNT_GAIN_SD = 0.03  # per-channel gain step at a re-mounting
REMOUNT_AMBIENT_SD = 150.0  # per-channel ambient-light step at a re-mounting, counts
SESSION_GAP_DAYS = (2.0, 3.0)  # between sessions
START_UNIX = 1.7e9
WARMUP_S = 5.0  # LED warm-up time constant: switched on shortly before each recording


def ageing_skin(
    sessions: int = 36,
    session_s: float = 40.0,
    seed: int = 0,
    remount_every: float | None = REMOUNT_EVERY,
) -> Dataset:
    """`sessions` sessions of `session_s` seconds at 100 Hz of one ageing skin (module
    docstring), in recording order; `remount_every` None: never re-mounted (the ageing
    alone)."""
    if isinstance(sessions, bool) or not isinstance(sessions, int) or sessions < 1:
        raise TwinError(f"sessions must be an int >= 1, got {sessions!r}")
    if not (np.isfinite(session_s) and session_s >= 2.0):
        raise TwinError(f"session_s must be >= 2 s, got {session_s!r}")
    rng = np.random.default_rng([int(seed), 0xA6E5])  # presses, noise, warm-up
    age = np.random.default_rng([int(seed), 0xA6E6])  # the drift: alike at any session length
    n = round(session_s * RATE_HZ)
    gain = 1.0 + 0.08 * age.normal(size=4)
    ambient = age.uniform(0.0, 2500.0, 4)
    mount_sens = 1.0
    start = START_UNIX
    parts = []
    for k in range(sessions):
        draw = age.random()  # drawn either way: the same ageing with or without re-mounts
        remounted = k > 0 and remount_every is not None and draw < 1.0 / remount_every
        if remounted:
            gain = gain * (1.0 + REMOUNT_GAIN_SD * age.normal(size=4))
            ambient = np.clip(ambient + age.normal(0.0, REMOUNT_AMBIENT_SD, 4), 0.0, None)
            mount_sens *= age.uniform(*REMOUNT_SENSITIVITY)
        sens = mount_sens * (1.0 - SENSITIVITY_DECAY) ** k
        led = (1.0 - LED_DECAY) ** k
        ds = _session(n, sens, gain * led, ambient, rng)
        ds.meta["sessions"] = [
            {
                "source": "spectratac.sim.ageing_skin",
                "session_index": k,
                "started_unix": start,
                "sensitivity": float(sens),
                "led_output": float(led),
                "remounted": bool(remounted),
            }
        ]
        parts.append(ds)
        start += 86400.0 * age.uniform(*SESSION_GAP_DAYS)
    out = concat(parts)
    out.meta["source"] = "spectratac.sim.ageing_skin"
    out.meta["sim"] = {"sessions": sessions, "session_s": session_s, "seed": seed}
    return out


def _session(
    n: int, sens: float, gain: np.ndarray, ambient: np.ndarray, rng: np.random.Generator
) -> Dataset:
    fz, pos, press = _loads(n, rng)
    dist2 = np.sum((pos[:, None, :] - POSITIONS[None, :, :]) ** 2, axis=2)
    reach = np.exp(-dist2 / (2 * REACH_CM**2))
    fast = 1.0 - np.exp(-fz / F_SAT_N)
    slow = np.empty(n)
    a, acc = 1.0 / (CREEP_S * RATE_HZ), 0.0
    for j in range(n):
        acc += a * (fast[j] - acc)
        slow[j] = acc
    dim = sens * DEPTH * reach * ((1 - CREEP_SHARE) * fast + CREEP_SHARE * slow)[:, None]
    t = np.arange(n) / RATE_HZ
    warm = 1.0 + 0.03 * rng.uniform(0.3, 1.0) * np.exp(-t / WARMUP_S)
    light = FULL_COUNTS * (1.0 - dim) * gain * warm[:, None] + ambient
    counts = light * (1.0 + NOISE * rng.normal(size=light.shape))
    return Dataset.generic(counts, fz, CHANNELS, ["Fz"], t=t, press=press)
