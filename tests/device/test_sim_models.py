"""The simulated device's native VEML3328 register models (firmware/ports/native/veml_model.c)
behave exactly like the twin's Python model, and the device built on them sends the same
frames as one whose every register transfer goes to Python."""

from __future__ import annotations

import random
import re
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from spectratac.device import Sensor
from spectratac.protocol import StreamDecoder, encode_frame
from spectratac.protocol.generated import messages as m
from spectratac.sim import native
from spectratac.sim.device import SimDevice
from spectratac.sim.named_scenes import make_scene
from spectratac.twin import I2CNack, builtin_scenes, rig

SCENE = make_scene("tour")
# short: cheap rigs per example
PRESS = builtin_scenes.single_press(6, 6.0, start_s=0.3, hold_s=2.0)

# One register transfer: (bus, time step µs, bytes written, bytes read).
_settings = st.builds(  # IT, gain, DG (0b11 reserved), SENS, SD_ALS
    lambda it, g, dg, sens, als: (dg << 12) | (g << 10) | (it << 4) | sens | als,
    st.integers(0, 3),
    st.integers(0, 3),
    st.integers(0, 3),
    st.sampled_from([0, 0x40]),
    st.sampled_from([0, 0, 0x4000]),
)
_conf = st.one_of(
    _settings.map(lambda v: v | 0x0C),  # active force + trigger
    _settings.map(lambda v: v | 0x0C),
    _settings.map(lambda v: v | 0x08),  # active force, no trigger
    _settings,  # continuous mode
    _settings.map(lambda v: v | 0x8001),  # shut down
    st.integers(0, 0xFFFF),
)
_write = st.one_of(
    _conf.map(lambda v: bytes([0x00, v & 0xFF, v >> 8])),
    st.sampled_from([0x04, 0x05, 0x06, 0x07, 0x08]).map(lambda r: bytes([r])),
    st.sampled_from([0x04, 0x05, 0x06, 0x07, 0x08]).map(lambda r: bytes([r])),
    st.sampled_from([0x00, 0x0C, 0x01, 0x09, 0xFF]).map(lambda r: bytes([r])),
    st.binary(min_size=0, max_size=4),
)
_dt = st.one_of(
    st.integers(0, 2_000),
    st.sampled_from([50_000, 100_000, 200_000, 400_000]),
    st.integers(-3_000, 450_000),
)
_op = st.tuples(st.integers(0, 2), _dt, _write, st.sampled_from([2, 2, 0, 1, 4]))


def _pair() -> tuple[SimDevice, SimDevice]:
    native = SimDevice(PRESS, 5, registers="native")
    python = SimDevice(PRESS, 5, registers="python")
    for dev in (native, python):
        dev.rig.set_led_duties(0, np.full((3, 3), 0.4))
    return native, python


def _compare(ops: list[tuple[int, int, bytes, int]]) -> int:
    """Run ops on both models, assert identical replies; return nonzero data reads."""
    native, python = _pair()
    now, data = 0, 0
    for bus, dt, write, read_len in ops:
        now = max(0, now + dt)
        replies: list[bytes | str] = []
        for dev in (native, python):
            try:
                replies.append(dev.sensor_transfer(bus, now, write, read_len))
            except I2CNack:
                replies.append("NACK")
        assert replies[0] == replies[1], (bus, now, write.hex(), read_len)
        data += write[:1] in (b"\x04", b"\x05", b"\x08") and replies[0] not in ("NACK", b"\0\0")
    assert native.i2c_errors == python.i2c_errors == 0
    return data


@settings(max_examples=80, deadline=None)
@given(st.lists(_op, min_size=1, max_size=80))
def test_native_register_model_matches_python_model(ops: list) -> None:  # type: ignore[type-arg]
    _compare(ops)


@pytest.mark.parametrize("seed", range(4))
def test_long_random_register_sessions_match_with_real_counts(seed: int) -> None:
    rng = random.Random(seed)
    ops = []
    for _ in range(300):
        bus = rng.randrange(3)
        settings_ = rng.randrange(4) << 4 | rng.randrange(4) << 10 | rng.randrange(3) << 12
        settings_ |= rng.choice([0, 0, 0x40]) | rng.choice([0, 0, 0, 0x4000])
        kind = rng.random()
        if kind < 0.3:
            conf = settings_ | rng.choice([0x0C, 0x0C, 0x08, 0x00, 0x8001, rng.randrange(1 << 16)])
            write, read_len = bytes([0x00, conf & 0xFF, conf >> 8]), 0
        elif kind < 0.8:
            write, read_len = bytes([rng.choice([4, 5, 6, 7, 8, 0, 12])]), 2
        else:
            write, read_len = rng.randbytes(rng.randrange(5)), rng.randrange(5)
        dt = rng.choice([0, rng.randrange(2_000), rng.choice([50_000, 100_000, 400_000])])
        ops.append((bus, dt, write, read_len))
    assert _compare(ops) > 20  # windows completed and real counts were compared


def test_native_model_serves_a_steady_stream_from_the_twins_plan() -> None:
    """Triggered every 50 ms like the firmware does: the counts come from plans computed
    ahead and are still exactly the Python model's."""
    native, python = _pair()
    calls = []
    original = native.rig.read_window
    native.rig.read_window = lambda *a, **k: calls.append(a) or original(*a, **k)  # type: ignore[method-assign]
    trigger = bytes([0x00, 0x0C, 0x00])  # AF + TRIG, 50 ms, gain x1
    t, got = 0, {id(native): [], id(python): []}
    for _ in range(400):
        for dev in (native, python):
            for bus in range(3):
                dev.sensor_transfer(bus, t, trigger, 0)
        t += 50_000
        for dev in (native, python):
            for bus in range(3):
                got[id(dev)] += [dev.sensor_transfer(bus, t, bytes([r]), 2) for r in (4, 5, 8)]
    assert got[id(native)] == got[id(python)]
    assert len(calls) < 0.1 * 3 * 400  # most windows never called into Python


def _frames(registers: str, lookahead: bool) -> bytes:
    out: list[bytes] = []
    dev = SimDevice(
        SCENE,
        3,
        absent=(1,),
        on_tx=lambda data, _t: out.append(data),
        registers=registers,  # type: ignore[arg-type]
        lookahead=lookahead,
    )
    seq = iter(range(1, 100))

    def command(msg: m.Message) -> None:
        dev.feed(encode_frame(msg, next(seq)))
        dev.step(dev.now_us)

    def stream(count: int) -> None:
        target = len(out) + count
        while len(out) < target:
            dev.run(1)

    dev.feed(b"\x00")
    command(m.GetInfo())
    command(m.Start())
    stream(300)
    steps = [[[500] * 3] * 3, [[900, 0, 0]] * 3, [[0, 0, 900]] * 3] + [[[0] * 3] * 3] * 5
    command(
        m.Configure(
            integration_ms=100,
            gain=int(m.Gain.GAIN_X2),
            digital_gain=int(m.DigitalGain.DG_X1),
            led_settle_us=1000,
            led_step_count=3,
            led_duty=tuple(tuple(tuple(d) for d in s) for s in steps),
        )
    )
    stream(40)
    command(m.Stop())
    dev.step(dev.now_us + 300_000)
    command(m.Start())
    stream(300)
    return b"".join(out)


def test_native_and_python_registers_send_identical_frames() -> None:
    reference = _frames("python", lookahead=False)
    frames = StreamDecoder().feed(reference)
    samples = [f.message for f in frames if isinstance(f.message, m.Sample)]
    assert len(samples) >= 600 and {s.led_step for s in samples} == {0, 1, 2}
    absent = int(m.SensorStatus.SENSOR_ABSENT)
    saturated = int(m.SensorStatus.SENSOR_SATURATED)  # gain x2 at 100 ms: bright steps clip
    assert all(s.sensor_status[1] == absent for s in samples)
    assert {s.sensor_status[k] for s in samples for k in (0, 2)} <= {0, saturated}
    for registers, lookahead in (("python", True), ("native", False), ("native", True)):
        assert _frames(registers, lookahead) == reference, (registers, lookahead)


def test_twin_failure_is_a_bus_fault_and_streaming_goes_on() -> None:
    out: list[bytes] = []
    dev = SimDevice(SCENE, 1, on_tx=lambda data, _t: out.append(data))
    original = dev.rig.read_window
    failures = iter([True])

    def flaky(k, *args, **kwargs):  # type: ignore[no-untyped-def]
        if k == 2 and next(failures, False):
            raise RuntimeError("injected twin bug")
        return original(k, *args, **kwargs)

    dev.rig.read_window = flaky  # type: ignore[method-assign]
    dev.feed(b"\x00" + encode_frame(m.Start(), 1))
    dev.step(0)
    while len(out) < 30:
        dev.run(8)
    samples = [f.message for f in StreamDecoder().feed(b"".join(out))]
    samples = [s for s in samples if isinstance(s, m.Sample)]
    fault = int(m.SensorStatus.SENSOR_BUS_FAULT)
    assert dev.i2c_errors == 1
    assert samples[0].sensor_status == (0, 0, fault)
    assert all(s.sensor_status == (0, 0, 0) for s in samples[1:])
    assert [s.sample_seq for s in samples] == list(range(len(samples)))


@pytest.mark.parametrize("count", [4000])
def test_speed_max_through_sensor_loses_nothing(count: int) -> None:
    with Sensor.open("sim://?scene=tour&seed=2&speed=max", buffer_size=2 * count) as sensor:
        sensor.start()
        batch = sensor.read(count, timeout=120)
        sensor.stop()
        stats = sensor.stats
    assert len(batch) == count
    assert batch["sequence"].tolist() == list(range(count))
    assert stats.sample_gaps == stats.buffer_overflows == stats.crc_errors == 0
    assert (np.diff(batch["device_time_us"].astype(np.int64)) == 50_000).all()
    assert (batch["status"] == 0).all() and batch["counts"].min() > 0


def test_constants_shared_with_the_native_port_agree() -> None:
    firmware = Path(__file__).resolve().parents[2] / "firmware"
    header = (firmware / "ports" / "native" / "generated" / "stac_sim.h").read_text()
    model = (firmware / "ports" / "native" / "veml_model.h").read_text()

    def define(text: str, name: str) -> int:
        found = re.search(rf"#define {name} (0x[0-9A-Fa-f]+|\d+)u?", text)
        assert found, name
        return int(found.group(1), 0)

    assert define(header, "STAC_SIM_PLAN_MAX") == native.PLAN_MAX == rig.PLAN_MAX
    assert define(header, "STAC_SIM_SHARED_WINDOWS") == native.SHARED_WINDOWS
    assert native.SHARED_WINDOWS == rig.SHARED_WINDOWS
    assert "#define VEML_MODEL_WINDOW_BITS VEML3328_CONF_WINDOW" in model  # both generated
