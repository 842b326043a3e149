"""The firmware core's receive/command path under libFuzzer with ASan + UBSan (harness
tests/fuzz/native/fuzz_core.c, target "fuzz-core" of tools/firmware/build.toml), a fixed
number of runs from the golden vectors; crash inputs land in tests/fuzz/regressions/
native_core/ and are replayed, with the vectors, by test_native_regressions_replay."""

from __future__ import annotations

import importlib
import json
import os
import subprocess
from pathlib import Path
from types import ModuleType

import pytest

from tests.fuzz.harness import REGRESSIONS, SEED_ENV, native_runs

pytestmark = [pytest.mark.fuzz, pytest.mark.firmware, pytest.mark.subprocess]

REPO = Path(__file__).resolve().parents[2]
BUILD = REPO / "tools" / "firmware" / "build.py"
TARGET = "fuzz-core"
CRASHES = REGRESSIONS / "native_core"
MAX_LEN = 4096  # bytes per input: several maximum-length frames and an oversize run
MALLOC_LIMIT_MB = 64
RSS_LIMIT_MB = 6144


def _builder() -> ModuleType:
    return importlib.import_module("tools.firmware.build")


@pytest.fixture(scope="module")
def harness(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The harness compiled as the build description says, with the compiler it names."""
    try:
        return _builder().build(TARGET, tmp_path_factory.mktemp("fuzz"))
    except RuntimeError as exc:  # no clang, or a compile error: say which
        pytest.fail(f"{TARGET} did not build: {str(exc)[-3000:]}")


def _vector_corpus(folder: Path) -> Path:
    folder.mkdir()
    for path in sorted((REPO / "protocol" / "vectors").glob("*.json")):
        (folder / path.stem).write_bytes(bytes.fromhex(json.loads(path.read_text())["hex"]))
    return folder


def test_core_survives_fuzzed_input(harness: Path, tmp_path: Path) -> None:
    CRASHES.mkdir(parents=True, exist_ok=True)
    before = set(CRASHES.iterdir())
    corpus = _vector_corpus(tmp_path / "corpus")
    runs = native_runs()
    done = subprocess.run(
        [
            str(harness),
            f"-runs={runs}",
            f"-seed={1 + int(os.environ.get(SEED_ENV, '0'))}",
            f"-max_len={MAX_LEN}",
            # the core has no heap: one input asking for more than this is a finding; the
            # process's RSS (ASan's shadow and quarantine, the fuzzer's corpus) grows past
            # libFuzzer's default 2 GB over 300k runs without any input being at fault
            f"-malloc_limit_mb={MALLOC_LIMIT_MB}",
            f"-rss_limit_mb={RSS_LIMIT_MB}",
            f"-artifact_prefix={CRASHES}/",
            "-print_final_stats=1",
            str(corpus),
        ],
        capture_output=True,
        text=True,
        check=False,
        cwd=tmp_path,
        env={**os.environ, "ASAN_OPTIONS": "quarantine_size_mb=64"},  # ASan's default: 256
    )
    new = sorted(set(CRASHES.iterdir()) - before)
    assert done.returncode == 0 and not new, (
        f"the core crashed or stopped answering; inputs saved: {[str(p) for p in new]}\n"
        f"{done.stderr[-4000:]}"
    )
    assert f"Done {runs} runs" in done.stderr, done.stderr[-2000:]


def test_native_regressions_replay(harness: Path, tmp_path: Path) -> None:
    """Each saved crash input (and each golden vector) runs once through the harness."""
    inputs = sorted(_vector_corpus(tmp_path / "vectors").iterdir())
    if CRASHES.is_dir():
        inputs += sorted(p for p in CRASHES.iterdir() if p.is_file())
    done = subprocess.run(
        [str(harness), *map(str, inputs)], capture_output=True, text=True, check=False
    )
    assert done.returncode == 0, done.stderr[-4000:]
    assert done.stderr.count("Executed ") == len(inputs)
