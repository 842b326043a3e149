"""The register-level VEML3328 model behaves like the device on its I2C bus."""

from __future__ import annotations

import numpy as np
import pytest
from spectratac.errors import SpectraTacError
from spectratac.hardware.generated import veml3328 as chip
from spectratac.twin import I2CNack, builtin_scenes
from spectratac.twin.electronics import AF, INTEGRATION_MS, SD0, SD1, TRIG, SensorConfig
from spectratac.twin.rig import TwinRig
from spectratac.twin.veml3328 import Veml3328


def _rig(scene=None, duty: float = 0.25) -> TwinRig:
    rig = TwinRig(scene or builtin_scenes.idle(10.0), seed=3)
    rig.set_led_duties(0, np.full((3, 3), duty))
    return rig


def _w(dev: Veml3328, now: int, reg: int, value: int) -> None:
    assert dev.transfer(now, bytes([reg, value & 0xFF, value >> 8]), 0) == b""


def _r(dev: Veml3328, now: int, reg: int) -> int:
    return int.from_bytes(dev.transfer(now, bytes([reg]), 2), "little")


def _trigger(dev: Veml3328, now: int, cfg: SensorConfig | None = None) -> None:
    cfg = cfg or SensorConfig()
    _w(dev, now, chip.REG_CONF, cfg.to_conf() | AF | TRIG)


def test_id_and_power_on_state() -> None:
    dev = _rig().sensors[1]
    assert _r(dev, 0, chip.REG_ID) & 0xFF == chip.ID_LOW
    assert _r(dev, 0, chip.REG_CONF) == SD1 | SD0
    assert all(
        _r(dev, 0, reg) == 0
        for reg in (chip.REG_C, chip.REG_R, chip.REG_G, chip.REG_B, chip.REG_IR)
    )


def test_nacks_are_typed() -> None:
    rig = _rig()
    dev = rig.sensors[0]
    assert issubclass(I2CNack, SpectraTacError)
    with pytest.raises(I2CNack, match="no register"):
        dev.transfer(0, b"\x01", 2)
    with pytest.raises(I2CNack, match="read-only"):
        dev.transfer(0, b"\x04\x00\x00", 0)
    with pytest.raises(I2CNack, match="write of 2 bytes"):
        dev.transfer(0, b"\x00\x00", 0)
    absent = Veml3328(rig, 2, present=False)
    with pytest.raises(I2CNack, match="no device"):
        absent.transfer(0, b"\x0c", 2)


def test_active_force_trigger_completes_after_integration_time() -> None:
    dev = _rig().sensors[0]
    _trigger(dev, 1_000)
    assert _r(dev, 1_000, chip.REG_CONF) & TRIG
    assert _r(dev, 50_999, chip.REG_C) == 0  # still integrating: previous data
    c = _r(dev, 51_000, chip.REG_C)
    assert 15_000 < c < 45_000
    assert not _r(dev, 51_000, chip.REG_CONF) & TRIG  # self-cleared
    # No new trigger: data stays put.
    assert _r(dev, 500_000, chip.REG_C) == c
    assert dev.completed == 1
    _trigger(dev, 600_000, SensorConfig(integration_ms=100))
    assert _r(dev, 650_000, chip.REG_C) == c
    assert _r(dev, 700_000, chip.REG_C) != c
    assert dev.completed == 2


def test_continuous_mode_integrates_back_to_back_and_shutdown_stops() -> None:
    dev = _rig().sensors[2]
    _w(dev, 0x00, chip.REG_CONF, SensorConfig().to_conf())  # powered, AF = 0, 50 ms
    assert _r(dev, 49_000, chip.REG_B) == 0
    values = [_r(dev, t, chip.REG_B) for t in (50_000, 100_000, 150_000, 400_000)]
    assert all(v > 0 for v in values) and len(set(values)) > 1
    done = dev.completed
    _w(dev, 410_000, chip.REG_CONF, SensorConfig().to_conf() | SD0)
    frozen = _r(dev, 410_000, chip.REG_B)
    assert _r(dev, 2_000_000, chip.REG_B) == frozen and dev.completed == done


def test_pointer_then_read_and_bus_padding() -> None:
    dev = _rig().sensors[0]
    dev.transfer(0, b"\x0c", 0)
    assert dev.transfer(1, b"", 2) == b"\x28\x00"
    assert dev.transfer(2, b"\x0c", 4) == b"\x28\x00\xff\xff"
    assert dev.transfer(3, b"\x0c", 1) == b"\x28"


def test_doubling_integration_time_doubles_counts_until_saturation() -> None:
    rig = _rig()
    dev = rig.sensors[0]
    t = 0
    means = {}
    for it in INTEGRATION_MS:
        vals = []
        for _ in range(8):
            _trigger(dev, t, SensorConfig(integration_ms=it))
            t += it * 1000
            vals.append(_r(dev, t, chip.REG_R))  # red channel (~11.6k at 50 ms)
        means[it] = np.mean(vals)
    assert means[100] / means[50] == pytest.approx(2.0, rel=0.03)
    assert means[200] / means[100] == pytest.approx(2.0, rel=0.03)
    assert means[400] < 2 * means[200] and means[400] == 65535
    assert dev.saturated


def test_gain_bits_scale_counts() -> None:
    rig = _rig()
    dev = rig.sensors[1]
    t, vals = 0, {}
    for gain in (0.5, 1.0, 2.0):
        acc = []
        for _ in range(6):
            _trigger(dev, t, SensorConfig(gain=gain))
            t += 50_000
            acc.append(_r(dev, t, chip.REG_G))
        vals[gain] = np.mean(acc)
    assert vals[1.0] / vals[0.5] == pytest.approx(2.0, rel=0.03)
    assert vals[2.0] / vals[1.0] == pytest.approx(2.0, rel=0.03)


def test_window_averages_led_duty_changes_inside_it() -> None:
    steady = _rig(duty=0.2)
    half = _rig(duty=0.2)  # same thermal state as `steady`
    half.set_led_duties(0, np.full((3, 3), 0.4))
    half.set_led_duties(25_000, np.zeros((3, 3)))  # on for the first half only
    np.testing.assert_allclose(half.mean_duty(0, 50_000), steady.mean_duty(0, 50_000))
    a = np.mean([steady.read_window(0, 0, 50_000, SensorConfig())[0] for _ in range(10)], 0)
    b = np.mean([half.read_window(0, 0, 50_000, SensorConfig())[0] for _ in range(10)], 0)
    np.testing.assert_allclose(a[:4], b[:4], rtol=0.01)


def test_press_changes_counts_through_the_register_interface() -> None:
    rig = _rig(builtin_scenes.single_press(6, 8.0, start_s=0.5, hold_s=2.0))
    dev = rig.sensors[0]
    _trigger(dev, 0)
    idle = _r(dev, 50_000, chip.REG_R)
    _trigger(dev, 1_500_000)
    pressed = _r(dev, 1_550_000, chip.REG_R)
    assert abs(pressed - idle) > 0.1 * idle  # a firm press next to sensor 0 moves its red


def test_led_timeline_rejects_bad_input() -> None:
    rig = _rig()
    rig.set_led_duties(1_000, np.zeros((3, 3)))
    with pytest.raises(SpectraTacError, match="backwards"):
        rig.set_led_duties(500, np.zeros((3, 3)))
    with pytest.raises(SpectraTacError, match=r"\(3 LEDs, 3 colours"):
        rig.set_led_duties(2_000, np.zeros(3))
    with pytest.raises(SpectraTacError, match=r"\[0, 1\]"):
        rig.set_led_duties(2_000, np.full((3, 3), 1.5))


def test_rig_ft_follows_the_contact() -> None:
    rig = _rig(builtin_scenes.single_press(5, 6.0, start_s=0.5, hold_s=2.0))
    w = rig.ft(np.array([0.1, 1.8]))
    assert abs(w[0, 2]) < 0.1
    assert w[1, 2] == pytest.approx(-6.0, abs=0.15)
