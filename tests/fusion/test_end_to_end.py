"""The simulated optical sensor and simulated Net F/T of one sim:// world, each on its own
clock, aligned through fit_clock and window_average, agree with the scene's ground truth."""

from __future__ import annotations

import numpy as np
from spectratac.device import Sensor
from spectratac.ft import open_ft
from spectratac.fusion import fit_clock, window_average
from spectratac.sim.world import SimWorld

SPEED = 10.0
URL = f"sim://?scene=calibration&seed=3&speed={SPEED:g}&ft=netft&ft_loss=0.01&ft_offset=0.05"


def test_optical_windows_get_the_scene_force_from_the_ft_stream() -> None:
    before = set(SimWorld._registry)
    with Sensor.open(URL) as sensor, open_ft(URL) as ft:
        (key,) = set(SimWorld._registry) - before
        scene = SimWorld._registry[key].scene
        ft.start()
        sensor.configure(integration_ms=50, stream=True)
        sensor.sync_clock(8)
        optical = sensor.read(60, timeout=30.0)
        sensor.sync_clock(8)
        rows = ft.read(10**7, timeout=0.2)
        lost = ft.stats.lost
    assert len(optical) == 60 and lost > 0  # some F/T packets were lost on the way
    device_clock = fit_clock(
        optical["device_time_us"] / 1e6, optical["host_time"], exchanges=sensor.time_sync
    )
    ft_clock = fit_clock(rows["sensor_time"], rows["host_time"])
    # both devices run on scene time, speed x faster than the host: drift = 1/speed - 1
    assert abs(device_clock.drift - (1 / SPEED - 1)) < 1e-3
    assert abs(ft_clock.drift - ((1 / SPEED) / (1 + 1e-4) - 1)) < 1e-3
    # the F/T clock reads 0.05 s + (1 + 1e-4) x scene time: both clocks agree on the host
    # to within an integration window (the simulated device's clock itself lags the
    # world's by a few host ms when its runner falls behind on a busy machine)
    t = optical["device_time_us"] / 1e6
    gap = device_clock.to_host(t) - ft_clock.to_host(0.05 + (1 + 1e-4) * t)
    assert np.max(np.abs(gap)) * SPEED < 0.050  # scene seconds
    mean, valid, count = window_average(
        ft_clock.to_host(rows["sensor_time"]),
        rows["wrench"],
        device_clock.to_host(optical["t_start_us"] / 1e6),
        device_clock.to_host(optical["device_time_us"] / 1e6),
    )
    assert valid.mean() > 0.8 and np.all(count[valid] >= 40)  # ~50 F/T samples per window
    truth = np.array(
        [
            -scene.contact(np.linspace(a, b, 50)).normal.mean()
            for a, b in zip(
                optical["t_start_us"] / 1e6, optical["device_time_us"] / 1e6, strict=True
            )
        ]
    )
    assert np.median(np.abs(mean[valid, 2] - truth[valid])) < 0.05
