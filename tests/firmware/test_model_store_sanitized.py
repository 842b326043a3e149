"""The model store tests of the simulator library (test_model_store_sim.py) on its
AddressSanitizer + UBSan build (target simlib-asan), in a subprocess that preloads the
sanitizer runtime: the native port's store file, flash faults and the decoder run clean."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest
from spectratac.sim import native

pytestmark = [pytest.mark.firmware, pytest.mark.subprocess]

REPO = Path(__file__).resolve().parents[2]


def test_store_tests_pass_on_the_sanitized_library() -> None:
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
    tests = REPO / "tests" / "firmware" / "test_model_store_sim.py"
    done = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", str(tests)],
        capture_output=True,
        text=True,
        env=env,
        cwd=REPO,
        timeout=900,
    )
    output = done.stdout + done.stderr
    assert done.returncode == 0, output[-4000:]
    assert " passed" in done.stdout and " failed" not in done.stdout, output[-4000:]
    assert "AddressSanitizer" not in output and "runtime error" not in output, output[-4000:]
