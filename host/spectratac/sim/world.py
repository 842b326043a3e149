"""One simulated world per scene: the clock and twin that every simulated device of a
sim:// URL shares, so that the optical sensor and a simulated reference F/T sensor opened
on the same scene and seed see the same contact at the same moment.

Scene time runs at `speed` times the host's monotonic clock from the world's epoch: the
moment a host first starts a stream from one of its optical devices (its first START), or,
in a world without one, the moment its simulated F/T is first read; not the moment the world
was made or a device was opened. Until then scene time stays at 0, so
a recording is a function of its URL and options only: however long the host took to open
and configure, its first integration window starts at scene time 0 and every later one on
the same grid, and a simulated F/T sensor's samples fall on its own clock's grid in scene
time. What takes long to build (each device's twin, and for a URL with ``ft=`` the F/T twin
with its first evaluation) is built before any stream can start. Worlds are shared within
one process by key (scene, seed, speed, scene parameters) and dropped when the last device
releases them.

>>> from spectratac.sim.url import parse_sim_url
>>> a = SimWorld.join(parse_sim_url("sim://?scene=press&seed=2&speed=5"))
>>> b = SimWorld.join(parse_sim_url("sim://?scene=press&seed=2&speed=5&ft=bota"))
>>> a is b, a.speed
(True, 5.0)
>>> a.release(); b.release()
>>> rebuild_scene({"scene": "press", "seed": 2, "params": {"ft": "bota"}}).name
'single_press'
"""

from __future__ import annotations

import threading
import time
from typing import Any, ClassVar

from spectratac.sim.named_scenes import make_scene
from spectratac.sim.runner import MAX
from spectratac.sim.url import SimOptions
from spectratac.twin.rig import TwinRig
from spectratac.twin.scene_model import Scene

#: URL parameters that choose devices rather than the scene; they do not split worlds.
DEVICE_PARAMS = frozenset({"ft", "ft_rate", "ft_loss", "ft_offset", "ft_drift", "ft_port"})


def scene_params(params: dict[str, str]) -> dict[str, str]:
    """The URL parameters that shape the scene (the others choose devices)."""
    return {k: v for k, v in params.items() if k not in DEVICE_PARAMS}


def rebuild_scene(sim: dict[str, Any]) -> Scene:
    """The scene a recording's session message names (its "sim" block): for checks and
    oracles that want the scene itself; the recording already holds its ground truth."""
    return make_scene(sim["scene"], seed=str(sim["seed"]), **scene_params(sim.get("params", {})))


class SimWorld:
    _registry: ClassVar[dict[tuple[object, ...], SimWorld]] = {}
    _lock: ClassVar[threading.Lock] = threading.Lock()

    def __init__(self, key: tuple[object, ...], scene: Scene, seed: int, speed: float | str):
        self.key = key
        self.scene = scene
        self.seed = seed
        self.speed = speed
        self._epoch: float | None = None  # set by the first stream that starts
        self._epoch_lock = threading.Lock()
        self._users = 0
        self.optical = 0  # optical devices open on this world (their START starts the clock)
        self._ft_rig: TwinRig | None = None

    @property
    def epoch(self) -> float | None:
        """Host monotonic time of scene time 0, or None while no stream has started."""
        with self._epoch_lock:
            return self._epoch

    def count_optical(self, change: int) -> None:
        """An optical device opened (+1) or closed (-1) on this world."""
        with self._epoch_lock:
            self.optical += change

    def start_clock(self, now: float) -> float:
        """Start scene time at host monotonic time `now` unless a stream already started it
        (the first stream wins: every device of the world shares its clock); the epoch."""
        with self._epoch_lock:
            if self._epoch is None:
                self._epoch = now
            return self._epoch

    @classmethod
    def join(cls, opts: SimOptions) -> SimWorld:
        """The world of `opts` (created on first use); call release() when done with it."""
        params = scene_params(opts.scene_params)
        key = (opts.scene, opts.seed, opts.speed, tuple(sorted(params.items())))
        with cls._lock:
            world = cls._registry.get(key)
            if world is None:
                scene = make_scene(opts.scene, seed=str(opts.seed), **params)
                world = cls._registry[key] = SimWorld(key, scene, opts.seed, opts.speed)
            world._users += 1
        if opts.scene_params.get("ft") and world.paced:
            try:
                world.ft_rig.ft([0.0])  # the F/T twin's build and first call: before the clock
            except BaseException:
                world.release()
                raise
        return world

    def release(self) -> None:
        with self._lock:
            self._users -= 1
            if self._users <= 0 and self._registry.get(self.key) is self:
                del self._registry[self.key]

    @property
    def ft_rig(self) -> TwinRig:
        """A twin of this world's scene and unit for reference F/T models (built on first
        use, then shared; optical devices build their own, their sensor models hold state)."""
        with self._lock:
            if self._ft_rig is None:
                self._ft_rig = TwinRig(self.scene, seed=self.seed)
            return self._ft_rig

    @property
    def paced(self) -> bool:
        """True when scene time follows the wall clock (speed is a number, not 'max')."""
        return self.speed != MAX

    def scene_time(self, now: float | None = None) -> float:
        """Scene seconds at host monotonic time `now` (default: now); 0 until the clock
        starts. Paced worlds only."""
        if not self.paced:
            raise ValueError("speed=max has no wall-clock scene time; give a numeric speed")
        epoch = self.epoch
        if epoch is None:
            return 0.0  # the scene waits at its start for the first stream
        t = time.monotonic() if now is None else now
        return (t - epoch) * float(self.speed)
