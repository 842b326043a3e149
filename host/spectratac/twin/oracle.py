"""Oracle decoder: knows the unit's true parameters and inverts the forward model per sample.

For every optical sample it finds the static contact (x, y, Fx, Fy, normal, indenter radius)
whose noise-free counts best match the measured ones, weighting each channel by its expected
noise (shot, read, quantisation, LED flicker) and ignoring saturated channels: a coarse grid
search for the start, then a batched Levenberg-Marquardt refinement (all samples in parallel,
finite-difference Jacobians). It knows the LED duties, the settings, the room temperature and
ambient light, but not the press history (creep) nor the noise, so its error is the floor a
learned decoder can approach, not zero. The F/T estimate is the wrench of the fitted contact.

>>> from spectratac.twin import generate_session, builtin_scenes
>>> sc = builtin_scenes.single_press(6, 6.0, (1.5, 0.0), hold_s=1.0)
>>> s = generate_session(sc, seed=2)
>>> i = np.array([int(np.argmax(-s.force[:, 2]))])
>>> r = Oracle.for_session(s, sc).decode(s.counts[i], s.t_start[i], s.step[i])
>>> bool(abs(r.force[0, 2] - 6.0) < 1.0), int(r.region[0])
(True, 6)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from spectratac.twin import optics
from spectratac.twin.electronics import FULL_SCALE, SensorConfig, expected_counts
from spectratac.twin.errors import TwinError
from spectratac.twin.forward import deformation, static_rates
from spectratac.twin.ft import wrench
from spectratac.twin.generate import Session
from spectratac.twin.geometry import DISC_RADIUS_MM, region_of
from spectratac.twin.scene_model import Environment, Scene
from spectratac.twin.unit import UnitParams

F64 = NDArray[np.float64]

_N_PARAMS = 6  # x, y, fx, fy, p (normal = p^2), log indenter radius
_FD_STEP = np.array([0.02, 0.02, 0.01, 0.01, 0.005, 0.01])
_LOG_R = (np.log(2.0), np.log(8.0))


@dataclass(frozen=True)
class OracleResult:
    ft: F64  # (n, 6) F/T estimate
    xy: F64  # (n, 2) contact position, mm
    force: F64  # (n, 3): Fx, Fy, normal (N)
    radius_mm: F64  # (n,) fitted indenter radius
    region: NDArray[np.int8]  # (n,) 1-9 from the fitted position
    cost: F64  # (n,) whitened residual sum of squares


class Oracle:
    """Per-sample model inversion with the true unit, settings, LEDs and environment."""

    def __init__(
        self,
        unit: UnitParams,
        cfg: SensorConfig,
        led_steps: F64,
        env: Environment,
        *,
        sample_period_s: float | None = None,
    ) -> None:
        self.unit = unit
        self.cfg = cfg
        self.steps = np.asarray(led_steps, dtype=np.float64)
        self.env = env
        it = cfg.integration_ms / 1000.0
        self.mean_duty = float(self.steps.mean()) * it / (sample_period_s or it)

    @staticmethod
    def for_session(session: Session, scene: Scene) -> Oracle:
        period = float(session.t_start[1] - session.t_start[0]) if len(session) > 1 else None
        return Oracle(
            session.unit, session.config, session.led_steps, scene.env, sample_period_s=period
        )

    # --- forward ------------------------------------------------------------------------------
    def _led(self, t_mid: F64, step: NDArray[np.integer]) -> tuple[F64, F64]:
        temp = self.env.temperature(t_mid)
        rise = optics.led_junction_rise(self.unit, self.mean_duty, t_mid, self.env.leds_prewarmed)
        return optics.led_intensity(self.unit, self.steps[step], temp + rise), temp

    def _predict(self, theta: F64, led: F64, lux: F64, temp: F64) -> F64:
        u = self.unit
        r = np.exp(np.clip(theta[:, 5], *_LOG_R))
        rates = static_rates(
            u,
            theta[:, 0],
            theta[:, 1],
            theta[:, 2],
            theta[:, 3],
            theta[:, 4] ** 2,
            r,
            led,
            lux=lux,
            spectrum=self.env.spectrum,
            temperature_c=temp,
        )
        return (expected_counts(rates, self.cfg, u, temp) * self.cfg.dg).reshape(-1, 15)

    def _weights(self, counts: F64) -> F64:
        u, cfg = self.unit, self.cfg
        analog = counts / cfg.dg
        var = (
            cfg.dg**2
            * (analog * cfg.gain / u.electrons_per_count + u.read_noise_counts**2 + 1.0 / 12.0)
            + (u.led_flicker * counts) ** 2
        )
        w = 1.0 / np.sqrt(np.maximum(var, 1.0))
        return np.where(counts >= FULL_SCALE, 0.0, w)

    # --- inversion ----------------------------------------------------------------------------
    def decode(
        self,
        counts: NDArray[np.integer],
        t_mid: F64,
        step: NDArray[np.integer] | None = None,
        *,
        iterations: int = 25,
    ) -> OracleResult:
        """Invert (n, 3, 5) counts measured at window centres `t_mid` (s) with LED `step`."""
        c = np.asarray(counts, dtype=np.float64)
        n = c.shape[0]
        if c.shape != (n, 3, 5):
            raise TwinError(f"oracle needs counts shaped (n, 3, 5), got {c.shape}")
        t_mid = np.broadcast_to(np.asarray(t_mid, dtype=np.float64), (n,))
        step = np.zeros(n, np.int64) if step is None else np.asarray(step, np.int64)
        y = c.reshape(n, 15)
        w = self._weights(y)
        led, temp = self._led(t_mid, step)
        lux = self.env.lux(t_mid)

        def cost_of(theta: F64, rows: NDArray[np.int64]) -> F64:
            res = (self._predict(theta, led[rows], lux[rows], temp[rows]) - y[rows]) * w[rows]
            return np.sum(res * res, axis=1)

        # Coarse start: a grid of positions x normal loads, zero shear, mid-size indenter.
        grid = _start_grid()
        g = grid.shape[0]
        rows = np.repeat(np.arange(n), g)
        costs = cost_of(np.tile(grid, (n, 1)), rows).reshape(n, g)
        best = np.argsort(costs, axis=1)[:, :2]
        results = [
            self._refine(grid[best[:, s]].copy(), y, w, led, lux, temp, iterations)
            for s in range(2)
        ]
        pick = results[0][1] <= results[1][1]
        theta = np.where(pick[:, None], results[0][0], results[1][0])
        cost = np.where(pick, results[0][1], results[1][1])
        return self._result(theta, cost)

    def _refine(
        self, theta: F64, y: F64, w: F64, led: F64, lux: F64, temp: F64, iterations: int
    ) -> tuple[F64, F64]:
        n = theta.shape[0]

        def resid(th: F64) -> F64:
            return (self._predict(th, led, lux, temp) - y) * w

        r = resid(theta)
        cost = np.sum(r * r, axis=1)
        lam = np.full(n, 1e-2)
        eye = np.eye(_N_PARAMS)
        for _ in range(iterations):
            jac = np.empty((n, 15, _N_PARAMS))
            for p in range(_N_PARAMS):
                th = theta.copy()
                th[:, p] += _FD_STEP[p]
                jac[:, :, p] = (resid(th) - r) / _FD_STEP[p]
            jtj = np.einsum("nip,niq->npq", jac, jac)
            jtr = np.einsum("nip,ni->np", jac, r)
            damp = jtj + lam[:, None, None] * (jtj * eye + 1e-6 * eye)
            step = -np.linalg.solve(damp, jtr[..., None])[..., 0]
            trial = _project(theta + step)
            r_new = resid(trial)
            c_new = np.sum(r_new * r_new, axis=1)
            ok = c_new < cost
            theta = np.where(ok[:, None], trial, theta)
            r = np.where(ok[:, None], r_new, r)
            cost = np.where(ok, c_new, cost)
            lam = np.where(ok, lam / 3.0, lam * 4.0)
        return theta, cost

    def _result(self, theta: F64, cost: F64) -> OracleResult:
        u = self.unit
        x, y, fx, fy = theta[:, 0], theta[:, 1], theta[:, 2], theta[:, 3]
        normal = theta[:, 4] ** 2
        r = np.exp(np.clip(theta[:, 5], *_LOG_R))
        delta, _, ux, uy = deformation(u, fx, fy, normal, r)
        ft = wrench(fx, fy, normal, x, y, delta, ux, uy, unit=u)
        return OracleResult(
            ft=ft,
            xy=np.stack([x, y], axis=1),
            force=np.stack([fx, fy, normal], axis=1),
            radius_mm=r,
            region=region_of(x, y),
            cost=cost,
        )


def _start_grid() -> F64:
    pts = [(0.0, 0.0)]
    for rad, n in ((2.0, 4), (5.3, 8), (7.5, 8)):
        for k in range(n):
            a = 2 * np.pi * k / n
            pts.append((rad * np.cos(a), rad * np.sin(a)))
    out = []
    for px, py in pts:
        for fz in (0.3, 1.5, 4.0, 8.0):
            out.append((px, py, 0.0, 0.0, np.sqrt(fz), np.log(4.5)))
    return np.array(out)


def _project(theta: F64) -> F64:
    r = np.hypot(theta[:, 0], theta[:, 1])
    s = np.where(r > DISC_RADIUS_MM, DISC_RADIUS_MM / np.maximum(r, 1e-9), 1.0)
    theta = theta.copy()
    theta[:, 0] *= s
    theta[:, 1] *= s
    theta[:, 5] = np.clip(theta[:, 5], *_LOG_R)
    return theta
