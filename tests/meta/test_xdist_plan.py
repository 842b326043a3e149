"""tests/xdist_plan.py: under `make test` the costliest modules are handed out first."""

from __future__ import annotations

import pytest

from tests import xdist_plan


class Item:
    """What plan() reads of a pytest item: its id and its marks."""

    def __init__(self, nodeid: str, *marks: pytest.MarkDecorator) -> None:
        self.nodeid = nodeid
        self.marks = [m.mark for m in marks]

    def get_closest_marker(self, name: str) -> pytest.Mark | None:
        return next((m for m in self.marks if m.name == name), None)

    def add_marker(self, mark: pytest.MarkDecorator) -> None:
        self.marks.append(mark.mark)


def test_the_costliest_modules_go_first() -> None:
    items = [
        Item("tests/a/test_quick.py::test_1"),
        Item("tests/a/test_quick.py::test_2"),
        Item("tests/b/test_demo.py::test_runs", pytest.mark.slow),
        Item("tests/b/test_demo.py::test_table"),
        Item("tests/c/test_shared.py::test_x"),
        Item("tests/c/test_serve.py::test_y", pytest.mark.subprocess),
    ]
    xdist_plan.order(items)  # type: ignore[arg-type]
    assert [i.nodeid for i in items] == [
        "tests/b/test_demo.py::test_runs",
        "tests/b/test_demo.py::test_table",
        "tests/c/test_serve.py::test_y",
        "tests/a/test_quick.py::test_1",
        "tests/a/test_quick.py::test_2",
        "tests/c/test_shared.py::test_x",
    ]
