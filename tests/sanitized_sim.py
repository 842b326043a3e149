"""Running simulator tests again in a Python that loads the AddressSanitizer + UBSan build of
the simulator library (target simlib-asan; libasan preloaded, as a sanitized shared library
requires)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

from spectratac.sim import native

REPO = Path(__file__).resolve().parents[1]


def run_on_sanitized_library(tests: Path, *pytest_args: str) -> str:
    """Run the pytest file `tests` (plus `pytest_args`) on the sanitized library; fail unless
    it passes without a sanitizer report. Returns pytest's stdout."""
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
    done = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", str(tests), *pytest_args],
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
    return done.stdout
