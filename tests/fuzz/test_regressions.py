"""Every input the fuzzers found (tests/fuzz/regressions/<target>/*.bin), replayed: each must
now get a result or its reader's typed error."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.fuzz.harness import check_one, regression_inputs
from tests.fuzz.targets import TARGETS

CASES = regression_inputs()


@pytest.mark.parametrize(("target", "path"), CASES, ids=[f"{t}/{p.name}" for t, p in CASES])
def test_regression_input_is_answered(target: str, path: Path, tmp_path: Path) -> None:
    error = check_one(TARGETS[target], path.read_bytes(), tmp_path, measure_memory=True)
    assert error is None, f"{path}:\n{error}"
