"""What a transport knows about itself reaches users of a Sensor as one typed value."""

from __future__ import annotations

import pytest
from spectratac.device import LinkInfo, Sensor, link_info_of, open_transport


def test_a_port_is_hardware_and_an_object_without_facts_too() -> None:
    link = open_transport("loop://")
    try:
        assert link_info_of(link) == LinkInfo() == LinkInfo(1.0, None, False)
    finally:
        link.close()
    assert link_info_of(object()) == LinkInfo()


@pytest.mark.parametrize(
    ("url", "scale", "paired"),
    [
        ("sim://?scene=press&speed=4", 4.0, False),
        ("sim://?scene=press&speed=max", None, False),
        ("sim://?scene=press&speed=2&ft=bota", 2.0, True),
    ],
)
def test_a_simulated_link_says_its_speed_its_f_t_and_its_truth(
    url: str, scale: float | None, paired: bool
) -> None:
    with Sensor.open(url) as sensor:
        info = sensor.link_info
    # and the unit's name, as twin datasets of seed 0's unit call it (the unit check on open)
    assert info == LinkInfo(scale, url if paired else None, True, "twin-0")
    assert "unit_name" not in info.as_dict()  # recordings name the unit by its unique id


def test_link_info_round_trips_as_json_and_ignores_unknown_keys() -> None:
    info = LinkInfo(0.5, "sim://?ft=netft", True)
    assert LinkInfo.from_dict(info.as_dict() | {"newer": 1}) == info
    assert LinkInfo.from_dict({}) == LinkInfo()
