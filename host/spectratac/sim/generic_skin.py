"""A synthetic "other sensor": a 4-channel LED/photodiode skin at 100 Hz with a reference Fz.

Many recording sessions of presses at random places and loads. Each photodiode sees its LED's
light through the elastomer; a press dims it by an amount that saturates with load and falls
off with the distance from the press, and the elastomer creeps (part of the response lags
the load by `CREEP_S`). Between sessions the skin is taken off and put back: with
`drift=True` every session has its own channel gains, ambient-light offsets and an LED
warm-up within the session, and the gains age slowly from session to session. That is what a
real skin does and what makes random-row validation lie: rows of one session share its
offsets, so a model can learn them, and neighbouring rows at 100 Hz are near-duplicates.
With `drift=False` the sessions are alike (a stationary sensor).

>>> ds = generic_skin(sessions=3, session_s=4.0, seed=1)
>>> ds.input_names, ds.target_names, ds.n, int(ds.session.max()) + 1
(['pd0', 'pd1', 'pd2', 'pd3'], ['Fz'], 1200, 3)
>>> bool(ds.targets.max() > 1.0 and ds.targets.min() >= 0.0)
True
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from spectratac.dataset.schema import Dataset, concat

F64 = NDArray[np.float64]
RATE_HZ = 100.0
CHANNELS = ("pd0", "pd1", "pd2", "pd3")
POSITIONS = np.array([[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]])  # photodiodes, cm
FULL_COUNTS = 30000.0  # a photodiode's reading with no press
DEPTH = 0.45  # largest share of its light a press takes from the nearest photodiode
F_SAT_N = 6.0  # load scale of the saturating dimming
REACH_CM = 1.4  # how far a press's dimming reaches
CREEP_S = 0.8  # time constant of the elastomer's creep
CREEP_SHARE = 0.25  # share of the response that creeps
NOISE = 0.002  # relative read noise
AGEING = 0.006  # relative gain lost per session


def _loads(n: int, rng: np.random.Generator) -> tuple[F64, F64, NDArray[np.int64]]:
    """Fz (N), press position (N, 2) and press id (-1 between presses) of one session."""
    fz = np.zeros(n)
    pos = np.zeros((n, 2))
    press = np.full(n, -1, np.int64)
    i, k = int(rng.integers(20, 80)), 0
    while i < n:
        length = int(rng.integers(80, 250))
        stop = min(n, i + length)
        phase = np.linspace(0.0, np.pi, length)[: stop - i]
        peak = rng.uniform(0.5, 12.0)
        shape = np.sin(phase) ** rng.uniform(0.6, 2.0)
        fz[i:stop] = peak * shape
        pos[i:stop] = rng.uniform(-1.3, 1.3, 2)
        press[i:stop] = k
        k += 1
        i = stop + int(rng.integers(30, 150))
    return fz, pos, press


def _session(n: int, index: int, drift: bool, rng: np.random.Generator) -> Dataset:
    fz, pos, press = _loads(n, rng)
    dist2 = np.sum((pos[:, None, :] - POSITIONS[None, :, :]) ** 2, axis=2)
    reach = np.exp(-dist2 / (2 * REACH_CM**2))  # (N, 4)
    fast = 1.0 - np.exp(-fz / F_SAT_N)
    slow = np.empty(n)  # the creeping part follows `fast` with a lag
    a, acc = 1.0 / (CREEP_S * RATE_HZ), 0.0
    for j in range(n):
        acc += a * (fast[j] - acc)
        slow[j] = acc
    dim = DEPTH * reach * ((1 - CREEP_SHARE) * fast + CREEP_SHARE * slow)[:, None]
    light = FULL_COUNTS * (1.0 - dim)
    if drift:
        gain = (1.0 + 0.08 * rng.normal(size=4)) * (1.0 - AGEING * index)
        ambient = rng.uniform(0.0, 2500.0, 4)
        t = np.arange(n) / RATE_HZ
        warm = 1.0 + 0.03 * rng.uniform(0.3, 1.0) * np.exp(-t / 20.0)  # LED warm-up
        light = light * gain * warm[:, None] + ambient
    counts = light * (1.0 + NOISE * rng.normal(size=light.shape))
    t = np.arange(n) / RATE_HZ
    return Dataset.generic(counts, fz, CHANNELS, ["Fz"], t=t, press=press)


def generic_skin(
    sessions: int = 36, session_s: float = 40.0, seed: int = 0, drift: bool = True
) -> Dataset:
    """`sessions` sessions of `session_s` seconds each at 100 Hz (see the module docstring),
    in recording order (session 0 first: train on the first ones, test on later ones)."""
    rng = np.random.default_rng(seed)
    n = round(session_s * RATE_HZ)
    parts = [_session(n, i, drift, rng) for i in range(sessions)]
    ds = concat(parts)
    ds.meta["source"] = "spectratac.sim.generic_skin"
    ds.meta["sim"] = {"sessions": sessions, "session_s": session_s, "seed": seed, "drift": drift}
    return ds
