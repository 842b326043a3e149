"""The builder reads the link's facts generically (the session's "link", LinkInfo), and a
recording from before format 3, which said them in a "sim" block, builds the same dataset."""

from __future__ import annotations

import copy
from pathlib import Path

import numpy as np
import pytest
from spectratac.dataset.build import session_datasets
from spectratac.device import LinkInfo
from spectratac.record.reader import Recording, read_recording


def as_version_2(rec: Recording) -> Recording:
    """The same recording as a format-2 file holds it: the truth's description under "sim",
    no "link"."""
    old = copy.copy(rec)
    session = {k: v for k, v in rec.session.items() if k not in ("link", "truth")}
    old.session = session | {"version": 2, "sim": rec.session["truth"]}
    return old


@pytest.mark.parametrize("fixture", ["tour_mcap", "quick_mcaps"])
def test_a_format_2_recording_builds_the_same_dataset(
    fixture: str, request: pytest.FixtureRequest
) -> None:
    value = request.getfixturevalue(fixture)
    path: Path = value if isinstance(value, Path) else value["a50"]
    rec = read_recording(path)
    old = as_version_2(rec)
    assert old.link.clock_scale == rec.link.clock_scale and old.link.ground_truth
    assert old.truth == rec.truth  # (a format-2 file never said which F/T it was paired with)
    [new_ds], [old_ds] = session_datasets(rec), session_datasets(old)
    assert new_ds.arrays.keys() == old_ds.arrays.keys()
    for key, value in new_ds.arrays.items():
        np.testing.assert_array_equal(value, old_ds.arrays[key], err_msg=key)
    assert new_ds.meta["sessions"][0]["speed"] == old_ds.meta["sessions"][0]["speed"]


def test_the_link_facts_of_each_kind_of_session(tour_mcap: Path, quick_mcaps: dict) -> None:
    paced, unpaced = read_recording(tour_mcap), read_recording(quick_mcaps["a50"])
    assert paced.link.clock_scale == 10.0 and paced.link.paired_ft_url == paced.session["url"]
    assert unpaced.link == LinkInfo(clock_scale=None, ground_truth=True)  # speed=max
    legacy_max = Recording(Path("x"), {"sim": {"scene": "press", "speed": "max"}})
    assert legacy_max.link == LinkInfo(clock_scale=None, ground_truth=True)
    hardware = Recording(Path("x"), {"version": 2, "sim": None})
    assert hardware.link == LinkInfo() and hardware.truth == {}
    assert Recording(Path("x"), {"link": LinkInfo().as_dict(), "truth": None}).truth == {}
