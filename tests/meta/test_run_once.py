"""tests/run_once.py: an expensive input (the apps' trained decoder) is made once per run even
when several pytest-xdist workers ask for it at the same time."""

from __future__ import annotations

import threading
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest

from tests.run_once import made_once, run_folder


def test_workers_asking_at_once_make_the_input_once(
    tmp_path_factory: pytest.TempPathFactory, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.delenv("PYTEST_XDIST_WORKER", raising=False)  # this run's own basetemp
    makes = []
    inside = threading.Lock()

    def make(folder: Path) -> None:
        assert inside.acquire(blocking=False), "two makers ran at once"
        makes.append(folder)
        (folder / "model.stac").write_bytes(b"trained")
        inside.release()

    with ThreadPoolExecutor(4) as pool:
        folders = list(pool.map(lambda _: made_once(tmp_path_factory, "thing", make), range(4)))
    assert len(makes) == 1 and set(folders) == {makes[0]}
    assert (folders[0] / "model.stac").read_bytes() == b"trained"


def test_workers_share_the_parent_of_their_basetemps(
    tmp_path_factory: pytest.TempPathFactory, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("PYTEST_XDIST_WORKER", "gw1")  # as a worker sees it
    assert run_folder(tmp_path_factory) == tmp_path_factory.getbasetemp().parent
    monkeypatch.delenv("PYTEST_XDIST_WORKER")
    assert run_folder(tmp_path_factory) == tmp_path_factory.getbasetemp()
