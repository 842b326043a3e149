"""How `make test` shares the suite among pytest-xdist workers (`--dist loadfile
--no-loadscope-reorder`): each test module is one unit of work (its module fixtures are made
once, in one worker), and the modules go out costliest first, so that no long module starts
last while the other worker sits idle."""

from __future__ import annotations

import pytest

#: Rough cost of a test by its tier markers (pyproject.toml), relative to a plain unit test.
#: Only the order of the modules depends on it: a wrong guess costs balance, never a result.
MARKER_COST = {"slow": 40, "train": 20, "firmware": 20, "qemu": 20, "kicad": 20, "fuzz": 20,
               "subprocess": 5}  # fmt: skip


def module_of(item: pytest.Item) -> str:
    return item.nodeid.split("::", 1)[0]


def cost(item: pytest.Item) -> int:
    return max([1, *(c for m, c in MARKER_COST.items() if item.get_closest_marker(m))])


def order(items: list[pytest.Item]) -> None:
    """Sort modules (each keeping its tests' order) by their summed cost, costliest first."""
    totals: dict[str, int] = {}
    for item in items:
        totals[module_of(item)] = totals.get(module_of(item), 0) + cost(item)
    first_seen = {m: i for i, m in reversed(list(enumerate(map(module_of, items))))}
    items.sort(key=lambda it: (-totals[module_of(it)], first_seen[module_of(it)]))
