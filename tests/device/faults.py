"""Fault-injecting transports: wrap a real transport and damage what crosses it."""

from __future__ import annotations

import random
from collections.abc import Callable

from spectratac.device.transport import Transport
from spectratac.protocol import Frame, decode_frame, encode_raw
from spectratac.protocol.framing import FrameError


class CorruptingTransport:
    """Flips random bits in a fraction of the bytes the device sends, once `armed`."""

    def __init__(self, inner: Transport, rate: float, seed: int = 1) -> None:
        self.inner = inner
        self.url = inner.url
        self.rate = rate
        self.armed = False
        self.flipped = 0
        self._rng = random.Random(seed)

    def read(self, timeout: float) -> bytes:
        data = self.inner.read(timeout)
        if not self.armed or not data:
            return data
        out = bytearray(data)
        for i in range(len(out)):
            if self._rng.random() < self.rate:
                out[i] ^= 1 << self._rng.randrange(8)
                self.flipped += 1
        return bytes(out)

    def write(self, data: bytes) -> None:
        self.inner.write(data)

    def close(self) -> None:
        self.inner.close()


class RewritingTransport:
    """Passes every device frame through `rewrite(frame) -> wire bytes` (with its 0x00):
    a device that sends frames the way the test needs them (bad times, another major)."""

    def __init__(self, inner: Transport, rewrite: Callable[[Frame], bytes]) -> None:
        self.inner = inner
        self.url = inner.url
        self.rewrite = rewrite
        self._pending = b""

    def read(self, timeout: float) -> bytes:
        *frames, self._pending = (self._pending + self.inner.read(timeout)).split(b"\x00")
        out = b""
        for encoded in frames:
            try:
                frame = decode_frame(encoded)
            except FrameError:
                continue
            out += self.rewrite(frame)
        return out

    def write(self, data: bytes) -> None:
        self.inner.write(data)

    def close(self) -> None:
        self.inner.close()


class LineNoiseTransport:
    """Damages what the host sends, once armed: `noise` bytes put before the next write
    (stray bytes on the line), or `drop` the next write (a command lost on the way)."""

    def __init__(self, inner: Transport) -> None:
        self.inner = inner
        self.url = inner.url
        self.noise = b""
        self.drop = 0  # writes still to drop
        self.dropped: list[bytes] = []

    def read(self, timeout: float) -> bytes:
        return self.inner.read(timeout)

    def write(self, data: bytes) -> None:
        if self.drop:
            self.drop -= 1
            self.dropped.append(data)
            return
        noise, self.noise = self.noise, b""
        self.inner.write(noise + data)

    def close(self) -> None:
        self.inner.close()


class FutureMajorTransport(RewritingTransport):
    """Re-frames every device frame as protocol major 2: a firmware from another major."""

    def __init__(self, inner: Transport) -> None:
        super().__init__(
            inner,
            lambda f: encode_raw(f.message.TYPE_ID, f.message.pack(), f.seq, (2, 1)),
        )
