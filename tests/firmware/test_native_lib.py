"""The native port as a shared library through its C ABI
(firmware/ports/native/generated/stac_sim.h), driven from Python with ctypes the way the simulated
device drives it: caller-supplied I2C, PWM, UART and clock, bytes fed in, time advanced by the
caller. Its frames are decoded with the host's own protocol package, so the C and Python sides of
the protocol are cross-checked."""

from __future__ import annotations

import ctypes
from pathlib import Path

import pytest
from spectratac.protocol import StreamDecoder, encode_frame
from spectratac.protocol.framing import Frame
from spectratac.protocol.generated import messages
from spectratac.sim.generated import native_abi
from spectratac.sim.native import CLOCK_FN, I2C_FN, PWM_FN, TX_FN, Callbacks, declare


class Nack(Exception):
    """The model's way to say: nobody acknowledged."""


class Veml3328Model:
    """Just enough of the sensor for an ABI test: registers, active-force trigger, timing."""

    IT_US = (50_000, 100_000, 200_000, 400_000)

    def __init__(self, counts: tuple[int, int, int, int, int], present: bool = True) -> None:
        self.present = present
        self.conf = 0x8001
        self.counts = counts  # R, G, B, C, IR
        self.latched = (0, 0, 0, 0, 0)
        self.done_at: int | None = None

    def transfer(self, now_us: int, write: bytes, read_len: int) -> bytes:
        if not self.present:
            raise Nack
        if self.done_at is not None and now_us >= self.done_at:
            self.done_at = None
            self.conf &= ~0x0004
            self.latched = self.counts
        reg = write[0]
        if len(write) == 3 and reg == 0x00:
            self.conf = write[1] | write[2] << 8
            if self.conf & 0x000C == 0x000C and self.conf & 0x8001 == 0:
                self.done_at = now_us + self.IT_US[(self.conf >> 4) & 3]
            return b""
        value = {
            0x00: self.conf,
            0x0C: 0x0028,
            0x05: self.latched[0],
            0x06: self.latched[1],
            0x07: self.latched[2],
            0x04: self.latched[3],
            0x08: self.latched[4],
        }.get(reg, 0)
        return value.to_bytes(2, "little")[:read_len]


class Device:
    """One simulated device instance on the library."""

    def __init__(self, lib: ctypes.CDLL, board: bytes, sensors: list[Veml3328Model]) -> None:
        self.lib = lib
        self.sensors = sensors
        self.now = 0
        self.tx = bytearray()
        self.pwm: dict[tuple[int, int], int] = {}
        self.mem = (ctypes.c_uint64 * ((lib.stac_sim_sizeof() + 7) // 8))()
        self.cb = Callbacks(None, I2C_FN(self._i2c), PWM_FN(self._pwm), TX_FN(self._tx), CLOCK_FN())
        uid = bytes(range(12))
        caps = lib.stac_sim_default_capabilities()
        assert lib.stac_sim_init(self.mem, ctypes.byref(self.cb), board, caps, uid, 0, 0) == 0

    def _i2c(self, user, now, bus, addr, wr, wr_len, rd, rd_len, timeout):  # type: ignore[no-untyped-def]
        try:
            data = self.sensors[bus].transfer(now, bytes(wr[:wr_len]), rd_len)
        except Nack:
            return 1
        for i, b in enumerate(data):
            rd[i] = b
        return 0

    def _pwm(self, user, now, led, colour, duty):  # type: ignore[no-untyped-def]
        self.pwm[(led, colour)] = duty

    def _tx(self, user, now, data, length):  # type: ignore[no-untyped-def]
        self.tx += bytes(data[:length])
        return length

    def feed(self, data: bytes) -> int:
        return int(self.lib.stac_sim_rx_feed(self.mem, data, len(data)))

    def run(self, until_us: int) -> int:
        """Step at the times the device asks for; returns the number of steps."""
        steps = 0
        while self.now < until_us:
            self.lib.stac_sim_step(self.mem, self.now)
            steps += 1
            wake = int(self.lib.stac_sim_next_wake_us(self.mem))
            self.now = max(wake, self.now + 1)
        return steps


@pytest.fixture(scope="module")
def lib(sim_library: Path) -> ctypes.CDLL:
    lib = declare(ctypes.CDLL(str(sim_library)))
    return lib


def decode(data: bytes) -> tuple[list[Frame], StreamDecoder]:
    decoder = StreamDecoder()
    return decoder.feed(data), decoder


def test_abi_basics(lib: ctypes.CDLL) -> None:
    assert lib.stac_sim_abi_version() == native_abi.ABI_VERSION == 2  # 2: stac_sim_in_bootloader
    assert lib.stac_sim_sizeof() > 1000
    assert lib.stac_sim_default_capabilities() & messages.Capabilities.CAP_SIMULATED
    mem = (ctypes.c_uint64 * ((lib.stac_sim_sizeof() + 7) // 8))()
    assert lib.stac_sim_init(mem, None, None, 0, None, 0, 0) == -1


def test_two_instances_stream_independently(lib: ctypes.CDLL) -> None:
    a = Device(lib, b"sim-a", [Veml3328Model((10 * k + 1, 2, 3, 4, 5)) for k in range(3)])
    b = Device(
        lib,
        b"sim-b",
        [
            Veml3328Model((7, 7, 7, 7, 7)),
            Veml3328Model((0, 0, 0, 0, 0), present=False),
            Veml3328Model((9, 9, 9, 9, 9)),
        ],
    )
    for dev in (a, b):
        dev.feed(
            b"\x00"
            + encode_frame(messages.GetInfo(), seq=1)
            + encode_frame(messages.Start(), seq=2)
        )
    steps = a.run(1_000_000)
    b.run(1_000_000)
    frames_a, dec_a = decode(bytes(a.tx))
    frames_b, dec_b = decode(bytes(b.tx))
    assert dec_a.stats.dropped == dec_b.stats.dropped == 0
    info_a, info_b = frames_a[0].message, frames_b[0].message
    assert isinstance(info_a, messages.Info) and isinstance(info_b, messages.Info)
    assert (info_a.board, info_b.board) == ("sim-a", "sim-b")
    assert (info_a.sensor_present, info_b.sensor_present) == (0b111, 0b101)
    assert info_a.capabilities & messages.Capabilities.CAP_SIMULATED
    assert info_a.device_uid == bytes(range(12))
    samples_a = [f.message for f in frames_a if isinstance(f.message, messages.Sample)]
    samples_b = [f.message for f in frames_b if isinstance(f.message, messages.Sample)]
    assert 18 <= len(samples_a) <= 20 and 18 <= len(samples_b) <= 20
    assert samples_a[0].counts[1] == (11, 2, 3, 4, 5)
    absent = int(messages.SensorStatus.SENSOR_ABSENT)
    assert all(tuple(s.sensor_status) == (0, absent, 0) for s in samples_b)
    assert all(s.counts[2] == (9, 9, 9, 9, 9) for s in samples_b)
    # Event-driven stepping: a handful of passes per sample, not one per microsecond.
    assert steps < 20 * len(samples_a)
    assert a.pwm[(2, 2)] == 500  # default duty, driven through the PWM callback


def test_rx_feed_is_bounded_and_garbage_is_survived(lib: ctypes.CDLL) -> None:
    dev = Device(lib, b"sim", [Veml3328Model((1, 1, 1, 1, 1)) for _ in range(3)])
    assert dev.feed(bytes(range(1, 256)) * 20) == 4096  # the rest waits for the next step
    dev.run(1000)
    dev.feed(b"\x00" + encode_frame(messages.GetStatus(), seq=9))
    dev.run(dev.now + 1)
    frames, _ = decode(bytes(dev.tx))
    status = frames[-1].message
    assert isinstance(status, messages.Status)
    assert status.rx_errors >= 1 and status.rx_frames == 1
    assert lib.stac_sim_streaming(dev.mem) == 0
