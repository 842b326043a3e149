"""The sensor's vocabulary (hardware/definitions/vocabulary.toml) is consistent in itself, with
the board (params.toml beside it), the wire protocol and the twin's geometry, and its generated C
header says what the generated Python says."""

from __future__ import annotations

import importlib
import re
from pathlib import Path
from types import ModuleType

import numpy as np
import pytest
from spectratac.hardware.generated import board
from spectratac.hardware.generated import vocabulary as v
from spectratac.protocol.generated import messages
from spectratac.twin.geometry import region_centre, region_of

DEFINITION = "hardware/definitions/vocabulary.toml"
PARAMS = "hardware/definitions/params.toml"


@pytest.fixture
def backend() -> ModuleType:
    """tools/codegen/vocabulary_backend."""
    return importlib.import_module("tools.codegen.vocabulary_backend")


def test_regions_are_the_keypad() -> None:
    assert tuple(range(1, v.N_REGIONS + 1)) == v.REGIONS
    assert sorted(r for row in v.KEYPAD for r in row) == list(v.REGIONS)
    assert v.KEYPAD[1][1] == v.CENTRE_REGION  # the centre sits in the keypad's middle
    row_col = {r: (i, j) for i, row in enumerate(v.KEYPAD) for j, r in enumerate(row)}
    step = {"up": (-1, 0), "down": (1, 0), "left": (0, -1), "right": (0, 1), "centre": (0, 0)}
    centre = row_col[v.CENTRE_REGION]
    for direction, region in v.DIRECTION_REGION.items():
        di, dj = step[direction]
        assert row_col[region] == (centre[0] + di, centre[1] + dj), direction
    assert set(v.REGION_PROMPTS) == set(v.REGIONS)


def test_mirror_and_turn_maps() -> None:
    assert all(v.MIRROR_REGION[v.MIRROR_REGION[r]] == r for r in v.REGIONS)  # an involution
    for r, deg in v.SECTOR_CENTRE_DEG.items():  # y -> -y takes the sector at a to -a
        assert v.SECTOR_CENTRE_DEG[v.MIRROR_REGION[r]] == (-deg) % 360.0
    assert v.MIRROR_REGION[v.CENTRE_REGION] == v.CENTRE_REGION
    assert v.TURN_REGION == {v.CENTRE_REGION: v.CENTRE_REGION}


def test_sectors_tile_the_ring_and_the_twin_lays_them_out() -> None:
    width = 360.0 / len(v.RING_REGIONS)
    assert [v.SECTOR_CENTRE_DEG[r] for r in v.RING_REGIONS] == [
        width * k for k in range(len(v.RING_REGIONS))
    ]
    assert set(v.RING_REGIONS) | {v.CENTRE_REGION} == set(v.REGIONS)
    for r in v.REGIONS:
        assert int(region_of(*region_centre(r))) == r
    # A point mirrored in the x axis lands in the mirrored region.
    rng = np.random.default_rng(0)
    x, y = rng.uniform(-8, 8, 500), rng.uniform(-8, 8, 500)
    inside = np.hypot(x, y) < v.ACTIVE_RADIUS_MM
    mirrored = region_of(x[inside], -y[inside])
    expect = [v.MIRROR_REGION[int(r)] for r in region_of(x[inside], y[inside])]
    assert mirrored.tolist() == expect


def test_vocabulary_agrees_with_board_and_protocol() -> None:
    assert v.N_SENSORS == len(board.LAYOUT_SENSOR_ANGLES) == messages.SENSORS
    assert v.N_LEDS == len(board.LAYOUT_LED_ANGLES) == messages.LEDS
    assert len(v.LED_COLOURS) == messages.COLOURS
    assert len(v.CHANNELS) == messages.CHANNELS
    assert v.CHANNELS[: len(v.DECODED_CHANNELS)] == v.DECODED_CHANNELS
    assert tuple(
        f"s{s}.{c}" for s in range(v.N_SENSORS) for c in v.DECODED_CHANNELS
    ) == v.DECODED_INPUTS
    assert v.FT_AXES == v.FORCE_AXES + v.TORQUE_AXES
    assert set(v.AXIS_UNITS) == set(v.FT_AXES)


def test_c_header_says_what_python_says(repo: Path) -> None:
    text = (repo / "firmware/core/generated/stac_vocabulary.h").read_text(encoding="utf-8")
    define = dict(re.findall(r"^#define (STAC_\w+) (\d+)u", text, flags=re.M))
    assert int(define["STAC_REGIONS"]) == v.N_REGIONS
    assert int(define["STAC_REGION_CENTRE"]) == v.CENTRE_REGION
    assert int(define["STAC_FT_AXES"]) == len(v.FT_AXES)
    assert int(define["STAC_FORCE_AXES"]) == len(v.FORCE_AXES)
    assert int(define["STAC_DECODED_CHANNELS"]) == len(v.DECODED_CHANNELS)
    assert [int(define[f"STAC_CHANNEL_{c}"]) for c in v.CHANNELS] == list(range(len(v.CHANNELS)))


@pytest.mark.parametrize(
    ("old", "new", "complaint"),
    [
        ("mirror = 7\n", "mirror = 8\n", "involution"),
        ("keypad = [[1, 2, 3]", "keypad = [[1, 2, 2]", "keypad"),
        ("sector = 45.0", "sector = 50.0", "tile"),
        ('direction = "down"', 'direction = "up"', "direction"),
        ('decoded = ["R", "G", "B", "C"]', 'decoded = ["G", "B"]', "decoded"),
    ],
)
def test_generator_refuses_a_broken_definition(
    backend: ModuleType, repo: Path, tmp_path: Path, old: str, new: str, complaint: str
) -> None:
    text = (repo / DEFINITION).read_text(encoding="utf-8")
    assert old in text
    broken = tmp_path / "vocabulary.toml"
    broken.write_text(text.replace(old, new, 1), encoding="utf-8")
    with pytest.raises(backend.VocabularyError, match=complaint):
        backend.load(broken, repo / PARAMS, DEFINITION)
    backend.load(repo / DEFINITION, repo / PARAMS, DEFINITION)  # the real one
