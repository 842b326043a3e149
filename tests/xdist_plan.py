"""How `make test` shares the suite among pytest-xdist workers (`--dist loadgroup
--no-loadscope-reorder`): each test module is one unit of work (its module fixtures are made
once, in one worker) unless its tests name an `xdist_group` of their own, and the units go out
costliest first, so that no long module starts last while the other worker sits idle."""

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


def plan(items: list[pytest.Item]) -> None:
    """Group each test without an xdist_group mark by its module, and order the modules
    (then the groups' members keep their place) by their summed cost, costliest first."""
    totals: dict[str, int] = {}
    for item in items:
        if item.get_closest_marker("xdist_group") is None:
            item.add_marker(pytest.mark.xdist_group(module_of(item)))
        totals[module_of(item)] = totals.get(module_of(item), 0) + cost(item)
    first_seen = {m: i for i, m in reversed(list(enumerate(map(module_of, items))))}
    items.sort(key=lambda it: (-totals[module_of(it)], first_seen[module_of(it)]))
