"""The twin on a bench: one scene, one unit, an LED duty timeline, three VEML3328 models and
the reference F/T sensor, all answering at arbitrary (microsecond) times.

The simulated device runs the real firmware against register-level sensor models (the
native mirror of `rig.sensors[k]`, which asks `read_window` for each completed window's
counts) and sets LED duties through `set_led_duties`; a window's counts average the optics
over the window and the LED duties over the exact timeline inside it (the transport is
averaged over 10 ms sub-samples and multiplied by the time-weighted mean duty; the
correlation between a duty change and a contact change within one window is neglected).
A window's optics (count rates, temperature, one draw of LED flicker) are evaluated once
and shared by the three sensors triggered together (kept for the last `SHARED_WINDOWS`
windows evaluated).

Lookahead: when windows repeat with a constant period under an unchanged LED timeline (a
device streaming one LED step), the rig evaluates the next windows in one vectorised batch
(a plan) and hands them out as they are asked for. Every random draw comes from per-stream
buffers in the order one-window-at-a-time evaluation would use (PCG64 gives the same values
drawn in blocks), and a plan entry is used only while it is exactly what the per-window path
would compute, so the counts are identical with and without it (`lookahead=False`).

>>> from spectratac.twin import builtin_scenes
>>> rig = TwinRig(builtin_scenes.single_press(6, 5.0), seed=1)
>>> rig.set_led_duties(0, np.full((3, 3), 0.25))
>>> counts, sat = rig.read_window(0, 0, 50_000, SensorConfig())
>>> counts.shape, counts.dtype.name, bool(sat)
((5,), 'uint16', False)
>>> rig.ft(np.array([0.0, 2.0])).shape
(2, 6)
"""

from __future__ import annotations

import bisect
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from spectratac.twin import optics
from spectratac.twin.electronics import SensorConfig, digitise_noise, expected_counts
from spectratac.twin.errors import TwinError
from spectratac.twin.ft import wrench
from spectratac.twin.generate import MECH_DT_S, SUBSAMPLE_S
from spectratac.twin.mechanics import MechanicsTrack
from spectratac.twin.scene_model import ContactState, Scene
from spectratac.twin.unit import UnitParams
from spectratac.twin.veml3328 import Veml3328

F64 = NDArray[np.float64]
I64 = NDArray[np.int64]
Window = tuple[F64, float]  # count rates (3 sensors, 5 channels) and temperature (°C)
_PATHS_MAX = 512  # cached transports by sub-sample indices (speed only: a pure function)
SHARED_WINDOWS = 8  # windows whose optics later reads reuse (= STAC_SIM_SHARED_WINDOWS)
PLAN_MIN, PLAN_MAX = 8, 256  # plan lengths: doubled while plans are used up (native PLAN_MAX)


class _Normals:
    """Standard normals of one generator in rows of `width`, drawn in blocks and handed out in
    stream order; `pos` is the next row to consume, rows ahead can be read without consuming."""

    def __init__(self, rng: np.random.Generator, width: int) -> None:
        self._rng = rng
        self._width = width
        self._buf = np.empty((0, width))
        self._first = 0  # stream index of _buf[0]
        self.pos = 0

    def rows(self, start: int, n: int) -> F64:
        end = start + n
        have = self._first + self._buf.shape[0]
        if end > have:
            keep = self._buf[self.pos - self._first :]
            more = self._rng.standard_normal((max(end - have, 64), self._width))
            self._buf = np.concatenate([keep, more])
            self._first = self.pos
        return self._buf[start - self._first : end - self._first]

    def take(self) -> F64:
        row = self.rows(self.pos, 1)[0]
        self.pos += 1
        return row


@dataclass
class WindowPlan:
    """Windows evaluated ahead: `evaluated` of them handed out so far, `next[k]` is the entry
    sensor k reads next. Entry j of sensor k uses row sensor_base[k] + j of its noise."""

    keys: list[tuple[int, int, int]]  # (t0, t1, LED timeline version)
    windows: list[Window]
    cfg: SensorConfig
    sd_als: bool
    counts: NDArray[np.uint16]  # (n, 3 sensors, 5)
    saturated: NDArray[np.bool_]  # (n, 3)
    led_base: int
    sensor_base: list[int]
    next: list[int] = field(default_factory=lambda: [0, 0, 0])
    evaluated: int = 0

    @property
    def n(self) -> int:
        return len(self.keys)


class TwinRig:
    """Scene + unit + LED timeline + three `Veml3328` register models + reference F/T."""

    def __init__(
        self,
        scene: Scene,
        unit: UnitParams | None = None,
        seed: int = 0,
        *,
        lookahead: bool = True,
    ) -> None:
        if not isinstance(seed, (int, np.integer)) or seed < 0:
            raise TwinError(f"seed must be a non-negative int, got {seed!r}")
        self.scene = scene
        self.unit = unit if unit is not None else UnitParams.from_seed(int(seed))
        self.unit.validate()
        self.track = MechanicsTrack.from_scene(scene, self.unit, dt=MECH_DT_S)
        self.lookahead = lookahead
        seqs = np.random.SeedSequence([int(seed), 0x121]).spawn(5)
        self._noise_sensor = [_Normals(np.random.default_rng(s), 5) for s in seqs[:3]]
        self._noise_led = _Normals(np.random.default_rng(seqs[3]), 9)
        self._rng_ft = np.random.default_rng(seqs[4])
        # LED timeline: piecewise-constant duties from each change time (µs); LEDs start off.
        self._times: list[int] = [0]
        self._duties: list[F64] = [np.zeros((3, 3))]
        self._heat: list[float] = [0.0]  # junction rise (°C) at each change time
        self._target: list[float] = [0.0]  # steady junction rise of each segment's duties
        self._heat_set = False
        self._version = 0  # bumped by every LED change: part of every window's key
        self._timeline_arrays: tuple[int, I64, F64, F64] | None = None
        self._paths: dict[bytes, F64] = {}
        self._rates_cache: dict[tuple[int, int, int], Window] = {}
        self._last_eval: tuple[int, int, int] | None = None  # the latest window evaluated
        self._last_period: int | None = None  # its distance from the one before
        self.plan: WindowPlan | None = None
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
        target = unit.led_self_heating_c * float(d.mean())
        if now == self._times[-1]:
            self._duties[-1] = d.copy()
            self._heat[-1] = heat
            self._target[-1] = target
        else:
            self._times.append(now)
            self._duties.append(d.copy())
            self._heat.append(heat)
            self._target.append(target)
        self._version += 1

    def _junction_rise(self, t_us: int) -> float:
        i = bisect.bisect_right(self._times, t_us) - 1
        target = self._target[i]
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

    def _timeline(self) -> tuple[I64, F64, F64]:
        """The LED timeline as arrays (change times, heat, target) for batch evaluation."""
        cached = self._timeline_arrays
        if cached is None or cached[0] != self._version:
            cached = (
                self._version,
                np.array(self._times, dtype=np.int64),
                np.array(self._heat),
                np.array(self._target),
            )
            self._timeline_arrays = cached
        return cached[1], cached[2], cached[3]

    # --- optics -----------------------------------------------------------------------------
    def _window_paths(self, t0: I64, t1: I64) -> F64:
        """Transport (N, 3, 3, 3) of each window averaged over its 10 ms sub-samples."""
        out = np.empty((t0.shape[0], 3, 3, 3))
        it_us = t1 - t0
        for dur in np.unique(it_us).tolist():
            rows = np.flatnonzero(it_us == dur)
            it = dur * 1e-6
            n_sub = max(1, round(it / SUBSAMPLE_S))
            ts = t0[rows, None] * 1e-6 + (np.arange(n_sub) + 0.5) * (it / n_sub)
            idx = self.track.index(ts)
            todo: dict[bytes, list[int]] = {}
            for r, sub in zip(rows.tolist(), idx, strict=True):
                key = sub.tobytes()
                hit = self._paths.get(key)
                if hit is None:
                    todo.setdefault(key, []).append(r)
                else:
                    out[r] = hit
            if not todo:
                continue
            first = [rs[0] for rs in todo.values()]
            sel = idx[np.searchsorted(rows, first)].reshape(-1)
            tr = self.track
            t = optics.transport(
                self.unit, tr.x[sel], tr.y[sel], tr.delta[sel], tr.a[sel], tr.ux[sel], tr.uy[sel]
            )
            paths = t.reshape(len(first), n_sub, 3, 3, 3).mean(axis=1)
            for p, (key, rs) in zip(paths, todo.items(), strict=True):
                out[rs] = p
                if len(self._paths) >= _PATHS_MAX:
                    self._paths.pop(next(iter(self._paths)))
                self._paths[key] = p
        return out

    def _mean_duties(self, t0: I64, t1: I64) -> F64:
        """mean_duty for each window; a window inside one segment is (d * n) / n exactly as
        the per-window loop computes it."""
        times, _, _ = self._timeline()
        seg = np.searchsorted(times, t0, side="right") - 1
        n = (t1 - t0).astype(np.float64)[:, None, None]
        out = np.stack([self._duties[i] for i in seg.tolist()]) * n / n
        nxt = np.append(times, np.iinfo(np.int64).max)[seg + 1]
        for r in np.flatnonzero(nxt < t1).tolist():  # windows that straddle a change
            out[r] = self.mean_duty(int(t0[r]), int(t1[r]))
        return out

    def _evaluate(self, t0: I64, t1: I64, flicker_noise: F64) -> list[Window]:
        """Count rates and temperature of N windows (vectorised; each window's values do not
        depend on which others are evaluated with it)."""
        unit, env = self.unit, self.scene.env
        tmid = 0.5 * (t0 + t1) * 1e-6
        temp = env.temperature(tmid)
        paths = (
            self._window_paths(t0, t1)
            * (1.0 + unit.transport_temp_coeff * (temp - optics.REFERENCE_TEMP_C))[
                :, None, None, None
            ]
        )
        times, heat, target = self._timeline()
        mid = (t0 + t1) // 2
        seg = np.searchsorted(times, mid, side="right") - 1
        dt = (mid - times[seg]) * 1e-6
        rise = target[seg] + (heat[seg] - target[seg]) * np.exp(-dt / unit.led_thermal_tau_s)
        flicker = 1.0 + unit.led_flicker * flicker_noise.reshape(-1, 3, 3)
        led = optics.led_intensity(unit, self._mean_duties(t0, t1), temp + rise, flicker)
        ambient = optics.ambient_rates(unit, env.lux(tmid), env.spectrum)
        # Explicit sums over LEDs j and colours c (not einsum): the same operations in the
        # same order whatever the batch size, so batched and single windows agree exactly.
        s = unit.spectral_paths()  # (j, k, 5 channels, c): each LED's colour bin
        rates = ambient
        for j in range(3):
            for c in range(3):
                tl = paths[:, j, :, None, c] * led[:, j, None, None, c]  # (N, k, 1)
                rates = rates + tl * s[None, j, :, :, c]
        return list(zip(rates, temp.tolist(), strict=True))

    def _rates(self, key: tuple[int, int, int], cfg: tuple[SensorConfig, bool] | None) -> Window:
        """Reference count rates (3 sensors, 5 channels) over a window, and the temperature.

        Shared by the sensors of one window: the firmware triggers the three sensors together,
        so they share one evaluation and one draw of LED flicker (the LEDs are common to all
        three, so a shared draw is also the physical behaviour)."""
        hit = self._rates_cache.get(key)
        if hit is not None:
            return hit
        plan = self.plan
        if plan is not None and self._plan_supplies(plan, key):
            hit = plan.windows[plan.evaluated]
            plan.evaluated += 1
            self._noise_led.pos += 1
        else:
            self.plan = None
            if cfg is not None and self._stable(key):
                # Plans double while they are used up and start short again after a miss.
                used_up = plan is not None and plan.evaluated == plan.n
                n = min(PLAN_MAX, 2 * plan.n) if plan is not None and used_up else PLAN_MIN
                plan = self._make_plan(key, n, *cfg)
                hit = plan.windows[0]
                plan.evaluated = 1
                self._noise_led.pos += 1
            else:
                t0, t1 = np.array([key[0]]), np.array([key[1]])
                hit = self._evaluate(t0, t1, self._noise_led.take())[0]
        self._remember(key, hit)
        return hit

    def _plan_supplies(self, plan: WindowPlan, key: tuple[int, int, int]) -> bool:
        j = plan.evaluated
        return j < plan.n and plan.keys[j] == key and self._noise_led.pos == plan.led_base + j

    def _remember(self, key: tuple[int, int, int], window: Window) -> None:
        if len(self._rates_cache) >= SHARED_WINDOWS:
            self._rates_cache.pop(next(iter(self._rates_cache)))
        self._rates_cache[key] = window
        prev = self._last_eval
        same = prev is not None and prev[2] == key[2] and prev[1] - prev[0] == key[1] - key[0]
        self._last_period = key[0] - prev[0] if prev is not None and same else None
        self._last_eval = key

    def _stable(self, key: tuple[int, int, int]) -> bool:
        """This window is the third at one steady period, duration and LED timeline."""
        prev = self._last_eval
        if not self.lookahead or prev is None or prev[2] != key[2]:
            return False
        period, it = key[0] - prev[0], key[1] - key[0]
        return it == prev[1] - prev[0] and period == self._last_period and period >= it > 0

    def _make_plan(
        self, key: tuple[int, int, int], n: int, cfg: SensorConfig, sd_als: bool
    ) -> WindowPlan:
        """Evaluate n windows from `key` on at the period since the last one, for all sensors."""
        assert self._last_eval is not None
        t0 = key[0] + (key[0] - self._last_eval[0]) * np.arange(n, dtype=np.int64)
        t1 = t0 + (key[1] - key[0])
        led_base = self._noise_led.pos
        windows = self._evaluate(t0, t1, self._noise_led.rows(led_base, n))
        rates = np.stack([w[0] for w in windows])
        temps = np.array([w[1] for w in windows])
        analog = expected_counts(rates, cfg, self.unit, temps)
        bases = [s.pos for s in self._noise_sensor]
        noise = np.stack([s.rows(b, n) for s, b in zip(self._noise_sensor, bases, strict=True)], 1)
        counts, sat = digitise_noise(analog, noise, cfg, self.unit)
        if sd_als:
            counts[:, :, [0, 2]] = 0
        keys = [(a, b, key[2]) for a, b in zip(t0.tolist(), t1.tolist(), strict=True)]
        plan = WindowPlan(keys, windows, cfg, sd_als, counts, sat, led_base, bases)
        self.plan = plan
        return plan

    def read_window(
        self, k: int, t0_us: int, t1_us: int, cfg: SensorConfig, *, sd_als: bool = False
    ) -> tuple[NDArray[np.uint16], bool]:
        """Counts (5,) uint16 of sensor k for one integration window, and its saturation flag.
        With `sd_als` only G, C and IR are powered (R and B read 0)."""
        key = (int(t0_us), int(t1_us), self._version)
        window = self._rates(key, (cfg, sd_als))
        plan = self.plan
        noise = self._noise_sensor[k]
        if plan is not None:
            j = plan.next[k]
            if (
                j < plan.n
                and plan.keys[j] == key
                and plan.windows[j] is window
                and noise.pos == plan.sensor_base[k] + j
                and plan.sd_als == sd_als
                and plan.cfg == cfg
            ):
                plan.next[k] = j + 1
                noise.pos += 1
                return plan.counts[j, k].copy(), bool(plan.saturated[j, k])
        rates, temp = window
        analog = expected_counts(rates, cfg, self.unit, np.asarray(temp))[k]
        counts, sat = digitise_noise(analog, noise.take(), cfg, self.unit)
        if sd_als:
            counts[[0, 2]] = 0
        return counts, bool(sat)

    def plan_progress(self, next_: list[int], evaluated: int) -> None:
        """Account for plan entries handed out elsewhere (the native sensor models): sensor k
        has read entries up to next_[k], and `evaluated` entries were evaluated, exactly as if
        each had been asked for through read_window."""
        plan = self.plan
        if plan is None:
            return
        for j in range(plan.evaluated, min(evaluated, plan.n)):
            self._noise_led.pos += 1
            self._remember(plan.keys[j], plan.windows[j])
        plan.evaluated = max(plan.evaluated, min(evaluated, plan.n))
        for k in range(3):
            step = next_[k] - plan.next[k]
            if step > 0:
                self._noise_sensor[k].pos += step
                plan.next[k] = next_[k]

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
        return w + noise + bias + self.unit.ft_bias_offset
