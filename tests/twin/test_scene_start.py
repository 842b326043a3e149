"""Scenes joined part-way (`start=SECONDS` in sim:// URLs): the tour joined 226 ms into its
first press is pressed from the first moment, with the same presses later on."""

from __future__ import annotations

import numpy as np
import pytest
from spectratac.sim.named_scenes import make_scene
from spectratac.twin.errors import TwinError


def test_the_tour_joined_mid_press_is_pressed_at_time_zero() -> None:
    whole, joined = make_scene("tour"), make_scene("tour", start="0.282")
    t = np.array([0.0, 0.5, 3.0])
    a, b = whole.contact(t + 0.282), joined.contact(t)
    assert b.in_contact[0] and b.region[0] == 1 and b.normal[0] > 3.9
    assert np.allclose(a.normal, b.normal) and np.array_equal(a.region, b.region)
    assert joined.duration_s == pytest.approx(whole.duration_s - 0.282)


@pytest.mark.parametrize("start", ["-1", "1e9", "nan"])
def test_a_start_outside_the_scene_says_what_to_give(start: str) -> None:
    with pytest.raises(TwinError, match=r"start=.*give seconds in \[0"):
        make_scene("press", start=start)
