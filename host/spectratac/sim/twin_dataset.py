"""Datasets straight from the twin (no device, no recording): one session for benchmarks over
sensor configurations and for tests, or a population of units each recorded in several
sessions (`population`) for decoders that must generalise to units and sessions they never
saw. Recorded sessions go through `spectratac dataset build`.

>>> from spectratac.twin import Scene, generate_session
>>> scene = Scene.single_press(x=4.0, normal_n=6.0)
>>> ds = from_twin_session(generate_session(scene, seed=1), scene)
>>> ds.meta["labels"], ds.targets.shape[1], int(ds.press.max())
('scene', 6, 0)
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from spectratac.dataset.schema import FT_NAMES, SPECTRATAC_INPUTS, Dataset, concat
from spectratac.sim.named_scenes import POPULATION_SCENES, named_scene
from spectratac.twin.errors import TwinError
from spectratac.twin.generate import Session, generate_session
from spectratac.twin.scene_model import Scene
from spectratac.twin.session import SessionConditions
from spectratac.twin.unit import UnitParams


def twin_config(session: Session) -> dict[str, object]:
    """The sensor configuration a twin session was generated under, as a device reports it."""
    cfg = session.config
    return {
        "integration_ms": int(cfg.integration_ms),
        "gain": float(cfg.gain),
        "digital_gain": int(cfg.dg),
        "sensitivity": "low" if cfg.sens_low else "high",
        "leds": np.rint(session.led_steps * 1000).astype(int).tolist(),
        "settle_us": 0,
    }


def from_twin_session(session: Session, scene: Scene | None = None) -> Dataset:
    """Targets are the F/T stream averaged over each window (what a reference sensor gives)."""
    n = len(session)
    tmid = 0.5 * (session.t_start + session.t_end)
    arrays = {
        "inputs": session.raw12(),
        "targets": session.ft_window.copy(),
        "target_valid": np.ones(n, bool),
        "region": session.region,
        "in_contact": session.in_contact,
        "t_start": session.t_start,
        "t_end": session.t_end,
        "step": session.step,
        "config_id": np.ones(n),
        "session": np.zeros(n),
        "press": scene.press_index(tmid) if scene is not None else np.full(n, -1),
        "counts": session.counts,
        "status": np.where(session.saturated, 0x01, 0),  # SENSOR_SATURATED
    }
    meta = {
        "kind": "spectratac",
        "input_names": list(SPECTRATAC_INPUTS),
        "target_names": list(FT_NAMES),
        "unit_id": f"twin-{session.seed}",
        "firmware_version": None,
        "protocol_version": None,
        "definition_hash": None,
        "config": twin_config(session),
        "sessions": [{"source": "twin", "scene": session.scene_name, "seed": session.seed, "n": n}],
        "labels": "scene",
    }
    return Dataset(arrays, meta)


def population(
    units: Sequence[int],
    sessions_per_unit: int,
    session_s: float,
    seed: int = 0,
    scene: str = "calibration",
    progress: Callable[[int, int], None] | None = None,
) -> Dataset:
    """Units x sessions of the twin, one dataset: session i of ``meta["sessions"]`` is unit
    ``meta["sessions"][i]["unit"]`` (a `UnitParams.from_seed` seed) recorded for `session_s`
    seconds under `SessionConditions.draw(unit, session_index, seed)` (re-mounting, room
    temperature, ageing, its own presses). ``dataset.session`` numbers the sessions;
    `progress(done, total)` is called after each session. Same arguments, same dataset.

    >>> ds = population([0, 1], sessions_per_unit=2, session_s=20.0)
    >>> sorted(set(ds.session.tolist())), [s["unit"] for s in ds.meta["sessions"]]
    ([0, 1, 2, 3], [0, 0, 1, 1])
    >>> ds.meta["sessions"][3]["session_index"], ds.meta["sessions"][3]["unit_id"]
    (1, 'twin-1')
    """
    unit_seeds = [_unit_seed(u) for u in units]
    if not unit_seeds or len(set(unit_seeds)) != len(unit_seeds):
        raise TwinError(f"units must be distinct unit seeds, at least one, got {list(units)!r}")
    if isinstance(sessions_per_unit, bool) or not isinstance(sessions_per_unit, int):
        raise TwinError(f"sessions_per_unit must be an int >= 1, got {sessions_per_unit!r}")
    if sessions_per_unit < 1:
        raise TwinError(f"sessions_per_unit must be >= 1, got {sessions_per_unit}")
    if not (np.isfinite(session_s) and session_s >= 5.0):
        raise TwinError(f"session_s must be >= 5 s, got {session_s!r}")
    if scene not in POPULATION_SCENES:
        raise TwinError(f"scene must be one of {sorted(POPULATION_SCENES)}, got {scene!r}")
    total = len(unit_seeds) * sessions_per_unit
    parts: list[Dataset] = []
    for unit_seed in unit_seeds:
        unit = UnitParams.from_seed(unit_seed)
        for k in range(sessions_per_unit):
            cond = SessionConditions.draw(unit_seed, k, seed)
            seconds = float(session_s)
            sc = cond.apply_scene(
                named_scene(scene, cond.scene_seed, seconds, open_ended_s=seconds)
            )
            run = generate_session(sc, seed=cond.noise_seed, unit=cond.apply_unit(unit))
            ds = from_twin_session(run, sc)
            ds.meta["unit_id"] = f"twin-{unit_seed}"
            ds.meta["sessions"][0].update(
                unit=unit_seed,
                unit_id=f"twin-{unit_seed}",
                session_index=k,
                conditions=cond.to_dict(),
            )
            parts.append(ds)
            if progress is not None:
                progress(len(parts), total)
    out = concat(parts)
    out.meta["unit_id"] = "twin-population"
    out.meta["units"] = unit_seeds
    return out


def _unit_seed(u: object) -> int:
    if isinstance(u, bool) or not isinstance(u, (int, np.integer)) or u < 0:
        raise TwinError(f"unit seeds must be non-negative ints, got {u!r}")
    return int(u)
