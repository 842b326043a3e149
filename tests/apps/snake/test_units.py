"""Snake on units the model was not trained on (issue 22 item 3): the real pipeline (firmware
sim -> Sensor -> Decoder -> CommandDetector) never fires a press twice, whatever the
out-of-distribution flag does on a foreign unit."""

from __future__ import annotations

import numpy as np
import pytest
from spectratac.apps.sensor_setup import SampleTap, open_for_decoder
from spectratac.apps.snake.control import CommandDetector
from spectratac.decode import Decoder
from spectratac.sim.named_scenes import make_scene
from spectratac.twin.scripted_presses import press_regions


def commands_per_press(decoder: Decoder, seed: int) -> tuple[list[list[int]], list[int]]:
    scene = make_scene("presses", seed=str(seed))
    per_press: list[list[int]] = [[] for _ in range(len(scene.presses))]
    det, ood = CommandDetector(), 0
    with open_for_decoder(decoder, f"sim://?scene=presses&speed=max&seed={seed}") as sensor:
        tap = SampleTap(sensor)
        for est in decoder.stream(tap):
            assert tap.last is not None
            t = tap.last.device_time_us / 1e6
            ood += int(est.ood)
            c = det.feed(est, t)
            if c is not None:
                i = int(scene.press_index(np.array([t]))[0])
                assert i >= 0, f"unit {seed}: a command at {t:.2f} s, between presses"
                per_press[i].append(c.region)
            if t >= scene.duration_s:
                break
    return per_press, [int(r) for r in press_regions(scene)]


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_no_press_fires_twice_on_another_unit(press_model, seed: int) -> None:
    decoder = Decoder.load(press_model)  # trained on unit 0
    decoder.unit_policy = "off"
    per_press, want = commands_per_press(decoder, seed)
    assert all(len(c) <= 1 for c in per_press), (seed, per_press, want)
