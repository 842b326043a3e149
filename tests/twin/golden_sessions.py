"""Golden sessions: small recordings saved from the twin before its speed-up, so a faster
`generate_session` can be held to computing the same thing (`test_golden_sessions.py`).

The cases cover every branch of the generator: the calibration protocol (presses, shear,
friction cap, drifting light and temperature), a re-mounted and aged unit (tilted F/T, offset
contact, preload, tare offset) with several LED steps, gaps between windows, 100 ms windows and
a 500 Hz F/T stream, a cold start in a warming room with an F/T slower than the windows (their
F/T segments overlap), an empty scene, and a single press at 400 ms x4 that saturates.

Each case keeps every per-window array whole and the F/T stream every `FT_STRIDE`-th row (the
stream's window averages `ft_window` cover every row), which keeps the file small.

The file was written by `python tests/twin/golden_sessions.py` at commit 0d680bf, before the
speed-up; run it again only when the twin's model changes on purpose, and say so in the commit.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
from spectratac.twin import Session, SessionConditions, UnitParams, builtin_scenes, generate_session
from spectratac.twin.builtin_scenes import hard_cases

GOLDEN_PATH = Path(__file__).parent / "data" / "golden_sessions.npz"
FT_STRIDE = 41
WINDOW_FIELDS = (
    "t_start",
    "t_end",
    "step",
    "counts",
    "saturated",
    "ft_window",
    "force",
    "contact_xy",
    "in_contact",
    "region",
)


def _calibration() -> Session:
    return generate_session(builtin_scenes.calibration_session(seed=3, duration_s=30.0), seed=3)


def _remounted() -> Session:
    cond = SessionConditions.draw(unit_seed=2, session_index=3, seed=1)
    scene = cond.apply_scene(builtin_scenes.calibration_session(seed=8, duration_s=20.0))
    steps = np.stack([np.full((3, 3), 0.25), np.eye(3) * 0.6, np.full((3, 3), 0.1)])
    return generate_session(
        scene,
        seed=11,
        unit=cond.apply_unit(UnitParams.from_seed(2)),
        integration_ms=100,
        gain=2.0,
        led_steps=steps,
        gap_ms=10.0,
        ft_rate_hz=500,
    )


def _cold_start() -> Session:
    scene = builtin_scenes.drift_session(duration_s=20.0)
    return generate_session(scene, seed=4, sens_low=True, dg=2, ft_rate_hz=10)


def _idle() -> Session:
    return generate_session(builtin_scenes.idle(duration_s=1.0), seed=0)


def _saturating() -> Session:
    case = hard_cases()["saturation_led"]
    return generate_session(case.scene, seed=6, **case.settings)


CASES: dict[str, Callable[[], Session]] = {
    "calibration": _calibration,
    "remounted": _remounted,
    "cold_start": _cold_start,
    "idle": _idle,
    "saturating": _saturating,
}


def arrays(session: Session) -> Iterator[tuple[str, np.ndarray[Any, Any]]]:
    """The arrays a golden case keeps, by field name."""
    for name in WINDOW_FIELDS:
        yield name, getattr(session, name)
    rows = np.r_[np.arange(0, session.ft.shape[0], FT_STRIDE), session.ft.shape[0] - 1]
    yield "ft_rows", rows
    yield "ft_t", session.ft_t[rows]
    yield "ft", session.ft[rows]


def main() -> None:
    out: dict[str, np.ndarray[Any, Any]] = {}
    for case, make in CASES.items():
        for name, arr in arrays(make()):
            out[f"{case}/{name}"] = arr
    GOLDEN_PATH.parent.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(GOLDEN_PATH, **out)
    print(f"wrote {GOLDEN_PATH} ({GOLDEN_PATH.stat().st_size} bytes)")


if __name__ == "__main__":
    main()
