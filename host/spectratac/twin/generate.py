"""Fast, vectorised session generation: optical samples plus the 1 kHz F/T stream.

`generate_session(scene, seed=...)` runs the whole forward model for a scene in a few NumPy
passes: the scene's loads on a 5 ms mechanics grid (creep, indentation, shear), the path
transport at 10 ms sub-samples inside each integration window (averaged over the window),
LEDs (duty, droop, flicker), ambient leakage, the VEML3328 electronics, and the reference F/T
reading at 1 kHz with its noise, averaged over each window too. Same seed, same data.

>>> s = generate_session(Scene.single_press(x=4.0, normal_n=6.0), seed=1)
>>> s.counts.shape[1:], s.counts.dtype.name, s.ft.shape[1]
((3, 5), 'uint16', 6)
>>> bool(s.in_contact.any()), sorted(set(s.region.tolist()) - {-1})
(True, [6])
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike, NDArray

from spectratac.twin import optics
from spectratac.twin.electronics import SensorConfig, digitise, expected_counts
from spectratac.twin.errors import TwinError
from spectratac.twin.ft import ft_noise, wrench
from spectratac.twin.mechanics import MechanicsTrack
from spectratac.twin.scene_model import Scene
from spectratac.twin.unit import UnitParams

F64 = NDArray[np.float64]

# All nine LED channels at this duty put the clear channel near 27k counts (41 % of full
# scale) at 50 ms, x1: headroom for the ~+40 % a firm press adds, far above the noise floor.
DEFAULT_WHITE_DUTY = 0.25
MECH_DT_S = 0.005
SUBSAMPLE_S = 0.010
_CHUNK = 8192


def white_step(duty: float = DEFAULT_WHITE_DUTY) -> F64:
    """One LED step with all nine channels (3 LEDs x R, G, B) at `duty`, shape (1, 3, 3)."""
    return np.full((1, 3, 3), float(duty))


def check_led_steps(led_steps: ArrayLike | None) -> F64:
    """Validate an LED sequence: (S, 3, 3) or (3, 3) duties in [0, 1]."""
    if led_steps is None:
        return white_step()
    steps = np.asarray(led_steps, dtype=np.float64)
    if steps.shape == (3, 3):
        steps = steps[None]
    if steps.ndim != 3 or steps.shape[1:] != (3, 3) or steps.shape[0] < 1:
        raise TwinError(
            f"led_steps must have shape (steps, 3 LEDs, 3 colours) or (3, 3), got {steps.shape}"
        )
    if not np.all(np.isfinite(steps)) or steps.min() < 0 or steps.max() > 1:
        raise TwinError("LED duties must be finite and within [0, 1]")
    return steps


@dataclass(frozen=True)
class Session:
    """A generated recording. N optical samples, M F/T samples.

    Optical (one row per integration window): ``t_start``/``t_end`` (s), ``step`` (LED step),
    ``counts`` (N, 3 sensors, 5 channels R G B C IR) uint16, ``saturated`` (N, 3).
    Reference: ``ft_t`` (M,) and ``ft`` (M, 6) at the F/T rate, ``ft_window`` (N, 6) = the F/T
    stream averaged over each window. Truth: ``force`` (N, 3) applied load in board axes
    (Fz = -normal) averaged over the window, ``contact_xy`` (N, 2) mm and ``in_contact`` (N,)
    at the window centre, ``region`` (N,) 1-9 on firm contacts, -1 elsewhere.
    """

    t_start: F64
    t_end: F64
    step: NDArray[np.int16]
    counts: NDArray[np.uint16]
    saturated: NDArray[np.bool_]
    ft_t: F64
    ft: F64
    ft_window: F64
    force: F64
    contact_xy: F64
    in_contact: NDArray[np.bool_]
    region: NDArray[np.int8]
    config: SensorConfig
    led_steps: F64
    seed: int
    scene_name: str
    unit: UnitParams

    def __len__(self) -> int:
        return int(self.t_start.shape[0])

    def raw12(self) -> F64:
        """The paper's 12 inputs: R, G, B, C of sensors 0, 1, 2 (IR excluded), float64."""
        return self.counts[:, :, :4].reshape(-1, 12).astype(np.float64)

    def save_npz(self, path: str | Path) -> None:
        arrays = {
            k: getattr(self, k)
            for k in [
                "t_start",
                "t_end",
                "step",
                "counts",
                "saturated",
                "ft_t",
                "ft",
                "ft_window",
                "force",
                "contact_xy",
                "in_contact",
                "region",
                "led_steps",
            ]
        }
        cfg = self.config
        np.savez_compressed(
            path,
            **arrays,
            seed=self.seed,
            scene_name=self.scene_name,
            integration_ms=cfg.integration_ms,
            gain=cfg.gain,
            dg=cfg.dg,
            sens_low=cfg.sens_low,
        )


def window_schedule(
    duration_s: float, integration_ms: int, n_steps: int, gap_ms: float = 0.0
) -> tuple[F64, F64, NDArray[np.int16]]:
    """Back-to-back integration windows (plus `gap_ms`), cycling through the LED steps."""
    if gap_ms < 0 or not np.isfinite(gap_ms):
        raise TwinError(f"gap_ms must be >= 0, got {gap_ms!r}")
    period = (integration_ms + gap_ms) / 1000.0
    it = integration_ms / 1000.0
    if duration_s < it:
        raise TwinError(f"scene ({duration_s} s) is shorter than one {integration_ms} ms window")
    n = int(np.floor((duration_s - it) / period + 1e-9)) + 1
    t0 = np.arange(n) * period
    return t0, t0 + it, (np.arange(n) % n_steps).astype(np.int16)


def window_transport(
    track: MechanicsTrack, unit: UnitParams, t0: F64, it_s: float, temperature_c: F64
) -> F64:
    """Path transport averaged over each window (N, 3, 3, 3), from 10 ms sub-samples."""
    n_sub = max(1, round(it_s / SUBSAMPLE_S))
    offs = (np.arange(n_sub) + 0.5) * (it_s / n_sub)
    out = np.empty((t0.shape[0], 3, 3, 3))
    for lo in range(0, t0.shape[0], _CHUNK):
        hi = min(lo + _CHUNK, t0.shape[0])
        idx = track.index((t0[lo:hi, None] + offs[None, :]).reshape(-1))
        t = optics.transport(
            unit,
            track.x[idx],
            track.y[idx],
            track.delta[idx],
            track.a[idx],
            track.ux[idx],
            track.uy[idx],
        )
        out[lo:hi] = t.reshape(hi - lo, n_sub, 3, 3, 3).mean(axis=1)
    out *= (1.0 + unit.transport_temp_coeff * (temperature_c - optics.REFERENCE_TEMP_C))[
        :, None, None, None
    ]
    return out


def generate_session(
    scene: Scene,
    seed: int = 0,
    *,
    unit: UnitParams | None = None,
    integration_ms: int = 50,
    gain: float = 1.0,
    dg: int = 1,
    sens_low: bool = False,
    led_steps: ArrayLike | None = None,
    gap_ms: float = 0.0,
    ft_rate_hz: int = 1000,
) -> Session:
    """Simulate a recording of `scene` on one unit (default: the unit drawn from `seed`)."""
    if not isinstance(seed, (int, np.integer)) or seed < 0:
        raise TwinError(f"seed must be a non-negative int, got {seed!r}")
    if not isinstance(ft_rate_hz, (int, np.integer)) or not 10 <= ft_rate_hz <= 100_000:
        raise TwinError(f"ft_rate_hz must be an int in 10..100000, got {ft_rate_hz!r}")
    cfg = SensorConfig(integration_ms=integration_ms, gain=gain, dg=dg, sens_low=sens_low)
    steps = check_led_steps(led_steps)
    unit = unit if unit is not None else UnitParams.from_seed(int(seed))
    unit.validate()
    rng_opt, rng_led, rng_ft = (
        np.random.default_rng(s) for s in np.random.SeedSequence([int(seed), 0x5E55]).spawn(3)
    )
    it_s = integration_ms / 1000.0
    t0, t1, step = window_schedule(scene.duration_s, integration_ms, steps.shape[0], gap_ms)
    tmid = 0.5 * (t0 + t1)
    env = scene.env

    # Optics over each window.
    track = MechanicsTrack.from_scene(scene, unit, dt=MECH_DT_S)
    temp = env.temperature(tmid)
    paths = window_transport(track, unit, t0, it_s, temp)
    mean_duty = float(steps.mean()) * it_s / ((t0[1] - t0[0]) if len(t0) > 1 else it_s)
    junction = temp + optics.led_junction_rise(unit, mean_duty, tmid, env.leds_prewarmed)
    flicker = 1.0 + unit.led_flicker * rng_led.standard_normal((t0.shape[0], 3, 3))
    led = optics.led_intensity(unit, steps[step], junction, flicker)
    ambient = optics.ambient_rates(unit, env.lux(tmid), env.spectrum)
    rates = optics.sensor_rates(unit, paths, led, ambient)
    counts, saturated = digitise(expected_counts(rates, cfg, unit, temp), cfg, unit, rng_opt)

    # Reference F/T stream and its window averages.
    m = int(np.floor(scene.duration_s * ft_rate_hz + 1e-9)) + 1
    ft_t = np.arange(m) / float(ft_rate_hz)
    c = scene.contact(ft_t)
    ti = track.index(ft_t)
    ft = wrench(
        c.fx, c.fy, c.normal, c.x, c.y, track.delta[ti], track.ux[ti], track.uy[ti],
        unit=unit, add_to=ft_noise(m, float(ft_rate_hz), unit, rng_ft),
    )  # fmt: skip
    lo = np.clip(np.ceil(t0 * ft_rate_hz - 1e-9).astype(np.int64), 0, m - 1)
    hi = np.clip(np.ceil(t1 * ft_rate_hz - 1e-9).astype(np.int64), 1, m)
    hi = np.maximum(hi, lo + 1)
    counts_per = (hi - lo).astype(np.float64)
    ft_window = _segment_sums(ft, lo, hi) / counts_per[:, None]
    force = np.empty((t0.shape[0], 3))  # applied load in board axes, whatever the mounting
    for k, column in enumerate((c.fx, c.fy, c.normal)):
        force[:, k] = _segment_sums(column, lo, hi) / counts_per
    force[:, 2] *= -1.0

    cm = scene.contact(tmid)
    return Session(
        t_start=t0,
        t_end=t1,
        step=step,
        counts=counts,
        saturated=saturated,
        ft_t=ft_t,
        ft=ft,
        ft_window=ft_window,
        force=force,
        contact_xy=np.stack([cm.x, cm.y], axis=-1),
        in_contact=cm.in_contact,
        region=cm.region,
        config=cfg,
        led_steps=steps,
        seed=int(seed),
        scene_name=scene.name,
        unit=unit,
    )


def _segment_sums(values: F64, lo: NDArray[np.int64], hi: NDArray[np.int64]) -> F64:
    """Sums of values[lo_i:hi_i] along axis 0 (segments sorted, lo_i < hi_i).

    Disjoint segments (windows at least one F/T sample long) are summed one by one
    (`np.add.reduceat`, one pass, no running total of the whole stream); segments that share
    samples (an F/T slower than the windows) take differences of a running total.
    """
    if lo.shape[0] and bool(np.all(hi[:-1] <= lo[1:])):
        # reduceat sums bounds[k]:bounds[k+1]; even k are the segments, odd k the gaps (or a
        # single sample where a gap is empty), dropped. The last segment runs to the end.
        bounds = np.empty(2 * lo.shape[0], np.int64)
        bounds[0::2], bounds[1::2] = lo, hi
        end = int(hi[-1])
        return np.add.reduceat(values[:end], bounds[:-1], axis=0)[0::2]
    csum = np.zeros((values.shape[0] + 1, *values.shape[1:]))
    np.cumsum(values, axis=0, out=csum[1:])
    return csum[hi] - csum[lo]
