"""A dataset straight from a twin session (no device, no recording): for benchmarks over
sensor configurations and for tests. Recorded sessions go through `spectratac dataset build`.

>>> from spectratac.twin import Scene, generate_session
>>> scene = Scene.single_press(x=4.0, normal_n=6.0)
>>> ds = from_twin_session(generate_session(scene, seed=1), scene)
>>> ds.meta["labels"], ds.targets.shape[1], int(ds.press.max())
('scene', 6, 0)
"""

from __future__ import annotations

import numpy as np

from spectratac.dataset.schema import FT_NAMES, SPECTRATAC_INPUTS, Dataset
from spectratac.twin.generate import Session
from spectratac.twin.scene_model import Scene


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
