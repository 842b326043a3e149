"""The in-process transport behind sim:// URLs: Sensor.open("sim://?scene=tour&speed=max").

It reaches spectratac.device through the ``spectratac.transports`` entry point ``sim``
(`open_sim_transport`), carries its world's ground truth (`SimTransport.ground_truth`) and
says what it is (`SimTransport.link_info`: the scene's speed as clock scale, itself as the
paired F/T URL when the URL asks for one with ``ft=``).

>>> from spectratac.device.ground_truth import ground_truth_of
>>> import numpy as np
>>> link = open_sim_transport("sim://?scene=press&seed=2&speed=max", 921_600)
>>> truth = ground_truth_of(link)
>>> truth.describe()["scene"], truth.contact(np.array([1.5]))["region"].tolist()
('press', [5])
>>> link.link_info
LinkInfo(clock_scale=None, paired_ft_url=None, ground_truth=True, unit_name='twin-2')
>>> link.close()
"""

from __future__ import annotations

import threading
from typing import Any

from spectratac.device.errors import DeviceError, DisconnectedError
from spectratac.device.link_info import LinkInfo
from spectratac.sim.device import SimDevice
from spectratac.sim.faults import FaultLayer
from spectratac.sim.ground_truth import SceneTruth
from spectratac.sim.model_store import ModelStoreError, store_path
from spectratac.sim.named_scenes import scene_settings
from spectratac.sim.runner import MAX, DeviceRunner
from spectratac.sim.url import SimOptions, parse_sim_url
from spectratac.sim.world import SimWorld

HIGH_WATER = 256 * 1024  # bytes the host has not read yet before the device waits / drops


class SimTransport:
    def __init__(self, url: str) -> None:
        self.url = url
        try:
            opts = parse_sim_url(url)
            self.world = SimWorld.join(opts)
        except ValueError as exc:
            raise DeviceError(str(exc)) from None
        self.options = opts
        self.link_info = LinkInfo(
            clock_scale=None if opts.speed == MAX else float(opts.speed),
            paired_ft_url=url if opts.scene_params.get("ft") else None,  # ft=bota|netft
            ground_truth=True,
            unit_name=f"twin-{opts.seed}",  # what twin datasets of this unit call it
        )
        self._out = bytearray()
        self._cond = threading.Condition()
        self._closed = False
        self._closing = threading.Event()  # ends a wait for a lagging simulated F/T
        self._cable_out = False  # unplugged by a fault: reads drain, then report the loss
        self._blocking = opts.speed == MAX
        self.faults: FaultLayer | None = None
        if opts.faults:  # a faulty device: the layer sits on its UART, both ways
            self.faults = FaultLayer(
                url,
                opts.faults,
                opts.fault_params,
                opts.seed,
                self._on_tx,
                self._to_device,
                unplug=self._unplug,
            )
        try:
            self.device = SimDevice(  # its own rig: a device's sensor models are stateful
                self.world.scene,
                opts.seed,
                absent=opts.absent,
                on_tx=self.faults.from_device if self.faults else self._on_tx,
                model_store=store_path(opts.model_store, opts.seed),
                settings=scene_settings(opts.scene),  # hard cases: saturated / dark
            )
        except ModelStoreError as exc:
            self.world.release()
            raise DeviceError(str(exc)) from None
        self.ground_truth = SceneTruth(self.world.scene, self._describe())
        self.world.count_optical(+1)
        on_start = self._clock_started if self.world.paced else None
        self.runner = DeviceRunner(self.device, opts.speed, on_start).start()

    def _clock_started(self, now: float) -> float:
        """The device's first stream started at host time `now` (its runner's thread): the
        world's scene clock starts (unless another device's stream started it); its epoch."""
        epoch = self.world.start_clock(now)
        self.ground_truth.description["epoch"] = epoch
        return epoch

    def _describe(self) -> dict[str, Any]:
        """The session message's "sim" block: what this device plays."""
        world, opts = self.world, self.options
        return {
            "scene": opts.scene,
            "seed": opts.seed,
            "speed": world.speed,
            "params": dict(opts.scene_params),
            "absent": list(opts.absent),
            "epoch": world.epoch,  # host time of scene 0 once a stream started (paced)
            "duration_s": world.scene.duration_s,
            "presses": len(world.scene.presses),
            # a paired simulated F/T's clock against this device's (scene) clock: the dataset
            # averages it over each window exactly, as the scene defines them
            "ft_clock": _ft_clock(opts) if opts.scene_params.get("ft") else None,
        }

    def _on_tx(self, data: bytes, t_us: int) -> bool:
        if self._blocking and self.device.streaming:  # speed=max: the world's scene clock
            self.world.wait_for_ft(t_us / 1e6, self._closing)  # a lagging F/T catches up
            self.world.advance(t_us / 1e6)
        with self._cond:
            while self._blocking and len(self._out) > HIGH_WATER and not self._closed:
                self._cond.wait(0.1)  # back-pressure: speed=max never loses a frame
            if len(self._out) > HIGH_WATER:
                return False  # like a UART whose host stopped reading: the device counts it
            self._out += data
            self._cond.notify_all()
            return True

    def read(self, timeout: float) -> bytes:
        with self._cond:
            if not self._out and not self._closed and not self._cable_out and self.runner.running:
                self._cond.wait(timeout)
            if self._out:
                data = bytes(self._out)
                self._out.clear()
                self._cond.notify_all()
                return data
            if self._closed or self._cable_out or not self.runner.running:
                raise DisconnectedError(
                    f"simulated device {self.url} stopped"
                    + (f": {self.runner.error!r}" if self.runner.error else "")
                )
            return b""

    def write(self, data: bytes) -> None:
        if self._closed or self._cable_out or not self.runner.running:
            raise DisconnectedError(f"simulated device {self.url} stopped")
        if self.faults is not None:
            self.faults.from_host(data)
        else:
            self.runner.write(data)

    def _unplug(self) -> None:
        """The fault layer pulled the cable (called on the device's thread): the host reads
        what reached it, then DisconnectedError."""
        with self._cond:
            self._cable_out = True
            self._cond.notify_all()

    def _to_device(self, data: bytes) -> None:
        if data:
            self.runner.write(data)

    def close(self) -> None:
        self._closing.set()
        with self._cond:
            if self._closed:
                return
            self._closed = True
            self._cond.notify_all()
        if self.faults is not None:
            self.faults.close()
        self.runner.stop()
        self.world.count_optical(-1)
        self.world.release()


def _ft_clock(opts: SimOptions) -> dict[str, float] | None:
    """F/T sensor time = offset + (1 + drift) x device time (paced or at speed=max, the F/T
    runs on the scene clock)."""
    from spectratac.sim.ft_source import FTParams

    params = FTParams.from_sim(opts)
    return {"offset_s": params.offset, "drift": params.drift}


def open_sim_transport(url: str, baudrate: int) -> SimTransport:
    """The ``sim`` transport opener (a simulated device has no baud rate to set)."""
    del baudrate
    return SimTransport(url)
