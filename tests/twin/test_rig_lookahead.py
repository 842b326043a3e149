"""Lookahead plans in TwinRig: windows evaluated ahead in one batch give exactly the counts the
one-window-at-a-time path gives for the same seed, whatever the firmware does in between."""

from __future__ import annotations

import numpy as np
import pytest
from spectratac.twin import builtin_scenes, optics
from spectratac.twin.electronics import AF, SD_ALS, TRIG, SensorConfig
from spectratac.twin.rig import PLAN_MAX, TwinRig, _Normals


def _conf(cfg: SensorConfig, *, trigger: bool = True, sd_als: bool = False) -> bytes:
    value = cfg.to_conf() | (AF | TRIG if trigger else 0) | (SD_ALS if sd_als else 0)
    return bytes([0x00, value & 0xFF, value >> 8])


def _session(rig: TwinRig, windows: int = 600) -> tuple[np.ndarray, int]:
    """A firmware-like register session with everything that can break a plan; returns the
    counts read and the longest plan the rig made."""
    rig.set_led_duties(0, np.full((3, 3), 0.5))
    cfg, t, out, longest = SensorConfig(), 1_000, [], 0
    for i in range(windows):
        if i == 200:
            cfg = SensorConfig(integration_ms=100, gain=2.0)  # new period and settings
        if i == 260:
            rig.set_led_duties(t, np.full((3, 3), 0.3))  # LED change: plans are stale
        if i == 300:
            t += 777  # the period shifts once
        lagging = 400 <= i < 440 and i % 2  # sensor 2 skips every other window
        sd_als = 450 <= i < 470
        for dev in rig.sensors:
            if not (lagging and dev.index == 2):
                dev.transfer(t, _conf(cfg, sd_als=sd_als), 0)
        t += cfg.integration_ms * 1000
        if i == 500:  # continuous mode for a while (AF = 0): back-to-back windows
            for dev in rig.sensors:
                dev.transfer(t, _conf(cfg, trigger=False), 0)
            t += 10 * cfg.integration_ms * 1000
        for dev in rig.sensors:
            out.append(
                [int.from_bytes(dev.transfer(t, bytes([r]), 2), "little") for r in (4, 5, 8)]
            )
        if rig.plan is not None:
            longest = max(longest, rig.plan.n)
        t += 300
    return np.array(out), longest


def test_lookahead_counts_equal_window_by_window_counts() -> None:
    scene = builtin_scenes.single_press(6, 6.0, start_s=2.0, hold_s=20.0)
    plain, none = _session(TwinRig(scene, seed=4, lookahead=False))
    ahead, longest = _session(TwinRig(scene, seed=4, lookahead=True))
    assert none == 0 and longest >= 64  # the batched path really ran, and grew its plans
    np.testing.assert_array_equal(plain, ahead)
    assert plain[:, 0].min() > 0 and len(np.unique(plain[:, 1])) > 100  # real, varying data


def test_repeated_reads_of_one_window_share_optics_but_not_noise(monkeypatch) -> None:
    """The three sensors of a window (triggered together) and repeated reads of it share one
    evaluation of the optics, so one draw of LED flicker; shot and read noise are fresh."""
    evaluations = []
    led_intensity = optics.led_intensity

    def counted(*args, **kwargs):
        evaluations.append(args)
        return led_intensity(*args, **kwargs)

    rig = TwinRig(builtin_scenes.idle(5.0), seed=2)
    rig.set_led_duties(0, np.full((3, 3), 0.25))
    monkeypatch.setattr(optics, "led_intensity", counted)
    reads = [rig.read_window(k % 3, 0, 50_000, SensorConfig())[0] for k in range(15)]
    assert len(evaluations) == 1  # one evaluation, one flicker draw
    assert len({r.tobytes() for r in reads[::3]}) == 5  # fresh shot/read noise every read
    rig.read_window(0, 50_000, 100_000, SensorConfig())
    assert len(evaluations) == 2  # the spy sees every evaluation: the next window is one


def test_plans_stop_at_their_maximum_and_restart_short_after_a_miss() -> None:
    rig = TwinRig(builtin_scenes.idle(60.0), seed=1)
    rig.set_led_duties(0, np.full((3, 3), 0.25))
    lengths = []
    for i in range(700):
        rig.read_window(0, i * 50_000, (i + 1) * 50_000, SensorConfig())
        if rig.plan is not None and (not lengths or lengths[-1] != rig.plan.n):
            lengths.append(rig.plan.n)
    assert lengths[:3] == [8, 16, 32] and max(lengths) == PLAN_MAX
    rig.read_window(0, 99_000_000, 99_050_000, SensorConfig())  # off the period: no plan
    assert rig.plan is None


@pytest.mark.parametrize("width", [5, 9])
def test_block_draws_equal_one_row_at_a_time(width: int) -> None:
    """The premise of the plans: PCG64 normals drawn in blocks come in draw order."""
    one = np.random.default_rng(11)
    rows = _Normals(np.random.default_rng(11), width)
    peeked = rows.rows(0, 100).copy()  # look ahead without consuming
    taken = np.array([rows.take() for _ in range(300)])
    expected = np.array([one.standard_normal(width) for _ in range(300)])
    np.testing.assert_array_equal(taken, expected)
    np.testing.assert_array_equal(peeked, expected[:100])
