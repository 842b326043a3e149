"""The model store tests of the simulator library (test_model_store_sim.py) on its
AddressSanitizer + UBSan build (target simlib-asan), in a subprocess that preloads the
sanitizer runtime: the native port's store file, flash faults and the decoder run clean."""

from __future__ import annotations

import pytest

from tests.sanitized_sim import REPO, run_on_sanitized_library

pytestmark = [pytest.mark.firmware, pytest.mark.subprocess]


def test_store_tests_pass_on_the_sanitized_library() -> None:
    run_on_sanitized_library(REPO / "tests" / "firmware" / "test_model_store_sim.py")
