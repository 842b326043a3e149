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
    monkeypatch.setenv("PYTEST_XDIST_WORKER", "gw1")  # as a worker sees it
    makes = []
    inside = threading.Lock()

    def make(folder: Path) -> None:
        assert inside.acquire(blocking=False), "two makers ran at once"
        makes.append(folder)
        (folder / "model.stac").write_bytes(b"trained")
        inside.release()

    name = f"thing-{tmp_path_factory.getbasetemp().name}"  # this run's own, even serially
    with ThreadPoolExecutor(4) as pool:
        folders = list(pool.map(lambda _: made_once(tmp_path_factory, name, make), range(4)))
    assert len(makes) == 1 and set(folders) == {makes[0]}
    assert folders[0].parent == tmp_path_factory.getbasetemp().parent  # shared by the workers
    assert (folders[0] / "model.stac").read_bytes() == b"trained"


def test_a_serial_run_keeps_its_inputs_in_its_own_basetemp(
    tmp_path_factory: pytest.TempPathFactory, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.delenv("PYTEST_XDIST_WORKER", raising=False)
    assert run_folder(tmp_path_factory) == tmp_path_factory.getbasetemp()
