"""The scripted presses scene, from its URL parameters."""

from __future__ import annotations

import numpy as np
import pytest
from spectratac.sim.named_scenes import make_scene
from spectratac.sim.url import parse_sim_url
from spectratac.twin.errors import TwinError
from spectratac.twin.scripted_presses import DEFAULT_ORDER, parse_order, press_regions


def test_url_script_sets_order_forces_and_timing() -> None:
    opts = parse_sim_url("sim://?scene=presses&order=up,left,5,9&force=2,0.5,3,1.5&hold=1.2")
    scene = make_scene(opts.scene, **opts.scene_params)
    assert press_regions(scene).tolist() == [2, 4, 5, 9]
    assert scene.presses.normal_peak.tolist() == [2.0, 0.5, 3.0, 1.5]
    assert np.allclose(scene.presses.hold, 1.2) and np.allclose(np.diff(scene.presses.start), 2.3)
    peak = scene.contact(scene.presses.start + scene.presses.rise + 0.1)
    assert np.allclose(peak.normal, [2.0, 0.5, 3.0, 1.5]) and np.allclose(peak.fx, 0)
    assert peak.region.tolist() == [2, -1, 5, 9]  # under 1.0 N a sample carries no label


def test_default_script_presses_every_direction_and_the_centre() -> None:
    scene = make_scene("presses")
    assert press_regions(scene).tolist() == list(parse_order(DEFAULT_ORDER))
    assert set(press_regions(scene).tolist()) == {2, 4, 5, 6, 8}
    assert scene.contact(np.array([scene.duration_s])).in_contact.tolist() == [False]


@pytest.mark.parametrize(
    ("params", "match"),
    [({"order": "up,north"}, "region 1-9"), ({"order": ""}, "region 1-9|empty"),
     ({"force": "2,3"}, "2 forces for 9 presses"), ({"force": "x"}, "force=2.0")],
)  # fmt: skip
def test_bad_scripts_say_what_to_give(params, match) -> None:
    with pytest.raises(TwinError, match=match):
        make_scene("presses", **params)
