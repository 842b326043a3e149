"""Drives a SimDevice in time: real time (scaled by `speed`) or as fast as possible.

One thread owns the device (the native core is not thread-safe): it feeds bytes queued by
the host, steps the core when it wants to wake, and hands frames to a sink. With
speed="max" device time jumps straight to the next wake-up while the device streams, so
samples come as fast as the host can take them; the sink may block (back-pressure) and
nothing is lost. While idle after a stream, time runs at the wall clock's rate even at
speed="max".

Device time is scene time, and it stays at 0 until the host first starts a stream: opening,
GET_INFO, CONFIGURE and TIME_SYNC before it are answered at device time 0. The first START is
taken at device time 0, so the first integration window starts at scene time 0 and every
later one on the same grid, whatever the host's open delay: a recording depends on its URL
and options only (host times aside). A paced runner asks `on_clock_start(host time)` for the
epoch at that moment (its world's clock, started by the first stream of any of its devices).
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable

from spectratac.sim.device import SimDevice

MAX = "max"
#: Steps per library call at speed="max": host bytes are looked at between calls, so this
#: bounds command latency (a step is ~30 µs of simulated device work).
RUN_STEPS = 32


class DeviceRunner:
    def __init__(
        self,
        device: SimDevice,
        speed: float | str = 1.0,
        on_clock_start: Callable[[float], float] | None = None,
    ) -> None:
        """`on_clock_start(host monotonic time)`: the host time at which device time was 0,
        asked when the first stream starts (a shared world's clock; paced runs only). By
        default device time 0 is the moment of that first START."""
        if speed != MAX and (not isinstance(speed, (int, float)) or speed <= 0):
            raise ValueError(f"speed={speed!r}: give a positive number or 'max'")
        self.device = device
        self.speed = speed
        self.on_clock_start = on_clock_start
        self._inbound = bytearray()
        self._wake = threading.Condition()
        self._stop = False
        self._thread = threading.Thread(target=self._run, name="spectratac-sim", daemon=True)
        self.error: BaseException | None = None

    def start(self) -> DeviceRunner:
        self._thread.start()
        return self

    def write(self, data: bytes) -> None:
        """Bytes from the host to the device; wakes the device at once."""
        with self._wake:
            self._inbound += data
            self._wake.notify()

    def stop(self) -> None:
        with self._wake:
            self._stop = True
            self._wake.notify()
        if threading.current_thread() is not self._thread and self._thread.is_alive():
            self._thread.join(timeout=5.0)

    @property
    def running(self) -> bool:
        return self._thread.is_alive()

    def _run(self) -> None:
        try:
            self._loop()
        except BaseException as exc:  # surfaced to the transport as a disconnect
            self.error = exc

    def _step_held(self) -> list[bytes]:
        """Step at the current device time, keeping what the device sends; those bytes."""
        dev = self.device
        held: list[bytes] = []

        def keep(data: bytes, _t: int) -> bool:
            held.append(data)
            return True

        sink, dev.on_tx = dev.on_tx, keep
        try:
            dev.step(dev.now_us)
        finally:
            dev.on_tx = sink
        return held

    def _loop(self) -> None:
        dev = self.device
        fast = self.speed == MAX
        rate = 1.0 if fast else float(self.speed)  # device µs per wall µs when paced
        wall0, dev0 = time.monotonic(), dev.now_us
        started = False  # device (scene) time holds at its start until the first START
        while True:
            with self._wake:
                if self._stop:
                    return
                data = bytes(self._inbound)
                self._inbound.clear()
            if data:
                arrived = time.monotonic()
                paced_now = dev0 + int((arrived - wall0) * 1e6 * rate)
                if started and not fast:
                    # a loaded host ran this thread late: first end the integration windows
                    # due by now at their own wake times, as the loop below would have, so a
                    # command (the recorder's TIME_SYNC) never stretches a window in flight
                    while (wake := dev.next_wake_us()) <= paced_now:
                        dev.step(wake)
                dev.feed(data)
                # Answer at once, stamped with the current time: a TIME_SYNC reply stamped
                # with the last step's time would skew every clock fit built on it.
                if started:
                    dev.step(dev.now_us if fast else paced_now)
                else:
                    # output held back until the clock has started: a host that sees its
                    # START acknowledged finds the scene's epoch set
                    replies = self._step_held()
                    if dev.streaming:
                        started = True
                        wall0, dev0 = arrived, dev.now_us
                        if not fast and self.on_clock_start is not None:
                            wall0, dev0 = self.on_clock_start(arrived), 0
                    for reply in replies:
                        if dev.on_tx is not None:
                            dev.on_tx(reply, dev.now_us)
            if not started:
                with self._wake:
                    if not self._inbound and not self._stop:
                        self._wake.wait(0.05)
                continue
            if fast and dev.streaming:
                dev.run(RUN_STEPS)  # step(next_wake_us()) RUN_STEPS times, inside the library
                wall0, dev0 = time.monotonic(), dev.now_us  # paced time resumes from here
                continue
            wake = dev.next_wake_us()
            now = dev0 + int((time.monotonic() - wall0) * 1e6 * rate)
            if wake <= now:
                # step at the wake time itself, as the MCU's timer would fire: a step made
                # late (a loaded host) must not stretch the integration window it ends
                dev.step(wake)
                continue
            with self._wake:
                if not self._inbound and not self._stop:
                    self._wake.wait(min((wake - now) / 1e6 / rate, 0.05))
