"""A simulated Bota Systems serial F/T sensor on a pty, writing real Bota frames.

Like the device it boots streaming ("App Init", then binary frames), answers the text
commands 'C' (configuration mode: stop streaming), 'c,…' (communication setup), 'f,sinc,…'
(filter setup: the sample period becomes sinc/51200 s) and 'R' (run: stream) with
"r,0,<letter>,0", and stamps each frame with its own microsecond clock. Losses are split
between frames that vanish (a USB-serial buffer overrun: no bytes) and frames with a
damaged byte (the host sees a CRC error). Frames written while no host reads are dropped.

>>> from spectratac.sim.url import parse_sim_url
>>> from spectratac.sim.world import SimWorld
>>> from spectratac.sim.ft_source import FTParams, FTSource
>>> world = SimWorld.join(parse_sim_url("sim://?scene=press&seed=1&speed=10"))
>>> with BotaServer(FTSource(world, FTParams())) as server:
...     server.path.startswith("/dev/pts/")
True
>>> world.release()
"""

from __future__ import annotations

import contextlib
import dataclasses
import errno
import math
import os
import select
import threading
import time
import tty
from pathlib import Path

import numpy as np

from spectratac.ft.botaframe import FRAME_SIZE, encode_frames
from spectratac.sim.ft_source import FTSource

SINC_CLOCK_HZ = 51200.0
TEMPERATURE_C = 31.5
#: How long a write waits for a host that has been reading. A host's reader thread on a loaded
#: machine (load 50, two busy loops) stalls for over 0.5 s; frames dropped then made a
#: recording depend on the scheduler, so only a host that stopped reading loses frames.
PATIENCE_S = 10.0
#: At speed=max, even before the host has read: the device waits for us, so nothing is lost.
PATIENCE_MAX_S = 5.0
#: Paced, frames go out in one write every 10 ms, as a USB-serial adapter's latency timer
#: sends them (FTDI's is 16 ms by default), not one write per 1 kHz frame: this thread and
#: the host's reader woke 1,000 times a second each, and each wake-up took the GIL from
#: the live page's threads in the same process (18 % of a core between the two).
EMIT_EVERY_S = 0.01


class BotaServer:
    """Serves one simulated Bota sensor on a new pty; `path` is the port to open."""

    def __init__(self, source: FTSource, link: Path | None = None) -> None:
        self.source = source
        self._rng = np.random.default_rng([source.world.seed, 0xB07A])
        master, slave = os.openpty()
        tty.setraw(slave)
        self.path = os.ttyname(slave)
        os.close(slave)  # the host opens it by name
        os.set_blocking(master, False)
        self._fd = master
        self.link = link
        if link is not None:
            tmp = link.with_name(link.name + ".new")
            with contextlib.suppress(FileNotFoundError):
                tmp.unlink()
            tmp.symlink_to(self.path)
            tmp.replace(link)
        self.running = True  # the sensor boots streaming
        source.streaming(True)
        self.sent = 0
        self.dropped = 0  # frames lost on purpose (loss) or because nobody read them
        self.corrupted = 0
        self._stop = threading.Event()
        self._host_reading = False
        self._write(b"App Init\r\n")
        self._thread = threading.Thread(target=self._run, name="sim-bota", daemon=True)
        self._thread.start()

    @property
    def url(self) -> str:
        return f"bota://{self.link or self.path}"

    def stop(self) -> None:
        self.source.streaming(False)
        self._stop.set()
        self._thread.join(timeout=2.0)
        os.close(self._fd)
        if self.link is not None:
            with contextlib.suppress(FileNotFoundError):
                self.link.unlink()

    def __enter__(self) -> BotaServer:
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()

    # ------------------------------------------------------------------ device loop
    def _run(self) -> None:
        emitted = -math.inf
        while not self._stop.is_set():
            wait = 0.05
            if self.running:
                due = self.source.next_due_host()
                if self.source.world.paced:  # the adapter's latency timer (at max: no wait)
                    due = max(due, emitted + EMIT_EVERY_S)
                wait = min(wait, max(0.0002, due - time.monotonic()))
            readable, _, _ = select.select([self._fd], [], [], wait)
            if readable:
                self._commands()
            if self.running:
                self._emit()
                emitted = time.monotonic()

    def _commands(self) -> None:
        try:
            data = os.read(self._fd, 4096)
        except BlockingIOError:
            return
        except OSError as exc:  # EIO: no host has the pty open
            if exc.errno != errno.EIO:
                raise
            time.sleep(0.02)
            return
        for piece in data.replace(b"\r", b"\n").split(b"\n"):
            text = piece.strip().decode("ascii", "replace")
            if text[:2] in ("c,", "f,"):
                self._setup(text)
            else:
                for letter in text:
                    self._mode(letter)

    def _mode(self, letter: str) -> None:
        if letter == "C":
            if self.running and self.source.world.epoch is not None:
                # what came due before the command is sent, however late this thread runs: a
                # recording's end is then the scene's, not the scheduler's
                self._emit()
            self.running = False
            self.source.streaming(False)
        elif letter == "R":
            self.source.skip()  # streaming resumes with the next sample
            self.running = True
            self.source.streaming(True)
        else:
            self._write(f"r,1,{letter},0".encode())
            return
        self._write(f"r,0,{letter},0".encode())

    def _setup(self, text: str) -> None:
        fields = text.split(",")
        try:
            values = [int(v) for v in fields[1:]]
        except ValueError:
            values = []
        if len(values) != 4 or self.running:
            self._write(f"r,1,{fields[0]},0".encode())  # malformed, or not in config mode
            return
        if fields[0] == "f" and values[0] > 0:
            params = dataclasses.replace(self.source.params, rate=SINC_CLOCK_HZ / values[0])
            self.source = FTSource(self.source.world, params)
        self._write(f"r,0,{fields[0]},0".encode())

    def _emit(self) -> None:
        batch = self.source.pop_due()
        n = len(batch.k)
        if n == 0:
            return
        t_us = np.rint(batch.sensor_time * 1e6).astype(np.int64)
        wire = bytearray(encode_frames(np.zeros(n), batch.wrench, t_us, np.full(n, TEMPERATURE_C)))
        lost = np.flatnonzero(batch.lost)
        vanish = lost[self._rng.random(len(lost)) < 0.5]
        for i in lost:  # damage one data byte of a lost frame
            if i not in vanish:
                at = int(i) * FRAME_SIZE + 1 + int(self._rng.integers(34))
                wire[at] ^= 1 << int(self._rng.integers(8))
                self.corrupted += 1
        if len(vanish):
            keep = np.ones(n, dtype=bool)
            keep[vanish] = False
            frames = np.frombuffer(bytes(wire), dtype=np.uint8).reshape(n, FRAME_SIZE)
            wire = bytearray(frames[keep].tobytes())
            self.dropped += len(vanish)
        if self._write(bytes(wire)):
            self.sent += n - len(vanish)
        else:
            self.dropped += n - len(vanish)

    def _write(self, data: bytes) -> bool:
        """Write to the pty. While a host keeps up, wait (bounded) for it to drain the pty:
        at speed > 1 the simulated link is far faster than a real UART, and a host thread
        that is briefly descheduled should not see losses a real sensor would not cause.
        A host that stops reading loses what does not fit, like behind a real adapter."""
        view = memoryview(data)
        # at speed=max the device waits for us, so the host is given time to read it all
        patience = PATIENCE_S if self._host_reading else 0.0
        if not self.source.world.paced:
            patience = max(patience, PATIENCE_MAX_S)
        deadline = time.monotonic() + patience
        while view:
            try:
                view = view[os.write(self._fd, view) :]
                continue
            except BlockingIOError:
                pass
            except OSError:
                break
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                break
            select.select([], [self._fd], [], min(remaining, 0.02))
        self._host_reading = not view
        return not view
