"""The population dataset: units x sessions, one group per session, conditions in the metadata."""

from __future__ import annotations

import json

import numpy as np
import pytest
from spectratac.cli import main
from spectratac.dataset.schema import Dataset
from spectratac.sim.twin_dataset import population
from spectratac.twin.errors import TwinError


@pytest.fixture(scope="module")
def pop() -> Dataset:
    return population([4, 7, 9], sessions_per_unit=2, session_s=30.0, seed=1)


def test_one_group_per_unit_and_session(pop: Dataset) -> None:
    sessions = pop.meta["sessions"]
    assert [(s["unit"], s["session_index"]) for s in sessions] == [
        (u, k) for u in (4, 7, 9) for k in range(2)
    ]
    assert sorted(set(pop.session.tolist())) == list(range(6))
    for i, s in enumerate(sessions):
        rows = pop.session == i
        assert rows.sum() == s["n"] == 600
        assert s["unit_id"] == f"twin-{s['unit']}"
        assert s["conditions"]["unit_seed"] == s["unit"]
        assert s["conditions"]["session_index"] == s["session_index"]
    assert pop.meta["units"] == [4, 7, 9]
    json.dumps(pop.meta)  # the metadata is stored as JSON
    pop.validate()


def test_sessions_differ_and_the_build_is_repeatable(pop: Dataset) -> None:
    means = [pop.inputs[pop.session == i].mean(axis=0) for i in range(6)]
    assert all(not np.allclose(a, b) for i, a in enumerate(means) for b in means[i + 1 :])
    again = population([4, 7, 9], sessions_per_unit=2, session_s=30.0, seed=1)
    assert np.array_equal(again.inputs, pop.inputs)
    assert np.array_equal(again.targets, pop.targets)
    presses = pop.press[pop.press >= 0]
    assert len(set(presses.tolist())) == len(np.unique(presses))
    # press ids stay unique across sessions
    for i in range(5):
        a = set(pop.press[(pop.session == i) & (pop.press >= 0)].tolist())
        b = set(pop.press[(pop.session == i + 1) & (pop.press >= 0)].tolist())
        assert not a & b


def test_progress_counts_every_session() -> None:
    seen: list[tuple[int, int]] = []
    population([0], 2, 10.0, scene="idle", progress=lambda d, t: seen.append((d, t)))
    assert seen == [(1, 2), (2, 2)]


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"units": []}, "units"),
        ({"units": [1, 1]}, "distinct"),
        ({"units": [-1]}, "non-negative"),
        ({"sessions_per_unit": 0}, "sessions_per_unit"),
        ({"session_s": 1.0}, "session_s"),
        ({"scene": "tour"}, "scene"),
    ],
)
def test_bad_arguments_are_refused(kwargs: dict, match: str) -> None:
    args = {"units": [0], "sessions_per_unit": 1, "session_s": 10.0} | kwargs
    with pytest.raises(TwinError, match=match):
        population(**args)


def test_cli_writes_the_dataset(tmp_path, capsys) -> None:
    out = tmp_path / "pop.npz"
    argv = ["twin", "population", "-o", str(out), "--units", "0,2", "--sessions", "2",
            "--duration", "20", "--no-progress", "--json"]  # fmt: skip
    assert main(argv) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["sessions"] == 4 and summary["samples"] == 1600
    ds = Dataset.load(out)
    assert [s["unit"] for s in ds.meta["sessions"]] == [0, 0, 2, 2]
    assert main([*argv[:-2], "--no-progress"]) == 3  # exists, no --force
    assert main(["twin", "population", "-o", str(tmp_path / "x.npz"), "--units", "a,b",
                 "--sessions", "1", "--no-progress"]) == 2  # fmt: skip
