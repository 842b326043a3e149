"""The native port's additions (sensor models, window plans, free-running steps) under
AddressSanitizer and UBSan: the model tests run again in a Python that loads the sanitized
build of the library (libasan preloaded, as a sanitized shared library requires)."""

from __future__ import annotations

import pytest

from tests.sanitized_sim import REPO, run_on_sanitized_library

pytestmark = [pytest.mark.firmware, pytest.mark.subprocess]


def test_model_tests_pass_on_the_sanitized_library() -> None:
    # The seeded long sessions cover what the hypothesis variant does, in less time.
    select = "not test_native_register_model_matches_python_model"
    out = run_on_sanitized_library(REPO / "tests" / "device" / "test_sim_models.py", "-k", select)
    assert " passed, 1 deselected" in out, out[-4000:]
