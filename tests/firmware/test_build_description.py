"""tools/firmware/build.toml is the one description of the host builds: its reader's examples
hold, the simulator library it describes contains every source of the core, the native port and
the sensor models, a checkout rebuilds when an input is newer, and PlatformIO builds the same
library (the same exported entry points, the ones the generated ctypes declarations name)."""

from __future__ import annotations

import ctypes
import doctest
import os
import subprocess
import threading
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from types import ModuleType

import pytest
from spectratac.sim.generated import native_abi

from .conftest import BUILD_TIMEOUT_S, REPO, need, pio

pytestmark = pytest.mark.firmware  # compiles the build description's targets

FIRMWARE = REPO / "firmware"


def exported(library: Path) -> set[str]:
    out = subprocess.run(
        ["nm", "-D", "--defined-only", str(library)], capture_output=True, text=True, check=True
    ).stdout
    return {line.split()[-1] for line in out.splitlines() if " T " in line}


def test_reader_examples(native_build: ModuleType) -> None:
    result = doctest.testmod(native_build, optionflags=doctest.ELLIPSIS)
    assert result.attempted >= 3 and result.failed == 0


def test_simulator_library_holds_every_source_it_needs(native_build: ModuleType) -> None:
    lib = native_build.target("simlib")
    expected = {
        *FIRMWARE.glob("core/*.c"),
        *FIRMWARE.glob("core/generated/*.c"),
        *FIRMWARE.glob("ports/native/*.c"),
    }
    assert set(lib.sources) == expected
    assert {p.name for p in lib.sources} >= {"stac_sim.c", "veml_model.c"}
    assert lib.kind == "shared" and lib.output == "libstac_sim.so"
    assert all(p.is_relative_to(FIRMWARE) for p in lib.sources)


def test_a_newer_input_rebuilds(native_build: ModuleType, tmp_path: Path) -> None:
    first = native_build.build("vector-check", tmp_path)
    built_at = first.stat().st_mtime_ns
    assert native_build.build("vector-check", tmp_path).stat().st_mtime_ns == built_at
    source = native_build.target("vector-check").sources[-1]
    older = source.stat().st_mtime - 10
    os.utime(first, (older, older))  # as if the source had been edited after the build
    assert native_build.build("vector-check", tmp_path).stat().st_mtime > older


def test_builds_of_one_output_at_once_compile_it_once(
    native_build: ModuleType, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """pytest-xdist workers (or a test beside `make demo`) build the same library together:
    one compiles, the others wait and take its output; nobody fails on a shared partial file."""
    compiles = []
    real_run = subprocess.run

    def counting_run(cmd, *args, **kwargs):  # type: ignore[no-untyped-def]
        compiles.append(cmd)
        return real_run(cmd, *args, **kwargs)

    monkeypatch.setattr(subprocess, "run", counting_run)
    with ThreadPoolExecutor(4) as pool:
        built = list(pool.map(lambda _: native_build.build("vector-check", tmp_path), range(4)))
    assert built == [tmp_path / "vector_check"] * 4 and len(compiles) == 1, compiles
    assert built[0].read_bytes()[:4] == b"\x7fELF"  # whole, not a half-written file
    assert [p.name for p in tmp_path.iterdir() if "partial" in p.name] == []


def test_platformio_builds_the_same_simulator_library(sim_library: Path) -> None:
    need("gcc", "build-essential")
    result = pio.run(["run", "-e", "simlib"], timeout=BUILD_TIMEOUT_S)
    assert result.returncode == 0, result.stdout[-4000:] + result.stderr[-4000:]
    from_pio = REPO / "build" / "pio" / "simlib" / "libstac_sim.so"
    assert exported(from_pio) == exported(sim_library) == set(native_abi.SIGNATURES)
    lib = native_abi.declare(ctypes.CDLL(str(from_pio)))
    assert lib.stac_sim_abi_version() == native_abi.ABI_VERSION


def test_pio_runs_of_one_checkout_take_turns(monkeypatch: pytest.MonkeyPatch) -> None:
    """Two pio runs at once (pytest-xdist workers) would compile into the same build/pio
    objects: tools/platformio/pio.py lets one in at a time."""
    meetings: list[str] = []
    both = threading.Barrier(2, timeout=5.0)

    def fake_pio(*_args: object, **_kwargs: object) -> subprocess.CompletedProcess[str]:
        try:  # a second run inside pio at the same time passes the barrier
            both.wait()
            meetings.append("together")
        except threading.BrokenBarrierError:
            meetings.append("alone")
        return subprocess.CompletedProcess([], 0, "", "")

    monkeypatch.setattr(pio.subprocess, "run", fake_pio)
    with ThreadPoolExecutor(2) as pool:
        done = list(pool.map(lambda _: pio.run(["run", "-e", "native"]), range(2)))
    assert [d.returncode for d in done] == [0, 0]
    assert "together" not in meetings, meetings
