"""One simulated world per scene: the clock and twin that every simulated device of a
sim:// URL shares, so that the optical sensor and a simulated reference F/T sensor opened
on the same scene and seed see the same contact at the same moment.

Scene time runs at `speed` times the host's monotonic clock from the world's epoch: the moment
a host first starts a stream from one of its optical devices (its first START), or, in a world
without one, the moment its simulated F/T is first read; not the moment the world was made or a
device was opened. At speed=max scene time has no wall clock: it is the device time its optical
devices have reached (the scene time of the newest frame they sent), so a simulated F/T paces
itself with the device's samples, and the optical devices wait (`wait_for_ft`) while a
streaming F/T lags more than FT_LEAD_S behind them. Until the first stream scene time stays at
0, so a recording is a function of its URL and options only: however long the host took to open
and configure, its first integration window starts at scene time 0 and every later one on the
same grid, and a simulated F/T sensor's samples fall on its own clock's grid in scene time.
What takes long to build (each device's twin, and for a URL with ``ft=`` the F/T twin with its
first evaluation) is built before any stream can start. Worlds are shared within one process by
key (scene, seed, speed, scene parameters) and dropped when the last device releases them.

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

#: At speed=max: how far (scene s) the optical devices may run ahead of a streaming simulated
#: F/T, and the longest (host s) one wait lasts (a server that stopped polling holds nothing).
FT_LEAD_S = 0.25
FT_WAIT_S = 2.0
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
        # speed=max: the scene time the optical devices reached (None before any stream),
        # and how far a simulated F/T has released its samples, at which host time
        self._reached: float | None = None
        self._ft_time: dict[int, float] = {}  # streaming F/T sources: released up to
        self._ft_stalled: float | None = None  # a wait timed out with the F/T here
        self._pace = threading.Condition()

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
        if opts.scene_params.get("ft"):
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

    # ------------------------------------------------------------------ speed=max pacing
    @property
    def reached(self) -> float | None:
        """speed=max: scene seconds the optical devices have reached (None before a stream)."""
        with self._pace:
            return self._reached

    def advance(self, scene_s: float) -> None:
        """speed=max: an optical device sent a frame at scene time `scene_s` while streaming."""
        with self._pace:
            if self._reached is None or scene_s > self._reached:
                self._reached = scene_s
                self._pace.notify_all()

    def ft_streaming(self, source: int, on: bool) -> None:
        """speed=max: F/T source `source` (an id) starts (or stops) streaming: the optical
        devices wait for it while it lags."""
        with self._pace:
            if on:
                self._ft_time.setdefault(source, self._reached or 0.0)
            else:
                self._ft_time.pop(source, None)
            self._pace.notify_all()

    def ft_released(self, source: int, scene_s: float) -> None:
        """speed=max: streaming F/T source `source` released its samples up to `scene_s`."""
        with self._pace:
            if source in self._ft_time:
                self._ft_time[source] = max(self._ft_time[source], scene_s)
                self._pace.notify_all()

    def wait_for_ft(self, scene_s: float, stop: threading.Event | None = None) -> None:
        """speed=max: hold an optical device about to send a frame at `scene_s` while a
        streaming simulated F/T lags more than FT_LEAD_S behind (at most FT_WAIT_S, and not
        again until that F/T moves: a stalled one does not slow every frame)."""
        deadline = time.monotonic() + FT_WAIT_S
        with self._pace:
            while self._ft_time and scene_s - min(self._ft_time.values()) > FT_LEAD_S:
                lag = min(self._ft_time.values())
                if lag == self._ft_stalled or (stop is not None and stop.is_set()):
                    return  # an F/T nobody reads holds the device once, not every frame
                if time.monotonic() >= deadline:
                    self._ft_stalled = lag
                    return
                self._pace.wait(0.01)

    def scene_time(self, now: float | None = None) -> float:
        """Scene seconds at host monotonic time `now` (default: now); 0 until the clock
        starts. At speed=max: the scene time the optical devices have reached."""
        if not self.paced:
            return self.reached or 0.0
        epoch = self.epoch
        if epoch is None:
            return 0.0  # the scene waits at its start for the first stream
        t = time.monotonic() if now is None else now
        return (t - epoch) * float(self.speed)
