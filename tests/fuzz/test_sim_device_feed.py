"""SimDevice.feed copies a bounded amount per call: bytes copied grow linearly with the input
(offering the whole remaining input per 4 KiB the core takes copied it quadratically)."""

from __future__ import annotations

from typing import Any

import numpy as np
from spectratac.sim.device import SimDevice
from spectratac.sim.generated.native_abi import RX_CAPACITY
from spectratac.sim.named_scenes import make_scene


class CountingLib:
    """The native library, counting the bytes each rx_feed call was handed."""

    def __init__(self, lib: Any) -> None:
        self._lib = lib
        self.offered = 0
        self.calls = 0

    def stac_sim_rx_feed(self, sim: Any, data: bytes, length: int) -> int:
        self.offered += len(data)
        self.calls += 1
        return int(self._lib.stac_sim_rx_feed(sim, data, length))

    def __getattr__(self, name: str) -> Any:
        return getattr(self._lib, name)


def _offered(size: int) -> tuple[int, int]:
    dev = SimDevice(make_scene("idle"), seed=1)
    counting = CountingLib(dev.lib)
    dev.lib = counting
    garbage = np.random.default_rng(size).integers(1, 256, size, dtype=np.uint8).tobytes()
    dev.feed(garbage)
    return counting.offered, counting.calls


def test_feed_copies_linearly() -> None:
    small = 64 * 1024
    offered_small, _ = _offered(small)
    offered_large, calls = _offered(4 * small)
    # at most one receive buffer per call, and the core takes at least a few hundred bytes
    # per step: a bounded number of copies per input byte, the same for N and 4N bytes
    assert offered_large <= calls * RX_CAPACITY
    assert offered_large <= 16 * 4 * small
    assert offered_large <= 5 * offered_small


def test_feed_still_delivers_frames_after_garbage() -> None:
    from spectratac import protocol
    from spectratac.protocol.generated import messages

    frames: list[bytes] = []
    dev = SimDevice(make_scene("idle"), seed=1, on_tx=lambda data, t: frames.append(data))
    junk = np.random.default_rng(0).integers(1, 256, 3 * RX_CAPACITY + 11, dtype=np.uint8)
    dev.feed(junk.tobytes() + b"\x00" + protocol.encode_frame(messages.GetInfo(), seq=4))
    for k in range(1, 20):  # the core drains its receive buffer a bounded amount per step
        dev.step(dev.now_us + 1000 * k)
    infos = [protocol.decode_frame(f[:-1]).message for f in frames]
    assert any(getattr(m, "board", None) == "native-sim" for m in infos)
