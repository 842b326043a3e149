"""One table of scenes (sim/named_scenes.py) serves sim:// URLs, `twin generate` and twin
populations: every name builds for each of them, and they differ only where a scene has no
length of its own."""

from __future__ import annotations

import numpy as np
import pytest
from spectratac.cli import main
from spectratac.hardware.generated import vocabulary as vocab
from spectratac.sim.named_scenes import (
    DEVICE_OPEN_ENDED_S,
    POPULATION_SCENES,
    SCENES,
    UnknownSceneError,
    make_scene,
    named_scene,
    scene_names,
    scene_settings,
)
from spectratac.twin import builtin_scenes, region_of
from spectratac.twin.errors import TwinError


@pytest.mark.parametrize("name", scene_names())
def test_every_scene_builds_for_devices_and_files(name: str) -> None:
    device, file = make_scene(name), named_scene(name, open_ended_s=10.0)
    assert device.name == file.name
    if SCENES.get(name) is not None and SCENES[name].open_ended:
        assert (device.duration_s, file.duration_s) == (DEVICE_OPEN_ENDED_S, 10.0)
    else:
        assert device.duration_s == file.duration_s


def test_url_parameters_and_explicit_durations_agree() -> None:
    assert make_scene("drift", duration="60").duration_s == 60.0
    assert named_scene("drift", duration_s=60.0, open_ended_s=1.0).duration_s == 60.0
    a = make_scene("calibration", seed="3", duration="120")
    b = named_scene("calibration", 3, 120.0, open_ended_s=1.0)
    np.testing.assert_array_equal(a.presses.x, b.presses.x)
    pressed = make_scene("press", region="3", force="2.0")
    assert int(region_of(pressed.presses.x, pressed.presses.y)[0]) == 3


def test_hard_cases_carry_their_settings() -> None:
    for name, case in builtin_scenes.hard_cases().items():
        assert scene_settings(name).keys() == case.settings.keys()
    assert scene_settings("calibration") == {}


def test_the_tour_visits_the_regions_in_order() -> None:
    tour = make_scene("tour")
    first = region_of(tour.presses.x, tour.presses.y)[: vocab.N_REGIONS]
    assert tuple(int(r) for r in first) == vocab.REGIONS


def test_unknown_scene_is_a_twin_and_a_value_error() -> None:
    with pytest.raises(UnknownSceneError, match="choose one of") as err:
        make_scene("nope")
    assert isinstance(err.value, TwinError) and isinstance(err.value, ValueError)
    assert set(POPULATION_SCENES) <= set(SCENES)


def test_twin_generate_lists_the_table(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["twin", "generate", "--list"]) == 0
    assert capsys.readouterr().out.split() == scene_names()
