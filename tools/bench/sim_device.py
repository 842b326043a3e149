"""Simulated device input throughput: bytes the host sends into SimDevice.feed.

    python -m tools.bench.sim_device [--megabytes M] [--rounds R] [--json]

Figures, each beside a reference measured in the same run:
- feed of M MiB of line noise in one call, in bytes/s, beside the same bytes fed 4 KiB per
  call (1.0 when feed's work is linear in its input; copying the whole rest of the input per
  4 KiB the core takes made 120 MB stall for over a minute);
- feed of 4x the bytes in one call beside M MiB in one call, in bytes/s (1.0 when linear);
- the simulated device's input rate as a multiple of the real link (921600 Bd).
"""

from __future__ import annotations

import sys

import numpy as np
from spectratac.sim.device import SimDevice
from spectratac.sim.named_scenes import make_scene

from tools.bench.benchlib import Figure, parser, report, side_by_side

LINK_BYTES_PER_S = 921_600 / 10


def noise(size: int) -> bytes:
    """Line noise: random bytes, one in 64 a frame delimiter (short broken frames and long
    oversize runs both occur)."""
    rng = np.random.default_rng(5)
    data = rng.integers(1, 256, size, dtype=np.uint8)
    data[rng.random(size) < 1 / 64] = 0
    return data.tobytes()


class Feeder:
    """Feeds `data` into a fresh device per call (devices built ahead: only feed is timed)."""

    def __init__(self, data: bytes, chunk: int | None, calls: int) -> None:
        self.data = data
        self.chunk = chunk
        self.devices = [SimDevice(make_scene("idle"), seed=1) for _ in range(calls)]

    def __call__(self) -> int:
        dev = self.devices.pop()
        if self.chunk is None:
            dev.feed(self.data)
        else:
            for i in range(0, len(self.data), self.chunk):
                dev.feed(self.data[i : i + self.chunk])
        return len(self.data)


def main() -> int:
    p = parser(__doc__.splitlines()[0])
    p.add_argument("--megabytes", type=float, default=4.0, help="MiB of input per round")
    p.add_argument("--rounds", type=int, default=3)
    args = p.parse_args()
    data = noise(int(args.megabytes * (1 << 20)))
    big = noise(4 * len(data))
    Feeder(data[:65536], None, 1)()  # warm: library loaded
    rounds = args.rounds
    figures = []
    s, r = side_by_side(Feeder(data, None, rounds), Feeder(data, 4096, rounds), rounds)
    figures.append(Figure("sim feed, one call", s, "bytes/s", "4 KiB calls", r, s / r))
    s4, s1 = side_by_side(Feeder(big, None, rounds), Feeder(data, None, rounds), rounds)
    figures.append(Figure("sim feed, 4x input", s4, "bytes/s", "1x input", s1, s4 / s1))
    figures.append(
        Figure(
            "sim feed vs link",
            s1,
            "bytes/s",
            "921600 Bd link",
            LINK_BYTES_PER_S,
            s1 / LINK_BYTES_PER_S,
        )
    )
    report(figures, args.json)
    return 0


if __name__ == "__main__":
    sys.exit(main())
