"""Built-in scenes: idle, single press, a tour of the regions, the paper's calibration
session, drift, hard cases. `spectratac.sim.named_scenes` names them for sim:// URLs and the CLI.

>>> cal = calibration_session(seed=0)
>>> round(cal.duration_s / 60), 500 < len(cal.presses) < 900
(50, True)
>>> sorted(hard_cases())
['near_dark', 'over_range', 'rim_contact', 'saturation_ambient', 'saturation_led']
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from spectratac.hardware.generated import vocabulary as vocab
from spectratac.twin.errors import TwinError
from spectratac.twin.geometry import (
    ACTIVE_RADIUS_MM,
    CENTER_RADIUS_MM,
    SECTOR_CENTRE_DEG,
    region_centre,
    region_of,
)
from spectratac.twin.scene_model import Environment, Presses, Scene

# Calibration protocol (paper: ~60,000 samples in ~50 min at 20 Hz, nine regions, normal up
# to ~10 N, shear up to ~+-3 N). Ranges below are the operator's press statistics.
CAL_DURATION_S = 3000.0
CAL_NORMAL_N = (0.8, 10.0)
CAL_SHEAR_N = 3.0
CAL_RISE_S = (0.3, 1.0)
CAL_HOLD_S = (0.5, 3.0)
CAL_FALL_S = (0.3, 1.0)
CAL_GAP_S = (0.3, 2.0)
CAL_INDENTER_MM = (2.5, 6.5)  # fingertip / probe tip radii vary press to press
CAL_RIM_FRACTION = 0.02  # presses that land on the clamped rim: F/T only, label -1
REGION_MARGIN_MM = 0.3  # operators aim inside a region, not on its border
AIM_SCATTER_MM = 0.8  # scatter of presses around a region's representative point
FRICTION = 1.0  # silicone skin against a fingertip / rubber probe


def idle(duration_s: float = 10.0, env: Environment | None = None) -> Scene:
    """No contact; office light."""
    return Scene("idle", float(duration_s), Presses.empty(), env or Environment())


def single_press(
    region: int = vocab.CENTRE_REGION,
    normal_n: float = 5.0,
    shear_n: tuple[float, float] = (0.0, 0.0),
    **kwargs: Any,
) -> Scene:
    """One press at the centre of `region` (1-9); see `Scene.single_press` for timing."""
    x, y = region_centre(region)
    return Scene.single_press(x=x, y=y, normal_n=normal_n, shear_n=shear_n, **kwargs)


def region_tour(period_s: float = 10.0 / 9.0, normal_n: float = 4.0, laps: int = 100) -> Scene:
    """Presses every region in turn (1, 2, ...), one per `period_s`, repeating `laps` times."""
    n = len(vocab.REGIONS) * laps
    centres = np.array([region_centre(r) for r in vocab.REGIONS] * laps)
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


def sample_in_region(rng: np.random.Generator, regions: np.ndarray) -> tuple[np.ndarray, ...]:
    """Press positions around each region's representative point (the operator aims at it,
    with `AIM_SCATTER_MM` scatter), kept `REGION_MARGIN_MM` inside the region's borders."""
    n = regions.shape[0]
    cx = np.array([region_centre(int(g))[0] for g in regions])
    cy = np.array([region_centre(int(g))[1] for g in regions])
    x = cx + rng.normal(0.0, AIM_SCATTER_MM, n)
    y = cy + rng.normal(0.0, AIM_SCATTER_MM, n)
    ux, uy = _uniform_in_region(rng, regions)
    inside = region_of(x, y) == regions
    inside &= (
        region_of(
            x * (1 + REGION_MARGIN_MM / np.maximum(np.hypot(x, y), 1e-6)),
            y * (1 + REGION_MARGIN_MM / np.maximum(np.hypot(x, y), 1e-6)),
        )
        == regions
    )
    return np.where(inside, x, ux), np.where(inside, y, uy)


def _uniform_in_region(rng: np.random.Generator, regions: np.ndarray) -> tuple[np.ndarray, ...]:
    """Uniform-by-area positions inside each region, `REGION_MARGIN_MM` from its borders."""
    n = regions.shape[0]
    m = REGION_MARGIN_MM
    r_out = ACTIVE_RADIUS_MM - m
    r_in = CENTER_RADIUS_MM + m
    r_ring = np.sqrt(rng.uniform(r_in**2, r_out**2, n))
    half = np.deg2rad(180.0 / len(vocab.RING_REGIONS)) - m / r_ring  # half a sector
    centre = np.deg2rad(np.array([SECTOR_CENTRE_DEG.get(int(g), 0.0) for g in regions]))
    ang = centre + rng.uniform(-1.0, 1.0, n) * half
    r_c = (CENTER_RADIUS_MM - m) * np.sqrt(rng.uniform(0, 1, n))
    ang_c = rng.uniform(0, 2 * np.pi, n)
    is_c = regions == vocab.CENTRE_REGION
    r = np.where(is_c, r_c, r_ring)
    a = np.where(is_c, ang_c, ang)
    return r * np.cos(a), r * np.sin(a)


def calibration_session(seed: int = 0, duration_s: float = CAL_DURATION_S) -> Scene:
    """The paper's calibration protocol: randomised presses over the nine regions with
    holds, releases and idle gaps; slowly varying office light and room temperature."""
    if duration_s < 5:
        raise TwinError("calibration duration_s must be >= 5 s")
    rng = np.random.default_rng([int(seed), 0xCA1])
    cap = int(duration_s / 1.2) + 4
    rise = rng.uniform(*CAL_RISE_S, cap)
    hold = rng.uniform(*CAL_HOLD_S, cap)
    fall = rng.uniform(*CAL_FALL_S, cap)
    gap = rng.uniform(*CAL_GAP_S, cap)
    start = 1.0 + np.concatenate([[0.0], np.cumsum(rise + hold + fall + gap)[:-1]])
    keep = start + rise + hold + fall <= duration_s - 0.5
    regions = rng.integers(1, vocab.N_REGIONS + 1, cap)
    x, y = sample_in_region(rng, regions)
    rim = rng.uniform(0, 1, cap) < CAL_RIM_FRACTION
    rim_r = rng.uniform(ACTIVE_RADIUS_MM + 0.3, 9.2, cap)
    rim_a = rng.uniform(0, 2 * np.pi, cap)
    x = np.where(rim, rim_r * np.cos(rim_a), x)
    y = np.where(rim, rim_r * np.sin(rim_a), y)
    total = rise + hold + fall
    presses = Presses(
        start=start,
        rise=rise,
        hold=hold,
        fall=fall,
        x=x,
        y=y,
        normal_peak=rng.uniform(*CAL_NORMAL_N, cap),
        normal_mod_depth=rng.uniform(0.0, 0.25, cap),
        normal_mod_hz=rng.uniform(0.2, 1.0, cap),
        normal_mod_phase=rng.uniform(0, 2 * np.pi, cap),
        shear_amp=rng.uniform(-CAL_SHEAR_N, CAL_SHEAR_N, (cap, 2)),
        shear_hz=rng.uniform(0.5, 1.5, cap) / total,
        shear_phase=rng.uniform(0, 2 * np.pi, (cap, 2)),
        indenter_radius_mm=rng.uniform(*CAL_INDENTER_MM, cap),
    )
    presses = Presses(**{k: v[keep] for k, v in presses.__dict__.items()})
    knots = np.arange(0.0, duration_s + 60.0, 60.0)
    env = Environment(
        times=knots,
        ambient_lux=300.0 * (1.0 + 0.2 * rng.uniform(-1, 1, knots.shape[0])),
        temperature_c=25.0 + np.cumsum(rng.normal(0, 0.1, knots.shape[0])),
        spectrum="led",
        leds_prewarmed=True,
    )
    return Scene("calibration", float(duration_s), presses, env, friction=FRICTION)


def drift_session(duration_s: float = 1200.0) -> Scene:
    """No contact; the LEDs switch on cold at t=0 (warm-up) while the room warms 22 -> 30 °C."""
    env = Environment(
        times=np.array([0.0, 0.1 * duration_s, 0.9 * duration_s, duration_s]),
        ambient_lux=np.full(4, 300.0),
        temperature_c=np.array([22.0, 22.0, 30.0, 30.0]),
        spectrum="fluorescent",
        leds_prewarmed=False,
    )
    return Scene("drift", float(duration_s), Presses.empty(), env)


@dataclass(frozen=True)
class HardCase:
    """A stress scene and the acquisition settings (generate_session keywords) it needs."""

    scene: Scene
    settings: dict[str, Any] = field(default_factory=dict)
    expect_saturation: bool = False


def _press_train(
    name: str,
    xy: list[tuple[float, float]],
    normal: float,
    shear: float,
    env: Environment | None = None,
) -> Scene:
    n = len(xy)
    arr = np.asarray(xy, dtype=np.float64)
    start = 0.5 + 2.5 * np.arange(n)
    presses = Presses(
        start=start,
        rise=np.full(n, 0.4),
        hold=np.full(n, 1.2),
        fall=np.full(n, 0.4),
        x=arr[:, 0],
        y=arr[:, 1],
        normal_peak=np.full(n, normal),
        normal_mod_depth=np.zeros(n),
        normal_mod_hz=np.zeros(n),
        normal_mod_phase=np.zeros(n),
        shear_amp=np.tile([shear, -shear], (n, 1)),
        shear_hz=np.full(n, 0.5),
        shear_phase=np.zeros((n, 2)),
        indenter_radius_mm=np.full(n, 4.0),
    )
    return Scene(name, float(start[-1] + 2.5), presses, env or Environment(), friction=10.0)


def hard_cases() -> dict[str, HardCase]:
    """Stress scenes: saturation (sunlight, and full LED duty at 400 ms x4), near darkness,
    contact on the rim, and loads far beyond the calibrated range."""
    sun = Environment(ambient_lux=np.array([100_000.0]), spectrum="sunlight")
    dark = Environment(ambient_lux=np.array([0.0]))
    rim = [(9.2 * np.cos(a), 9.2 * np.sin(a)) for a in np.deg2rad([0, 60, 120, 200, 300])]
    ring = [region_centre(r) for r in (2, 5, 7)]
    return {
        "saturation_ambient": HardCase(
            _press_train("saturation_ambient", ring, 5.0, 1.0, sun),
            {"integration_ms": 400, "gain": 4.0, "dg": 4, "led_steps": np.zeros((3, 3))},
            expect_saturation=True,
        ),
        "saturation_led": HardCase(
            _press_train("saturation_led", ring, 8.0, 2.0),
            {"integration_ms": 400, "gain": 4.0, "led_steps": np.ones((3, 3))},
            expect_saturation=True,
        ),
        "near_dark": HardCase(
            _press_train("near_dark", ring, 5.0, 1.0, dark),
            {"gain": 0.5, "sens_low": True, "led_steps": np.full((3, 3), 0.002)},
        ),
        "rim_contact": HardCase(_press_train("rim_contact", rim, 6.0, 1.5)),
        "over_range": HardCase(_press_train("over_range", ring, 30.0, 8.0)),
    }
