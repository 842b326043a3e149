"""Fuzz every host reader (see targets.py): seeded mutations of valid inputs, a fixed number
per target derived from SPECTRATAC_FUZZ_SECONDS. A failure names the saved input; replay it
with tests/fuzz/test_regressions.py."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from tests.fuzz.harness import SEED_ENV, fuzz, iterations
from tests.fuzz.targets import TARGETS

pytestmark = pytest.mark.fuzz


@pytest.mark.parametrize("name", sorted(TARGETS))
def test_reader_answers_any_input_with_a_result_or_its_typed_error(
    name: str, tmp_path: Path
) -> None:
    target = TARGETS[name]
    seed = int(os.environ.get(SEED_ENV, "0"))
    findings = fuzz(target, tmp_path, iterations(target), seed=seed)
    report = "\n\n".join(f"{f.path}:\n{f.error}" for f in findings)
    assert not findings, f"{len(findings)} input(s) escaped {name}'s typed errors:\n{report}"
