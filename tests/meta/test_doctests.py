"""Every example in a public docstring of the package runs and gives what it shows.

Modules are found by walking the package, so a new module's examples are tested without
anyone listing it here.
"""

from __future__ import annotations

import doctest
import importlib
import pkgutil

import pytest
import spectratac


def modules_with_examples() -> list[str]:
    names = []
    for info in pkgutil.walk_packages(spectratac.__path__, "spectratac."):
        spec = importlib.util.find_spec(info.name)
        if spec and spec.origin and spec.origin.endswith(".py"):
            with open(spec.origin, encoding="utf-8") as f:
                if ">>> " in f.read():
                    names.append(info.name)
    return names


@pytest.mark.parametrize("name", modules_with_examples())
def test_examples(name: str) -> None:
    result = doctest.testmod(importlib.import_module(name), optionflags=doctest.ELLIPSIS)
    assert result.attempted > 0 and result.failed == 0
