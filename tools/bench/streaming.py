"""Host streaming: frame-to-user latency, samples/s at speed=max, CPU for 16 devices.

    python -m tools.bench.streaming [--json] [--frames N] [--samples N] [--devices N]
                                    [--seconds S] [--rounds R]

1. Latency over a pty: real firmware output (captured from the simulated device) is written to
   a pty one SAMPLE frame at a time; the figure is the time from os.write() to the sample
   coming out of Sensor.read(), p50 and p99, beside the raw pty latency (os.write() to pyserial
   read() of the same bytes) measured alternately in the same run.
2. Samples/s from one simulated device at speed=max through Sensor (no loss allowed), beside
   the bare device loop (firmware core + twin driven as the sim runner drives it, no
   transport, no parsing); R alternating rounds, medians (ranges in the JSON extras).
3. CPU of one process streaming from N simulated devices at 20 Hz (each served by its own
   `spectratac sim serve --tcp` process), in % of one core, beside the same process merely
   reading the raw bytes from the same servers with one selector thread (the cheapest
   reasonable reader); R alternating rounds of S seconds each, medians.
"""

from __future__ import annotations

import contextlib
import json
import os
import selectors
import socket
import statistics
import subprocess
import sys
import threading
import time
import tty

import numpy as np
import serial
from spectratac.device import Sensor
from spectratac.device.transport import SerialTransport
from spectratac.protocol import encode_frame
from spectratac.protocol.generated import messages as m
from spectratac.sim.device import SimDevice
from spectratac.sim.named_scenes import make_scene
from spectratac.sim.runner import RUN_STEPS

from tools.bench.benchlib import Figure, parser, report


def capture_device_frames(n: int) -> tuple[bytes, list[bytes]]:
    """The INFO reply and n SAMPLE frames, produced by the real firmware on the twin."""
    out: list[bytes] = []
    dev = SimDevice(make_scene("tour"), 1, on_tx=lambda data, _t: out.append(data))
    dev.feed(b"\x00" + encode_frame(m.GetInfo(), 1))
    dev.step(0)
    info = out.pop()
    dev.feed(encode_frame(m.Start(), 2))
    dev.step(0)
    out.clear()  # the ACK
    while len(out) < n:
        dev.step(dev.next_wake_us())
    return info, out[:n]


def _pty() -> tuple[int, int, str]:
    master, slave = os.openpty()
    tty.setraw(slave)
    return master, slave, os.ttyname(slave)


def latency(n: int) -> tuple[list[float], list[float]]:
    """(os.write -> Sensor.read, os.write -> pyserial read) per frame, alternating."""
    info, frames = capture_device_frames(n)
    master, slave, path = _pty()
    ref_master, ref_slave, ref_path = _pty()

    def answer_handshake() -> None:  # replays the firmware's INFO when the host asks
        data = b""
        while b"\x00" not in data[1:]:
            data += os.read(master, 4096)
        os.write(master, info)

    threading.Thread(target=answer_handshake, daemon=True).start()
    sensor = Sensor.attach(SerialTransport(path), timeout=5.0)
    ref = serial.Serial(ref_path, timeout=1.0)
    sensor_lat, raw_lat = [], []
    try:
        for frame in frames:
            t0 = time.monotonic()
            os.write(master, frame)
            got = sensor.read(1, timeout=1.0)
            sensor_lat.append(time.monotonic() - t0)
            assert len(got) == 1
            t0 = time.monotonic()
            os.write(ref_master, frame)
            buf = ref.read(1)
            while len(buf) < len(frame):
                buf += ref.read(max(1, ref.in_waiting))
            raw_lat.append(time.monotonic() - t0)
            time.sleep(0.0005)
    finally:
        ref.close()
        sensor.close()
        for fd in (master, slave, ref_master, ref_slave):
            os.close(fd)
    return sensor_lat, raw_lat


def throughput(samples: int, rounds: int) -> tuple[list[float], list[float], int]:
    """(Sensor samples/s per round, bare device samples/s per round, samples lost)."""
    rates, bares, lost = [], [], 0
    for _ in range(rounds):
        with Sensor.open("sim://?scene=tour&speed=max", buffer_size=samples * 2) as sensor:
            sensor.start()
            sensor.read(10, timeout=10)
            t0 = time.perf_counter()
            got = sensor.read(samples, timeout=120)
            rates.append(len(got) / (time.perf_counter() - t0))
            sensor.stop()
            lost += sensor.stats.sample_gaps + sensor.stats.buffer_overflows
            lost += samples - len(got)
        bares.append(bare_rate(samples))
    return rates, bares, lost


def bare_rate(samples: int) -> float:
    """Samples/s of the device alone, stepped the way the speed=max runner steps it."""
    count = [0]
    dev = SimDevice(make_scene("tour"), 1, on_tx=lambda _d, _t: count.__setitem__(0, count[0] + 1))
    dev.feed(encode_frame(m.Start(), 1))
    dev.step(0)
    while count[0] < 10:
        dev.run(RUN_STEPS)
    count[0] = 0
    t0 = time.perf_counter()
    while count[0] < samples:
        dev.run(RUN_STEPS)
    return count[0] / (time.perf_counter() - t0)


def serve_many(n: int) -> list[tuple[subprocess.Popen[str], str]]:
    procs = []
    for i in range(n):
        p = subprocess.Popen(
            [
                sys.executable,
                "-m",
                "spectratac",
                "sim",
                "serve",
                "--tcp",
                "0",
                "--json",
                "--scene",
                "idle",
                "--seed",
                str(i),
            ],
            stdout=subprocess.PIPE,
            text=True,
        )
        procs.append(p)
    try:
        return [(p, json.loads(p.stdout.readline())["url"]) for p in procs]  # type: ignore[union-attr]
    except BaseException:  # one did not start: stop them all, none outlives the bench
        for p in procs:
            p.kill()
            p.wait()
        raise


def _cpu_percent(seconds: float) -> float:
    c0, t0 = time.process_time(), time.monotonic()
    time.sleep(seconds)
    return (time.process_time() - c0) / (time.monotonic() - t0) * 100


def _raw_round(urls: list[str], seconds: float) -> tuple[float, int]:
    """Start each device over a fresh socket and read its bytes with one selector thread."""
    socks = []
    for url in urls:
        host, port = url.removeprefix("socket://").rsplit(":", 1)
        sock = socket.create_connection((host, int(port)), timeout=10)
        sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        sock.sendall(b"\x00" + encode_frame(m.Start(), 1))
        sock.setblocking(False)
        socks.append(sock)
    sel = selectors.DefaultSelector()
    for sock in socks:
        sel.register(sock, selectors.EVENT_READ)
    stop = threading.Event()
    received = [0]

    def drain() -> None:
        while not stop.is_set():
            for key, _ in sel.select(0.1):
                with contextlib.suppress(BlockingIOError):
                    received[0] += len(key.fileobj.recv(65536))  # type: ignore[union-attr]

    thread = threading.Thread(target=drain, daemon=True)
    thread.start()
    time.sleep(1.0)
    start = received[0]
    cpu = _cpu_percent(seconds)
    got = received[0] - start
    stop.set()
    thread.join(timeout=2)
    for sock in socks:
        sock.sendall(b"\x00" + encode_frame(m.Stop(), 2))
        sel.unregister(sock)
        sock.close()
    sel.close()
    return cpu, got


def _sensor_round(urls: list[str], seconds: float) -> tuple[float, int]:
    sensors = [Sensor.open(url, timeout=10.0) for url in urls]
    try:
        for s in sensors:
            s.start()
        time.sleep(1.0)
        for s in sensors:
            s.read(10_000, timeout=0)
        cpu = _cpu_percent(seconds)
        received = sum(len(s.read(100_000, timeout=0)) for s in sensors)
        for s in sensors:
            s.stop()
    finally:
        for s in sensors:
            s.close()
    return cpu, received


def cpu_many(n: int, seconds: float, rounds: int) -> tuple[list[float], list[float], int, int]:
    """(% of a core through Sensor per round, % reading raw bytes per round, samples received
    in the last Sensor round, raw bytes received in the last raw round)."""
    servers = serve_many(n)
    urls = [url for _, url in servers]
    sensor_cpu, raw_cpu, received, raw_bytes = [], [], 0, 0
    try:
        for _ in range(rounds):
            cpu, raw_bytes = _raw_round(urls, seconds)
            raw_cpu.append(cpu)
            cpu, received = _sensor_round(urls, seconds)
            sensor_cpu.append(cpu)
        return sensor_cpu, raw_cpu, received, raw_bytes
    finally:
        for p, _ in servers:
            p.terminate()
        for p, _ in servers:
            p.wait(timeout=10)


def _spread(values: list[float]) -> list[float]:
    return [round(min(values), 2), round(max(values), 2)]


def main() -> int:
    p = parser(__doc__.splitlines()[0])
    p.add_argument("--frames", type=int, default=2000, help="frames for the latency test")
    p.add_argument("--samples", type=int, default=20000, help="samples per throughput round")
    p.add_argument("--devices", type=int, default=16)
    p.add_argument("--seconds", type=float, default=5.0, help="CPU measurement per round")
    p.add_argument("--rounds", type=int, default=3, help="alternating rounds per figure")
    args = p.parse_args()
    s_lat, r_lat = latency(args.frames)
    p50, p99 = (float(np.percentile(s_lat, q)) * 1e6 for q in (50, 99))
    r50, r99 = (float(np.percentile(r_lat, q)) * 1e6 for q in (50, 99))
    rates, bares, lost = throughput(args.samples, args.rounds)
    rate, bare = statistics.median(rates), statistics.median(bares)
    cpus, raws, received, raw_bytes = cpu_many(args.devices, args.seconds, args.rounds)
    cpu, raw_cpu = statistics.median(cpus), statistics.median(raws)
    figures = [
        Figure("frame-to-user latency p50", p50, "µs", "raw pty p50", r50, p50 / r50),
        Figure(
            "frame-to-user latency p99",
            p99,
            "µs",
            "raw pty p99",
            r99,
            p99 / r99,
            {"frames": len(s_lat), "mean_us": statistics.mean(s_lat) * 1e6},
        ),
        Figure(
            "samples/s at speed=max",
            rate,
            "samples/s",
            "bare device loop",
            bare,
            rate / bare,
            {"lost": lost, "rounds": _spread(rates), "bare_rounds": _spread(bares)},
        ),
        Figure(
            f"CPU, {args.devices} devices at 20 Hz",
            cpu,
            "% core",
            "raw reads, one selector thread",
            raw_cpu,
            cpu / raw_cpu if raw_cpu else float("inf"),
            {
                "samples": received,
                "expected": int(args.devices * 20 * args.seconds),
                "raw_bytes": raw_bytes,
                "rounds": _spread(cpus),
                "raw_rounds": _spread(raws),
            },
        ),
    ]
    report(figures, args.json)
    return 0


if __name__ == "__main__":
    sys.exit(main())
