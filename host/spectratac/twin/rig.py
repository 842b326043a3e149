"""The twin on a bench: one scene, one unit, an LED duty timeline, three VEML3328 models and
the reference F/T sensor, all answering at arbitrary (microsecond) times.

The simulated device runs the real firmware against `rig.sensors[k]` (register level) and
sets LED duties through `set_led_duties`; a window's counts average the optics over the
window and the LED duties over the exact timeline inside it (the transport is averaged over
10 ms sub-samples and multiplied by the time-weighted mean duty; the correlation between a
duty change and a contact change within one window is neglected). The expensive optical part
is cached per window, so the three sensors triggered together share it.

>>> from spectratac.twin import scenes
>>> rig = TwinRig(scenes.single_press(6, 5.0), seed=1)
>>> rig.set_led_duties(0, np.full((3, 3), 0.25))
>>> counts, sat = rig.read_window(0, 0, 50_000, SensorConfig())
>>> counts.shape, counts.dtype.name, bool(sat)
((5,), 'uint16', False)
>>> rig.ft(np.array([0.0, 2.0])).shape
(2, 6)
"""

from __future__ import annotations

import bisect

import numpy as np
from numpy.typing import ArrayLike, NDArray

from spectratac.twin import optics
from spectratac.twin.electronics import SensorConfig, digitise, expected_counts
from spectratac.twin.errors import TwinError
from spectratac.twin.ft import wrench
from spectratac.twin.generate import MECH_DT_S, SUBSAMPLE_S
from spectratac.twin.mechanics import MechanicsTrack
from spectratac.twin.scene import ContactState, Scene
from spectratac.twin.unit import UnitParams
from spectratac.twin.veml3328 import Veml3328

F64 = NDArray[np.float64]
_CACHE_MAX = 64


class TwinRig:
    """Scene + unit + LED timeline + three `Veml3328` register models + reference F/T."""

    def __init__(self, scene: Scene, unit: UnitParams | None = None, seed: int = 0) -> None:
        if not isinstance(seed, (int, np.integer)) or seed < 0:
            raise TwinError(f"seed must be a non-negative int, got {seed!r}")
        self.scene = scene
        self.unit = unit if unit is not None else UnitParams.from_seed(int(seed))
        self.unit.validate()
        self.track = MechanicsTrack.from_scene(scene, self.unit, dt=MECH_DT_S)
        seqs = np.random.SeedSequence([int(seed), 0x121]).spawn(5)
        self._rng_sensor = [np.random.default_rng(s) for s in seqs[:3]]
        self._rng_led = np.random.default_rng(seqs[3])
        self._rng_ft = np.random.default_rng(seqs[4])
        # LED timeline: piecewise-constant duties from each change time (µs); LEDs start off.
        self._times: list[int] = [0]
        self._duties: list[F64] = [np.zeros((3, 3))]
        self._heat: list[float] = [0.0]  # junction rise (°C) at each change time
        self._heat_set = False
        self._paths: dict[tuple[int, int], F64] = {}
        self._rates_cache: dict[tuple[int, int, int], tuple[F64, float]] = {}
        seconds = int(np.ceil(scene.duration_s)) + 3600
        a = np.exp(-1.0 / self.unit.ft_bias_tau_s)
        steps = self._rng_ft.standard_normal((seconds, 6)) * self.unit.ft_bias_std
        steps *= np.sqrt(1.0 - a * a)
        self._ft_bias = np.zeros((seconds, 6))
        for i in range(1, seconds):
            self._ft_bias[i] = a * self._ft_bias[i - 1] + steps[i]
        self.sensors: tuple[Veml3328, Veml3328, Veml3328] = (
            Veml3328(self, 0),
            Veml3328(self, 1),
            Veml3328(self, 2),
        )

    # --- LEDs -----------------------------------------------------------------------------
    def set_led_duties(self, now_us: int, duties: ArrayLike) -> None:
        """From `now_us` on, LED j colour c runs at duty[j, c] in [0, 1] (shape (3, 3))."""
        d = np.asarray(duties, dtype=np.float64)
        if d.shape != (3, 3) or not np.all(np.isfinite(d)) or d.min() < 0 or d.max() > 1:
            raise TwinError("LED duties must be a (3 LEDs, 3 colours R G B) array in [0, 1]")
        now = int(now_us)
        if now < self._times[-1]:
            raise TwinError(
                f"LED duty change at {now} us is before the previous one at {self._times[-1]} us;"
                " times must not go backwards"
            )
        unit = self.unit
        if not self._heat_set and self.scene.env.leds_prewarmed:
            # A pre-warmed rig starts in thermal equilibrium with its first LED setting.
            self._heat[-1] = unit.led_self_heating_c * float(d.mean())
        self._heat_set = True
        heat = self._junction_rise(now)
        if now == self._times[-1]:
            self._duties[-1] = d.copy()
            self._heat[-1] = heat
        else:
            self._times.append(now)
            self._duties.append(d.copy())
            self._heat.append(heat)

    def _junction_rise(self, t_us: int) -> float:
        i = bisect.bisect_right(self._times, t_us) - 1
        target = self.unit.led_self_heating_c * float(self._duties[i].mean())
        dt = (t_us - self._times[i]) * 1e-6
        return target + (self._heat[i] - target) * float(np.exp(-dt / self.unit.led_thermal_tau_s))

    def mean_duty(self, t0_us: int, t1_us: int) -> F64:
        """Time-weighted mean LED duty (3, 3) over [t0, t1) from the timeline."""
        if t1_us <= t0_us:
            raise TwinError("window end must be after its start")
        i = bisect.bisect_right(self._times, t0_us) - 1
        acc = np.zeros((3, 3))
        t = t0_us
        while t < t1_us:
            nxt = self._times[i + 1] if i + 1 < len(self._times) else t1_us
            end = min(nxt, t1_us)
            acc += self._duties[i] * (end - t)
            t = end
            i += 1
        return acc / (t1_us - t0_us)

    # --- optics -----------------------------------------------------------------------------
    def _window_paths(self, t0_us: int, t1_us: int) -> F64:
        it = (t1_us - t0_us) * 1e-6
        n_sub = max(1, round(it / SUBSAMPLE_S))
        ts = t0_us * 1e-6 + (np.arange(n_sub) + 0.5) * (it / n_sub)
        idx = self.track.index(ts)
        key = (int(idx[0]), int(idx[-1]))
        paths = self._paths.get(key)
        if paths is None:
            tr = self.track
            t = optics.transport(
                self.unit, tr.x[idx], tr.y[idx], tr.delta[idx], tr.a[idx], tr.ux[idx], tr.uy[idx]
            )
            paths = t.mean(axis=0)
            if len(self._paths) >= _CACHE_MAX:
                self._paths.pop(next(iter(self._paths)))
            self._paths[key] = paths
        return paths

    def window_rates(self, t0_us: int, t1_us: int) -> tuple[F64, float]:
        """Reference count rates (3 sensors, 5 channels) over a window, and the temperature.

        Cached per window and LED timeline: the firmware triggers the three sensors together,
        so they share one evaluation and one draw of LED flicker (the LEDs are common to all
        three, so a shared draw is also the physical behaviour)."""
        key = (t0_us, t1_us, len(self._times))
        hit = self._rates_cache.get(key)
        if hit is None:
            hit = self._window_rates(t0_us, t1_us)
            if len(self._rates_cache) >= 8:
                self._rates_cache.pop(next(iter(self._rates_cache)))
            self._rates_cache[key] = hit
        return hit

    def _window_rates(self, t0_us: int, t1_us: int) -> tuple[F64, float]:
        tmid = np.array([0.5 * (t0_us + t1_us) * 1e-6])
        env = self.scene.env
        temp = float(env.temperature(tmid)[0])
        paths = self._window_paths(t0_us, t1_us) * (
            1.0 + self.unit.transport_temp_coeff * (temp - optics.REFERENCE_TEMP_C)
        )
        junction = temp + self._junction_rise(int(0.5 * (t0_us + t1_us)))
        flicker = 1.0 + self.unit.led_flicker * self._rng_led.standard_normal((3, 3))
        led = optics.led_intensity(self.unit, self.mean_duty(t0_us, t1_us), junction, flicker)
        ambient = optics.ambient_rates(self.unit, env.lux(tmid), env.spectrum)
        return optics.sensor_rates(self.unit, paths[None], led[None], ambient)[0], temp

    def read_window(
        self, k: int, t0_us: int, t1_us: int, cfg: SensorConfig, *, sd_als: bool = False
    ) -> tuple[NDArray[np.uint16], bool]:
        """Counts (5,) uint16 of sensor k for one integration window, and its saturation flag.
        With `sd_als` only G, C and IR are powered (R and B read 0)."""
        rates, temp = self.window_rates(t0_us, t1_us)
        analog = expected_counts(rates, cfg, self.unit, np.asarray(temp))[k]
        counts, sat = digitise(analog, cfg, self.unit, self._rng_sensor[k])
        if sd_als:
            counts[[0, 2]] = 0
        return counts, bool(sat)

    # --- truth and reference ---------------------------------------------------------------
    def contact(self, t_seconds: ArrayLike) -> ContactState:
        return self.scene.contact(np.asarray(t_seconds, dtype=np.float64))

    def ft(self, t_seconds: ArrayLike) -> F64:
        """Reference F/T readings (N, 6) at the given times (s): wrench + noise + bias."""
        t = np.atleast_1d(np.asarray(t_seconds, dtype=np.float64))
        if not np.all(np.isfinite(t)) or np.any(t < 0):
            raise TwinError("F/T query times must be finite and >= 0 s")
        c = self.scene.contact(t)
        i = self.track.index(t)
        tr = self.track
        w = wrench(c.fx, c.fy, c.normal, c.x, c.y, tr.delta[i], tr.ux[i], tr.uy[i], unit=self.unit)
        noise = self._rng_ft.standard_normal(w.shape) * self.unit.ft_noise
        bias = self._ft_bias[np.minimum(t.astype(np.int64), self._ft_bias.shape[0] - 1)]
        return w + noise + bias
