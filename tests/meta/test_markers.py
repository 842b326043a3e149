"""The test tiers stay honest: a test module that trains a model, spawns processes, boots QEMU
or runs KiCad/OpenSCAD carries that marker, so that `make test-fast` (which deselects them)
stays fast as tests are added. Fixtures that do so are marked in tests/conftest.py instead."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

TESTS = Path(__file__).resolve().parents[1]
MODULES = sorted(TESTS.rglob("test_*.py"))
# What a module does (found in its source) -> the markers, one of which it must carry.
NEEDS: dict[str, tuple[re.Pattern[str], tuple[str, ...]]] = {
    "trains a model": (
        re.compile(
            r"import torch|\bTrainSpec\b|\btrain\(|main\(\[\"(train|demo)\"|\"twin\", \"report\""
            r"|\brun_demo\(|run_bench\(\s*\"decoder"
        ),
        ("train",),
    ),
    "spawns processes": (
        re.compile(r"\bsubprocess\.|\bPopen\b"),
        ("subprocess", "firmware", "qemu", "kicad"),
    ),
    "boots QEMU": (re.compile(r"qemu-system"), ("qemu",)),
    "runs KiCad or OpenSCAD": (re.compile(r"\bpcbnew\b|kicad-cli|\bopenscad\b"), ("kicad",)),
}


@pytest.mark.parametrize("path", MODULES, ids=lambda p: str(p.relative_to(TESTS)))
def test_modules_carry_the_markers_of_what_they_do(path: Path) -> None:
    source = path.read_text()
    if path == Path(__file__):
        return
    for what, (pattern, markers) in NEEDS.items():
        if pattern.search(source):
            assert any(f"pytest.mark.{m}" in source for m in markers), (
                f"{path.name} {what}: mark it pytest.mark.{markers[0]} (pytestmark = ...)"
            )
