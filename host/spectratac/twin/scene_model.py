"""A scene: contact over time (presses on the skin) plus the environment around the sensor.

A scene is a table of non-overlapping presses evaluated analytically at any time, so the same
scene feeds the optical model, the F/T model and the register-level rig with one ground truth.
Forces are the load the indenter applies: ``normal`` >= 0 pushes into the skin, ``fx``/``fy``
is the tangential (shear) load in board axes. Friction caps the shear at ``friction`` x normal
(no slip), as a finger or probe pressing without sliding.

>>> s = Scene.single_press(x=3.0, y=0.0, normal_n=5.0)
>>> c = s.contact(np.array([0.0, 1.5]))
>>> c.in_contact.tolist(), round(float(c.normal[1]), 2)
([False, True], 5.0)
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from spectratac.twin.errors import TwinError
from spectratac.twin.geometry import DISC_RADIUS_MM, region_of

F64 = NDArray[np.float64]

# A sample carries a region label only on a firm contact (the paper's interaction threshold,
# 1.0 N); lighter touches are -1 ("no valid annotation") and still train the F/T head.
LABEL_MIN_NORMAL_N = 1.0
# Sorted time streams at least this long take the press-by-press path of `Scene.contact`.
SORTED_PATH_MIN = 4096

AMBIENT_SPECTRA = ("led", "fluorescent", "incandescent", "sunlight")


@dataclass(frozen=True)
class Presses:
    """Struct-of-arrays press table, sorted by start time, non-overlapping. Times in s, mm, N."""

    start: F64
    rise: F64
    hold: F64
    fall: F64
    x: F64
    y: F64
    normal_peak: F64
    normal_mod_depth: F64  # slow hand-like modulation of the normal load during the press
    normal_mod_hz: F64
    normal_mod_phase: F64
    shear_amp: F64  # (P, 2): peak Fx, Fy amplitude in N
    shear_hz: F64
    shear_phase: F64  # (P, 2)
    indenter_radius_mm: F64

    @property
    def end(self) -> F64:
        return self.start + self.rise + self.hold + self.fall

    def __len__(self) -> int:
        return int(self.start.shape[0])

    @staticmethod
    def steady(
        start: ArrayLike,
        rise: ArrayLike,
        hold: ArrayLike,
        fall: ArrayLike,
        xy: ArrayLike,
        normal_peak: ArrayLike,
        indenter_radius_mm: float = 4.0,
    ) -> Presses:
        """Presses without shear or load modulation, as scripted demos and tours press: one
        row of `xy` (mm) per press; the other values are per press or one for all."""
        xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
        n = len(xy)

        def each(v: ArrayLike) -> F64:
            return np.broadcast_to(np.asarray(v, dtype=np.float64), (n,)).copy()

        z = np.zeros(n)
        return Presses(
            each(start), each(rise), each(hold), each(fall), xy[:, 0].copy(), xy[:, 1].copy(),
            each(normal_peak), z, z.copy(), z.copy(), np.zeros((n, 2)), z.copy(),
            np.zeros((n, 2)), each(indenter_radius_mm),
        )  # fmt: skip

    @staticmethod
    def empty() -> Presses:
        z = np.zeros(0)
        return Presses(z, z, z, z, z, z, z, z, z, z, np.zeros((0, 2)), z, np.zeros((0, 2)), z)

    def validate(self) -> None:
        n = len(self)
        for name, arr in self.__dict__.items():
            want = (n, 2) if name in ("shear_amp", "shear_phase") else (n,)
            if np.shape(arr) != want:
                raise TwinError(f"presses.{name} has shape {np.shape(arr)}, expected {want}")
            if not np.all(np.isfinite(arr)):
                raise TwinError(f"presses.{name} contains NaN or inf; give finite values")
        if n and (np.any(self.rise <= 0) or np.any(self.fall <= 0) or np.any(self.hold < 0)):
            raise TwinError("press rise and fall must be > 0 s and hold >= 0 s")
        if n > 1 and np.any(self.start[1:] < self.end[:-1]):
            raise TwinError("presses overlap or are unsorted; sort by start, one press at a time")
        if np.any(self.normal_peak < 0):
            raise TwinError("press normal_peak must be >= 0 N (it pushes into the skin)")
        if np.any(np.hypot(self.x, self.y) > DISC_RADIUS_MM):
            raise TwinError(f"press positions must lie on the {DISC_RADIUS_MM} mm disc")
        if np.any(self.indenter_radius_mm <= 0):
            raise TwinError("indenter_radius_mm must be > 0")


@dataclass(frozen=True)
class Environment:
    """Ambient light (lux, piecewise linear), ambient temperature (°C) and LED thermal state."""

    times: F64 = field(default_factory=lambda: np.array([0.0]))
    ambient_lux: F64 = field(default_factory=lambda: np.array([300.0]))
    temperature_c: F64 = field(default_factory=lambda: np.array([25.0]))
    spectrum: str = "led"
    leds_prewarmed: bool = True  # False: LEDs switch on at t=0 and warm up (drift session)

    def validate(self) -> None:
        n = self.times.shape[0]
        if n == 0 or self.ambient_lux.shape != (n,) or self.temperature_c.shape != (n,):
            raise TwinError("environment times, ambient_lux, temperature_c need equal length >= 1")
        if np.any(np.diff(self.times) < 0):
            raise TwinError("environment times must be sorted")
        if np.any(self.ambient_lux < 0) or not np.all(np.isfinite(self.ambient_lux)):
            raise TwinError("ambient_lux must be finite and >= 0")
        if not np.all(np.isfinite(self.temperature_c)):
            raise TwinError("temperature_c must be finite")
        if self.spectrum not in AMBIENT_SPECTRA:
            raise TwinError(f"spectrum must be one of {AMBIENT_SPECTRA}, got {self.spectrum!r}")

    def lux(self, t: F64) -> F64:
        return np.interp(t, self.times, self.ambient_lux)

    def temperature(self, t: F64) -> F64:
        return np.interp(t, self.times, self.temperature_c)


@dataclass(frozen=True)
class ContactState:
    """Contact truth at a set of times (all arrays share the leading shape)."""

    x: F64
    y: F64
    fx: F64
    fy: F64
    normal: F64
    indenter_radius_mm: F64
    in_contact: NDArray[np.bool_]

    @property
    def region(self) -> NDArray[np.int8]:
        """Region label 1-9 on firm contacts inside the active area, -1 elsewhere."""
        valid = self.in_contact & (self.normal >= LABEL_MIN_NORMAL_N)
        reg = region_of(self.x, self.y)
        return np.where(valid, reg, np.int8(-1)).astype(np.int8)


@dataclass(frozen=True)
class Scene:
    """Contact over time plus environment; see module docstring."""

    name: str
    duration_s: float
    presses: Presses
    env: Environment = field(default_factory=Environment)
    friction: float = 1.0

    def __post_init__(self) -> None:
        if not (np.isfinite(self.duration_s) and self.duration_s > 0):
            raise TwinError(f"scene duration_s must be > 0, got {self.duration_s!r}")
        if not self.friction > 0:
            raise TwinError("scene friction coefficient must be > 0")
        self.presses.validate()
        self.env.validate()

    def contact(self, t: F64) -> ContactState:
        """Evaluate the contact at times ``t`` (s, any shape), vectorised; a long ascending
        stream (a 1 kHz F/T, the mechanics grid) goes press by press, to the same values."""
        t = np.asarray(t, dtype=np.float64)
        p = self.presses
        shape = t.shape
        if len(p) == 0:
            z = np.zeros(shape)
            return ContactState(z, z, z, z, z, np.ones(shape), np.zeros(shape, dtype=bool))
        if t.ndim == 1 and t.shape[0] >= SORTED_PATH_MIN and bool(np.all(t[1:] >= t[:-1])):
            return self._contact_sorted(t)
        idx = np.clip(np.searchsorted(p.start, t, side="right") - 1, 0, len(p) - 1)
        tau = t - p.start[idx]
        rise, hold, fall = p.rise[idx], p.hold[idx], p.fall[idx]
        total = rise + hold + fall
        inside = (tau > 0) & (tau < total)
        env = np.where(
            tau < rise,
            0.5 - 0.5 * np.cos(np.pi * np.clip(tau / rise, 0, 1)),
            np.where(
                tau < rise + hold,
                1.0,
                0.5 + 0.5 * np.cos(np.pi * np.clip((tau - rise - hold) / fall, 0, 1)),
            ),
        )
        env = np.where(inside, env, 0.0)
        mod = 1.0 + p.normal_mod_depth[idx] * np.sin(
            2 * np.pi * p.normal_mod_hz[idx] * tau + p.normal_mod_phase[idx]
        )
        normal = p.normal_peak[idx] * env * mod
        w = 2 * np.pi * p.shear_hz[idx] * tau
        fx = env * p.shear_amp[idx, 0] * np.cos(w + p.shear_phase[idx, 0])
        fy = env * p.shear_amp[idx, 1] * np.cos(w + p.shear_phase[idx, 1])
        # No slip: the tangential load never exceeds friction x normal.
        mag = np.hypot(fx, fy)
        cap = self.friction * normal
        scale = np.where(mag > cap, cap / np.maximum(mag, 1e-12), 1.0)
        return ContactState(
            x=np.where(inside, p.x[idx], 0.0),
            y=np.where(inside, p.y[idx], 0.0),
            fx=fx * scale,
            fy=fy * scale,
            normal=normal,
            indenter_radius_mm=p.indenter_radius_mm[idx],
            in_contact=inside & (normal > 0),
        )

    def _contact_sorted(self, t: F64) -> ContactState:
        """`contact` for ascending times, press by press: only the samples inside a press are
        evaluated (in cache-sized pieces), with the same arithmetic as the general path, so
        the values are the same to the bit; long streams (a 1 kHz F/T) spend most of their
        time between presses or in a press's hold."""
        p = self.presses
        n = t.shape[0]
        # The press each time belongs to (the last one started at or before it; times before
        # the first start belong to press 0), as the general path's clipped searchsorted.
        first = np.searchsorted(t, p.start, side="left")
        owned = np.diff(np.r_[first, n])
        owned[0] += first[0]
        radius = np.repeat(p.indenter_radius_mm, owned)
        x, y, fx, fy, normal = (np.zeros(n) for _ in range(5))
        inside = np.zeros(n, dtype=bool)
        # Samples strictly after each start and before its end (a margin for rounding; the
        # exact test on tau below decides).
        lo = np.searchsorted(t, p.start, side="right")
        total = p.rise + p.hold + p.fall
        hi = np.minimum(
            np.searchsorted(t, p.start + total * (1.0 + 1e-12) + 1e-12), np.r_[first[1:], n]
        )
        for i in np.flatnonzero(hi > lo):
            a, b = int(lo[i]), int(hi[i])
            tau = t[a:b] - p.start[i]
            b = a + int(np.searchsorted(tau, total[i], side="left"))
            if b == a:
                continue
            tau = tau[: b - a]
            rise, hold, fall = p.rise[i], p.hold[i], p.fall[i]
            env = np.ones(b - a)
            r_end = int(np.searchsorted(tau, rise, side="left"))
            env[:r_end] = 0.5 - 0.5 * np.cos(np.pi * np.clip(tau[:r_end] / rise, 0, 1))
            h_end = int(np.searchsorted(tau, rise + hold, side="left"))
            f = tau[h_end:]
            env[h_end:] = 0.5 + 0.5 * np.cos(np.pi * np.clip((f - rise - hold) / fall, 0, 1))
            mod = 1.0 + p.normal_mod_depth[i] * np.sin(
                2 * np.pi * p.normal_mod_hz[i] * tau + p.normal_mod_phase[i]
            )
            nrm = p.normal_peak[i] * env * mod
            w = 2 * np.pi * p.shear_hz[i] * tau
            sx = env * p.shear_amp[i, 0] * np.cos(w + p.shear_phase[i, 0])
            sy = env * p.shear_amp[i, 1] * np.cos(w + p.shear_phase[i, 1])
            mag = np.hypot(sx, sy)
            cap = self.friction * nrm
            scale = np.where(mag > cap, cap / np.maximum(mag, 1e-12), 1.0)
            fx[a:b] = sx * scale
            fy[a:b] = sy * scale
            normal[a:b] = nrm
            x[a:b] = p.x[i]
            y[a:b] = p.y[i]
            inside[a:b] = True
        return ContactState(
            x=x,
            y=y,
            fx=fx,
            fy=fy,
            normal=normal,
            indenter_radius_mm=radius,
            in_contact=inside & (normal > 0),
        )

    def starting_at(self, start_s: float) -> Scene:
        """The same scene joined `start_s` seconds in: what happened before is gone (a press
        under way at `start_s` is already pressed at time 0).

        >>> sc = Scene.single_press(start_s=0.5)
        >>> bool(sc.starting_at(1.0).contact(np.array([0.0])).in_contact[0])
        True
        """
        if not (np.isfinite(start_s) and 0.0 <= start_s < self.duration_s):
            raise TwinError(
                f"start={start_s!r}: give seconds in [0, {self.duration_s:g}) of scene {self.name}"
            )
        p, env = self.presses, self.env
        return replace(
            self,
            duration_s=self.duration_s - start_s,
            presses=replace(p, start=p.start - start_s),
            env=replace(env, times=env.times - start_s),
        )

    def press_index(self, t: F64) -> NDArray[np.int32]:
        """Index of the press under way at each time in ``t``; -1 between presses.

        >>> Scene.single_press(start_s=0.5).press_index(np.array([0.2, 1.0, 9.0])).tolist()
        [-1, 0, -1]
        """
        t = np.asarray(t, dtype=np.float64)
        p = self.presses
        if not len(p):
            return np.full(t.shape, -1, np.int32)
        i = np.searchsorted(p.start, t, side="right") - 1
        inside = (i >= 0) & (t < p.end[np.clip(i, 0, None)])
        return np.where(inside, i, -1).astype(np.int32)

    @staticmethod
    def single_press(
        x: float = 0.0,
        y: float = 0.0,
        normal_n: float = 5.0,
        shear_n: tuple[float, float] = (0.0, 0.0),
        *,
        start_s: float = 0.5,
        rise_s: float = 0.5,
        hold_s: float = 2.0,
        fall_s: float = 0.5,
        indenter_radius_mm: float = 4.0,
        duration_s: float | None = None,
        env: Environment | None = None,
        name: str = "single_press",
    ) -> Scene:
        """One press with a constant shear ``shear_n`` (Fx, Fy) scaled by the same envelope."""
        a = np.array
        presses = Presses(
            start=a([start_s]),
            rise=a([rise_s]),
            hold=a([hold_s]),
            fall=a([fall_s]),
            x=a([x]),
            y=a([y]),
            normal_peak=a([normal_n]),
            normal_mod_depth=a([0.0]),
            normal_mod_hz=a([0.0]),
            normal_mod_phase=a([0.0]),
            shear_amp=a([list(shear_n)], dtype=np.float64),
            shear_hz=a([0.0]),
            shear_phase=a([[0.0, 0.0]]),
            indenter_radius_mm=a([indenter_radius_mm]),
        )
        end = start_s + rise_s + hold_s + fall_s
        return Scene(
            name=name,
            duration_s=float(duration_s if duration_s is not None else end + 0.5),
            presses=presses,
            env=env or Environment(),
            friction=10.0,  # single presses are set up explicitly; do not cap their shear
        )
