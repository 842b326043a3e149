"""The native port's additions (sensor models, window plans, free-running steps) under
AddressSanitizer and UBSan: the model tests run again in a Python that loads the sanitized
build of the library (libasan preloaded, as a sanitized shared library requires)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest
from spectratac.sim import native

pytestmark = [pytest.mark.firmware, pytest.mark.subprocess]

REPO = Path(__file__).resolve().parents[2]


def test_model_tests_pass_on_the_sanitized_library() -> None:
    builder = native.checkout_builder()
    assert builder is not None, "the tests run from a source checkout"
    lib = builder.build("simlib-asan")
    cc = builder.compiler()
    assert cc is not None
    asan = subprocess.run(
        [cc, "-print-file-name=libasan.so"], capture_output=True, text=True, check=True
    ).stdout.strip()
    env = dict(
        os.environ,
        LD_PRELOAD=asan,
        ASAN_OPTIONS="detect_leaks=0:abort_on_error=1",  # CPython's own allocations linger
        UBSAN_OPTIONS="halt_on_error=1:print_stacktrace=1",
        **{native.LIB_ENV: str(lib)},
    )
    tests = REPO / "tests" / "device" / "test_sim_models.py"
    # The seeded long sessions cover what the hypothesis variant does, in less time.
    select = "not test_native_register_model_matches_python_model"
    done = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", str(tests), "-k", select],
        capture_output=True,
        text=True,
        env=env,
        cwd=REPO,
        timeout=900,
    )
    output = done.stdout + done.stderr
    assert " passed, 1 deselected" in done.stdout, output[-4000:]
    assert done.returncode == 0, output[-4000:]
    assert "AddressSanitizer" not in output and "runtime error" not in output, output[-4000:]
