"""Contact mechanics surrogate: Hertz-like indentation, Mindlin shear, Prony-series creep.

Loads are force-controlled (the scene says what the indenter applies); the elastomer's
deformation lags them through linear viscoelasticity applied Lee-Radok style to the Hertz
variable: delta^(3/2) follows F_eff = F + sum_i beta_i * lowpass_tau_i(F). Deformation drives
the optics; the F/T sensor sees the applied load itself.

>>> u = UnitParams.nominal()
>>> d, a = indentation(np.array([0.0, 1.0, 10.0]), np.full(3, 4.0), u)
>>> [round(float(v), 2) for v in d], [round(float(v), 2) for v in a]
([0.0, 0.38, 1.25], [0.0, 1.24, 2.68])
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from spectratac.twin.scene_model import Scene
from spectratac.twin.unit import UnitParams

F64 = NDArray[np.float64]


def lowpass(x: F64, dt: float, tau: float) -> F64:
    """First-order low-pass y[n] = a*y[n-1] + (1-a)*x[n], y[-1] = 0, vectorised in blocks.

    Inside a block the recursion is a scaled cumulative sum; blocks are short enough that
    a**-B stays well inside float64, and block ends are chained by a tiny scalar loop.

    >>> y = lowpass(np.ones(5000), 0.001, 0.5)
    >>> round(float(y[499]), 3), round(float(y[-1]), 3)
    (0.632, 1.0)
    """
    x = np.asarray(x, dtype=np.float64)
    n = x.shape[0]
    if n == 0:
        return x.copy()
    a = float(np.exp(-dt / tau))
    block = int(max(1, min(4096, np.floor(20.0 * tau / dt))))
    nb = -(-n // block)
    xp = np.zeros(nb * block)
    xp[:n] = x
    xb = xp.reshape(nb, block)
    i = np.arange(block)
    up = a ** (-i.astype(np.float64))
    down = a ** i.astype(np.float64)
    y0 = (1.0 - a) * down * np.cumsum(xb * up, axis=1)
    carry = np.empty(nb)
    prev = 0.0
    ab = a**block
    ends = y0[:, -1]
    for b in range(nb):
        carry[b] = prev
        prev = ends[b] + ab * prev
    y = y0 + carry[:, None] * (a ** (i + 1.0))[None, :]
    return y.reshape(-1)[:n]


def creep_load(load: F64, dt: float, unit: UnitParams, *, shear: bool = False) -> F64:
    """Effective (creep-augmented) load on a regular time grid (normal or shear Prony set)."""
    out = load.copy()
    betas = unit.shear_creep_beta if shear else unit.creep_beta
    taus = unit.shear_creep_tau_s if shear else unit.creep_tau_s
    for beta, tau in zip(betas, taus, strict=True):
        out += beta * lowpass(load, dt, float(tau))
    return out


def indentation(normal_eff: F64, radius_mm: F64, unit: UnitParams) -> tuple[F64, F64]:
    """Hertz indentation depth and contact radius (mm) with a thin-layer ceiling."""
    f = np.maximum(normal_eff, 0.0)
    r = np.maximum(radius_mm, 1e-3)
    d_hertz = np.cbrt(9.0 * f * f / (16.0 * r * unit.e_star_mpa**2))
    a = np.sqrt(r * d_hertz)
    delta = unit.max_indent_mm * np.tanh(d_hertz / unit.max_indent_mm)
    return delta, a


def shear_displacement(fx_eff: F64, fy_eff: F64, a: F64, unit: UnitParams) -> tuple[F64, F64]:
    """Lateral surface displacement (mm) under shear: Mindlin stiffness 8 G a, capped."""
    k = 8.0 * unit.shear_modulus_mpa * np.maximum(a, 1.0)
    ux, uy = fx_eff / k, fy_eff / k
    mag = np.hypot(ux, uy)
    scale = np.where(mag > unit.max_shear_mm, unit.max_shear_mm / np.maximum(mag, 1e-12), 1.0)
    return ux * scale, uy * scale


@dataclass(frozen=True)
class MechanicsTrack:
    """Contact truth and elastomer deformation on a regular grid t = i*dt, i = 0..n-1."""

    dt: float
    x: F64
    y: F64
    fx: F64
    fy: F64
    normal: F64
    in_contact: NDArray[np.bool_]
    delta: F64
    a: F64
    ux: F64
    uy: F64

    @property
    def n(self) -> int:
        return int(self.x.shape[0])

    @property
    def t(self) -> F64:
        return np.arange(self.n) * self.dt

    @staticmethod
    def from_scene(scene: Scene, unit: UnitParams, dt: float = 1e-3) -> MechanicsTrack:
        n = int(np.floor(scene.duration_s / dt + 1e-9)) + 1
        t = np.arange(n) * dt
        c = scene.contact(t)
        fn = creep_load(c.normal, dt, unit)
        fx = creep_load(c.fx, dt, unit, shear=True)
        fy = creep_load(c.fy, dt, unit, shear=True)
        delta, a = indentation(fn, c.indenter_radius_mm, unit)
        ux, uy = shear_displacement(fx, fy, a, unit)
        # Optics see where the press lands on the board: the scene aims in the rig's frame, the
        # elastomer and the mounting may sit off it (mould alignment, re-mounting).
        ox, oy = (float(v) for v in unit.contact_offset_xy)
        return MechanicsTrack(
            dt=dt,
            x=np.where(c.in_contact, c.x + ox, c.x),
            y=np.where(c.in_contact, c.y + oy, c.y),
            fx=c.fx,
            fy=c.fy,
            normal=c.normal,
            in_contact=c.in_contact,
            delta=delta,
            a=a,
            ux=ux,
            uy=uy,
        )

    def index(self, t: F64) -> NDArray[np.int64]:
        """Nearest grid index of times t (clipped to the track)."""
        i = np.rint(np.asarray(t, dtype=np.float64) / self.dt).astype(np.int64)
        return np.clip(i, 0, self.n - 1)
