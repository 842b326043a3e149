"""F/T driver throughput and the cost of simulated F/T sensors.

    python -m tools.bench.ft [--records N] [--seconds S] [--json]

Figures, each beside a reference measured in the same run:
- Bota driver parse (resync-capable frame parser + records, 4 KiB chunks, in memory), in
  records/s, as a ratio to an unchecked NumPy decode of the same bytes (aligned frames, no
  CRC, no resync: the least any decoder does);
- Bota frame parser fed 1 MiB chunks beside the same bytes in 4 KiB chunks (1.0 when the
  parser's work is linear in the chunk size; a whole-buffer rescan per damaged frame made
  a 1 MB chunk take seconds), and line noise dense with false headers (bytes/s) beside
  good frames (bytes/s);
- Bota driver over a pty (reader thread, end to end) beside a raw read of the same bytes
  from the same kind of pty;
- Net F/T driver parse (packets -> records: sequence, loss, scaling, 256 packets a poll),
  beside an unchecked NumPy decode of the same joined packets;
- each as a multiple of the sensor's real link (Bota at 460800 Bd, Net F/T at 7 kHz);
- CPU used by a simulated sensor plus its driver in this process, per wall second, at
  speed 1 and 10 (1 kHz scene rate: 1k and 10k records per wall second), beside one core.
"""

from __future__ import annotations

import os
import sys
import threading
import time
import tty

import numpy as np
from spectratac.ft import FT_RECORD, botaframe, open_ft, rdt

from tools.bench.benchlib import Figure, parser, report, side_by_side

BOTA_LINK_FPS = 460_800 / 10 / botaframe.FRAME_SIZE
NETFT_MAX_RATE = 7000.0


def bota_bytes(n: int) -> bytes:
    rng = np.random.default_rng(1)
    k = np.arange(n)
    return botaframe.encode_frames(np.zeros(n), rng.normal(size=(n, 6)), k * 1000, np.full(n, 25.0))


def netft_packets(n: int) -> list[bytes]:
    rng = np.random.default_rng(2)
    k = np.arange(1, n + 1)
    wire = rdt.encode_records(k, k, np.zeros(n), rng.integers(-(10**6), 10**6, (n, 6)))
    return [wire[i : i + rdt.RECORD_SIZE] for i in range(0, len(wire), rdt.RECORD_SIZE)]


def unchecked_bota(data: bytes) -> np.ndarray:
    """The least a Bota decoder does: view aligned frames, copy the fields (no CRC, no sync)."""
    frames = np.frombuffer(data, dtype=botaframe.FRAME_DTYPE)["data"]
    out = np.empty(len(frames), dtype=FT_RECORD)
    out["sensor_time"] = frames["timestamp"] * 1e-6
    out["wrench"] = frames["forces"]
    out["status"] = frames["status"]
    return out


def unchecked_netft(packets: list[bytes]) -> np.ndarray:
    """The least a Net F/T decoder does: join packets, view records, scale the counts."""
    recs = np.frombuffer(b"".join(packets), dtype=rdt.RDT_RECORD)
    out = np.empty(len(recs), dtype=FT_RECORD)
    out["sequence"] = recs["rdt_sequence"]
    out["wrench"] = recs["counts"] / 1e6
    out["status"] = recs["status"]
    return out


class Pty:
    def __init__(self) -> None:
        self.master, slave = os.openpty()
        tty.setraw(slave)
        self.path = os.ttyname(slave)
        os.close(slave)

    def pump(self, data: bytes) -> threading.Thread:
        def run() -> None:
            view = memoryview(data)
            while view:
                view = view[os.write(self.master, view[:65536]) :]

        t = threading.Thread(target=run, daemon=True)
        t.start()
        return t

    def close(self) -> None:
        os.close(self.master)


def bota_driver_parse(data: bytes) -> tuple[callable, callable]:
    pty = Pty()
    ft = open_ft(f"bota://{pty.path}?configure=0&rate=1000")
    n = len(data) // botaframe.FRAME_SIZE

    def subject() -> int:
        from spectratac.ft.sequence import SequenceTracker, Unwrapper

        ft._parser = botaframe.FrameParser()  # type: ignore[attr-defined]
        ft._t0_us = None  # type: ignore[attr-defined]
        ft._unwrap = Unwrapper(32)  # type: ignore[attr-defined]
        ft._tracker = SequenceTracker(ft.stats)  # type: ignore[attr-defined]
        got = 0
        for i in range(0, len(data), 4096):
            frames = ft._parser.feed(data[i : i + 4096])  # type: ignore[attr-defined]
            got += len(ft._records(frames, np.full(len(frames), 0.0)))  # type: ignore[attr-defined]
        assert got == n, got
        return got

    def reference() -> int:
        return len(unchecked_bota(data))

    subject.close = lambda: (ft.close(), pty.close())  # type: ignore[attr-defined]
    return subject, reference


def parse_chunks(data: bytes, chunk: int) -> int:
    """Bytes through a fresh FrameParser fed `chunk` bytes at a time."""
    p = botaframe.FrameParser()
    for i in range(0, len(data), chunk):
        p.feed(data[i : i + chunk])
    return len(data)


def line_noise(size: int) -> bytes:
    """Random bytes with one in 20 a false header (0xAA): the parser's worst case."""
    rng = np.random.default_rng(4)
    noise = rng.integers(0, 256, size, dtype=np.uint8)
    noise[rng.random(size) < 0.05] = botaframe.HEADER
    return noise.tobytes()


def bota_over_pty(data: bytes) -> tuple[callable, callable]:
    n = len(data) // botaframe.FRAME_SIZE

    def subject() -> int:
        pty = Pty()
        try:
            with open_ft(f"bota://{pty.path}?configure=0&rate=1000", timeout=10.0) as ft:
                ft.start()
                writer = pty.pump(data)
                got = 0
                while got < n:
                    rows = ft.read(n - got, timeout=10.0)
                    if len(rows) == 0:
                        raise RuntimeError(f"bota over pty stalled at {got} of {n}")
                    got += len(rows)
                writer.join()
            return got
        finally:
            pty.close()

    def reference() -> int:
        import serial

        pty = Pty()
        try:
            port = serial.Serial(pty.path, 460800, timeout=0)
            fd = port.fileno()
            import select

            writer = pty.pump(data)
            total = 0
            while total < len(data):
                select.select([fd], [], [], 1.0)
                total += len(os.read(fd, 1 << 16))
            writer.join()
            port.close()
            return total // botaframe.FRAME_SIZE
        finally:
            pty.close()

    return subject, reference


def netft_driver_parse(packets: list[bytes]) -> tuple[callable, callable]:
    from spectratac.ft.netft import NetFTSensor
    from spectratac.ft.records import FTInfo

    times = [float(i) for i in range(len(packets))]

    def subject() -> int:
        ft = NetFTSensor(
            "netft://bench",
            FTInfo("netft", rate_hz=1000.0, counts_per_force=1e6, counts_per_torque=1e6),
            timeout=1.0,
            buffer_size=1,
        )
        ft._setup(None, "realtime", 1000.0)  # type: ignore[arg-type]
        got = 0
        for i in range(0, len(packets), 256):  # a poll's worth at a time
            got += len(ft._parse(packets[i : i + 256], times[i : i + 256]))
        return got

    def reference() -> int:
        return len(unchecked_netft(packets))

    return subject, reference


def sim_cpu(kind: str, speed: float, seconds: float) -> tuple[float, int]:
    """(process CPU s per wall s, records received) streaming a simulated sensor."""
    url = f"sim://?scene=calibration&seed=3&speed={speed:g}&ft={kind}"
    with open_ft(url, timeout=5.0) as ft:
        ft.read(100, timeout=5.0)  # warm: twin built, stream running
        c0, w0 = time.process_time(), time.perf_counter()
        got = 0
        while time.perf_counter() - w0 < seconds:
            got += len(ft.read(1 << 16, timeout=0.05))
        cpu = (time.process_time() - c0) / (time.perf_counter() - w0)
    return cpu, got


def main() -> int:
    p = parser(__doc__.splitlines()[0])
    p.add_argument("--records", type=int, default=200_000, help="records per throughput round")
    p.add_argument("--seconds", type=float, default=3.0, help="seconds per CPU measurement")
    p.add_argument("--rounds", type=int, default=5)
    args = p.parse_args()
    n = args.records
    data = bota_bytes(n)
    packets = netft_packets(n)
    figures = []

    sub, ref = bota_driver_parse(data)
    s, r = side_by_side(sub, ref, args.rounds)
    sub.close()  # type: ignore[attr-defined]
    figures.append(Figure("bota driver parse", s, "records/s", "unchecked NumPy decode", r, s / r))
    figures.append(
        Figure(
            "bota parse vs link", s, "records/s", "460800 Bd link", BOTA_LINK_FPS, s / BOTA_LINK_FPS
        )
    )
    mixed = bytearray(data)
    mixed[5 :: 37 * 50] = bytes(len(mixed[5 :: 37 * 50]))  # a damaged frame in fifty
    s, r = side_by_side(
        lambda: parse_chunks(bytes(mixed), 1 << 20),
        lambda: parse_chunks(bytes(mixed), 4096),
        args.rounds,
    )
    figures.append(Figure("bota parse, 1 MiB chunks", s, "bytes/s", "4 KiB chunks", r, s / r))
    noise = line_noise(len(data))
    s, r = side_by_side(
        lambda: parse_chunks(noise, 1 << 20), lambda: parse_chunks(data, 1 << 20), args.rounds
    )
    figures.append(Figure("bota parse of line noise", s, "bytes/s", "good frames", r, s / r))
    sub, ref = bota_over_pty(data)
    s, r = side_by_side(sub, ref, max(1, args.rounds // 2))
    figures.append(Figure("bota driver over pty", s, "records/s", "raw pty read", r, s / r))
    sub, ref = netft_driver_parse(packets)
    s, r = side_by_side(sub, ref, args.rounds)
    figures.append(Figure("netft driver parse", s, "records/s", "unchecked NumPy decode", r, s / r))
    figures.append(
        Figure(
            "netft parse vs 7 kHz",
            s,
            "records/s",
            "Net F/T max rate",
            NETFT_MAX_RATE,
            s / NETFT_MAX_RATE,
        )
    )
    for kind in ("netft", "bota"):
        for speed in (1.0, 10.0):
            cpu, got = sim_cpu(kind, speed, args.seconds)
            figures.append(
                Figure(
                    f"sim {kind}+driver CPU, speed {speed:g}",
                    cpu,
                    "core",
                    "one core",
                    1.0,
                    cpu,
                    {"records_per_s": got / args.seconds},
                )
            )
    report(figures, args.json)
    return 0


if __name__ == "__main__":
    sys.exit(main())
