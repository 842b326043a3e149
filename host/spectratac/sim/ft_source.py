"""The samples a simulated reference F/T sensor produces: the world's reference wrench
(twin scene + noise + slow bias, the same ground truth the simulated optical sensor sees)
sampled on the F/T's own crystal clock, with occasional losses.

The F/T clock reads sensor = offset + (1 + drift) * scene seconds; sample k is taken when
that clock reads k / rate, i.e. at scene time (k / rate - offset) / (1 + drift). Samples
are computed ahead in blocks (one vectorised twin call per block) and released when their
scene time has come, so a sender wakes often but pays for the twin rarely. Scene time starts
with the world's first optical stream (`SimWorld.start_clock`), or when the F/T is first read in
a world without an optical device; until then no sample is due. At speed=max the scene clock
is the optical device's (`SimWorld.reached`): a sample is due once the device has sent the
frames of its scene time, so the F/T is paced by the device's samples (and the device waits
for an F/T that lags, `SimWorld.wait_for_ft`); such an F/T needs the world's optical device.
The first block is computed when the source is made, so a server is ready to answer before it
is handed out.

>>> from spectratac.sim.url import parse_sim_url
>>> from spectratac.sim.world import SimWorld
>>> world = SimWorld.join(parse_sim_url("sim://?scene=press&seed=1&speed=10"))
>>> src = FTSource(world, FTParams(rate=1000.0, loss=0.0, offset=0.05, drift=1e-4))
>>> epoch = world.start_clock(__import__("time").monotonic())  # as an optical START does
>>> batch = src.pop_due(epoch + 0.02)  # 0.2 scene s after the epoch
>>> bool(len(batch.k) > 0), batch.wrench.shape[1], float(batch.sensor_time[0]) >= 0.05
(True, 6, True)
>>> world.release()
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from spectratac.ft.errors import FTURLError
from spectratac.sim.url import SimOptions
from spectratac.sim.world import SimWorld

F64 = NDArray[np.float64]
#: speed=max: how often (host s) a server looks for samples the device's progress made due.
UNPACED_POLL_S = 0.002
UNPACED_SPEED = 100.0


@dataclass(frozen=True)
class FTParams:
    """Simulated F/T sensor settings (sim:// URL: ft_rate, ft_loss, ft_offset, ft_drift)."""

    rate: float = 1000.0  # samples per scene second, on the sensor's clock
    loss: float = 0.001  # probability that a sample never reaches the host
    offset: float = 0.05  # sensor clock reading at scene time 0, s
    drift: float = 1e-4  # sensor clock rate error (ratio - 1)

    @classmethod
    def from_sim(cls, opts: SimOptions) -> FTParams:
        p = opts.scene_params
        try:
            params = cls(
                rate=float(p.get("ft_rate", cls.rate)),
                loss=float(p.get("ft_loss", cls.loss)),
                offset=float(p.get("ft_offset", cls.offset)),
                drift=float(p.get("ft_drift", cls.drift)),
            )
        except ValueError as exc:
            raise FTURLError(f"{opts.query()}: bad F/T parameter: {exc}") from None
        params.validate()
        return params

    def validate(self) -> None:
        if not (0 < self.rate <= 100_000):
            raise FTURLError(f"ft_rate={self.rate}: give samples per second in (0, 100000]")
        if not (0 <= self.loss < 1):
            raise FTURLError(f"ft_loss={self.loss}: give a probability in [0, 1)")
        if not (abs(self.drift) < 0.01) or not math.isfinite(self.offset):
            raise FTURLError("ft_drift must be within ±0.01 and ft_offset finite")


@dataclass
class FTBatch:
    k: NDArray[np.int64]  # sample index on the sensor clock
    sensor_time: F64  # k / rate, s
    scene_time: F64
    wrench: F64  # (n, 6) N and N*m
    lost: NDArray[np.bool_]  # these never reach the host


class FTSource:
    """Releases a simulated F/T sensor's samples as scene time passes."""

    def __init__(self, world: SimWorld, params: FTParams, stream: int = 0) -> None:
        if not world.paced and world.optical == 0:
            raise FTURLError(
                "a simulated F/T at speed=max is paced by the simulated optical sensor of the "
                "same URL, and none is open: open it first (record, live and decode take both "
                "from one sim:// URL), or give a numeric speed (e.g. speed=10) to serve the "
                "F/T alone"
            )
        params.validate()
        self.world = world
        self.params = params
        self._rng = np.random.default_rng([world.seed, 0xF7, stream])
        # speed=max: blocks as if at 100x (the device races ahead; larger blocks, fewer calls)
        self._speed = float(world.speed) if world.paced else UNPACED_SPEED
        self._k_next = 0
        self.skip()
        self._block_n = max(16, int(params.rate * self._speed * 0.02))  # ~20 ms of samples
        # Computed now, on the caller's thread, before any server thread serves: the first
        # twin call builds the world's F/T rig (~0.1 s for a tour idle, seconds on a loaded
        # machine). Left to the server thread, it ran after a host had begun to open the
        # sensor, so it counted against the host's open timeout (issue 25).
        self._block: FTBatch | None = self._compute(self._k_next, self._block_n)

    def streaming(self, on: bool) -> None:
        """The server starts (or stops) sending: at speed=max the optical device then waits
        for this source while it lags (SimWorld.wait_for_ft)."""
        if not self.world.paced:
            self.world.ft_streaming(id(self), on)

    def skip(self) -> None:
        """Forget samples not yet taken: the next one is the next tick of the sensor clock
        (a stream starts now; nothing is computed for the time nobody listened). At
        speed=max scene time moves only with the device, so nothing is skipped: a stream
        started after the device's has its samples from where the source left off."""
        if not self.world.paced and self._k_next:
            return
        self._k_next = math.floor(self.sensor_of(self.world.scene_time()) * self.params.rate) + 1

    def sensor_of(self, scene_time: float) -> float:
        return self.params.offset + (1.0 + self.params.drift) * scene_time

    def scene_of_k(self, k: NDArray[np.int64] | int) -> F64:
        p = self.params
        return (np.asarray(k) / p.rate - p.offset) / (1.0 + p.drift)

    def next_due_host(self) -> float:
        """Host monotonic time at which the next sample is due (speed=max: look again soon,
        the device's samples set the pace)."""
        if not self.world.paced:
            return time.monotonic() + UNPACED_POLL_S
        epoch = self._epoch(time.monotonic())
        if epoch is None:  # scene time waits at 0 for the first optical stream: look again
            return time.monotonic() + 0.01
        t_scene = float(self.scene_of_k(self._k_next))
        return epoch + t_scene / self._speed

    def pop_due(self, now: float | None = None) -> FTBatch:
        """Every sample whose time has come by host time `now` (default: now), in order.
        None has come before an optical stream started the scene clock."""
        t = time.monotonic() if now is None else now
        scene_now = self._scene_now(t)
        if scene_now is None:
            return _empty()
        k_due = math.floor(self.sensor_of(scene_now) * self.params.rate)
        parts: list[FTBatch] = []
        while self._k_next <= k_due:
            block = self._block
            if block is None or block.k[-1] < self._k_next:
                block = self._block = self._compute(self._k_next, self._block_n)
            i0 = self._k_next - int(block.k[0])
            i1 = min(len(block.k), k_due - int(block.k[0]) + 1)
            parts.append(_slice(block, i0, i1))
            self._k_next = int(block.k[0]) + i1
        if not self.world.paced:  # the optical device may run this far ahead of us
            self.world.ft_released(id(self), float(self.scene_of_k(self._k_next - 1)))
        if not parts:
            return _empty()
        return parts[0] if len(parts) == 1 else _concat(parts)

    @property
    def waiting(self) -> bool:
        """True while the scene clock waits for an optical stream (no sample is due)."""
        if not self.world.paced:
            return self.world.reached is None
        return self.world.epoch is None and self.world.optical > 0

    def rest_sample(self) -> FTBatch:
        """The sample of the sensor clock's tick at scene 0 (the scene at rest), for a probe
        answered while the scene waits; it precedes every sample `pop_due` will release."""
        k = math.floor(self.sensor_of(0.0) * self.params.rate)
        return self._compute(k, 1)

    def _scene_now(self, now: float) -> float | None:
        """Scene seconds at host time `now`, None before the scene clock started."""
        if not self.world.paced:
            return self.world.reached
        return None if self._epoch(now) is None else self.world.scene_time(now)

    def _epoch(self, now: float) -> float | None:
        """The world's epoch; an F/T alone in its world (no optical device) starts the scene
        clock itself when first read, one beside an optical device waits for its START."""
        epoch = self.world.epoch
        if epoch is None and self.world.optical == 0:
            epoch = self.world.start_clock(now)
        return epoch

    def _compute(self, k0: int, n: int) -> FTBatch:
        k = np.arange(k0, k0 + n, dtype=np.int64)
        scene = self.scene_of_k(k)
        wrench = self.world.ft_rig.ft(np.maximum(scene, 0.0))
        lost = self._rng.random(n) < self.params.loss
        return FTBatch(k, k / self.params.rate, scene, wrench, lost)


def _slice(b: FTBatch, i0: int, i1: int) -> FTBatch:
    return FTBatch(
        b.k[i0:i1], b.sensor_time[i0:i1], b.scene_time[i0:i1], b.wrench[i0:i1], b.lost[i0:i1]
    )


def _concat(parts: list[FTBatch]) -> FTBatch:
    return FTBatch(
        np.concatenate([p.k for p in parts]),
        np.concatenate([p.sensor_time for p in parts]),
        np.concatenate([p.scene_time for p in parts]),
        np.concatenate([p.wrench for p in parts]),
        np.concatenate([p.lost for p in parts]),
    )


def _empty() -> FTBatch:
    z = np.empty(0)
    return FTBatch(np.empty(0, dtype=np.int64), z, z, np.empty((0, 6)), np.empty(0, dtype=bool))
