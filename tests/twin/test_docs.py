"""Docstring examples of the twin and decode packages are tested; imports stay torch-free."""

from __future__ import annotations

import doctest
import importlib
import pkgutil
import subprocess
import sys

import pytest
import spectratac.decode
import spectratac.twin

_SUBMODULES = sorted(
    f"{pkg.__name__}.{m.name}"
    for pkg in (spectratac.twin, spectratac.decode)
    for m in pkgutil.iter_modules(pkg.__path__)
)
MODULES = [*_SUBMODULES, "spectratac.twin", "spectratac.decode"]


@pytest.mark.parametrize("name", MODULES)
def test_doctests(name: str) -> None:
    mod = importlib.import_module(name)
    result = doctest.testmod(mod, optionflags=doctest.ELLIPSIS)
    assert result.failed == 0


def test_twin_and_decode_do_not_import_torch() -> None:
    code = (
        "import sys, spectratac.twin, spectratac.decode, spectratac.twin.rig, "
        "spectratac.twin.oracle, spectratac.decode.fidelity; print('torch' in sys.modules)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def test_model_card_documents_every_unit_constant(repo) -> None:
    from dataclasses import fields

    from spectratac.twin.unit import UnitParams

    card = (repo / "host/spectratac/twin/MODEL.md").read_text()
    missing = [f.name for f in fields(UnitParams) if f"`{f.name}`" not in card]
    assert not missing, f"MODEL.md lacks: {missing}"
