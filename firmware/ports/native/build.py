"""Build the native port with the host's C compiler: the shared library (libstac_sim.so), the C
unit tests (AddressSanitizer + UBSan), the golden-vector probe and the benchmark program.

Used by `make firmware-native`, by the pytest suite (tests/firmware) and by
tools/bench/firmware.py. Rebuilds a target only when one of its sources is newer.

    python firmware/ports/native/build.py [--out build/firmware/native] [lib unit vectors bench]
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[3]
CORE = REPO / "firmware" / "core"
NATIVE = REPO / "firmware" / "ports" / "native"
CTESTS = REPO / "tests" / "firmware" / "c"
DEFAULT_OUT = REPO / "build" / "firmware" / "native"

WARN = ["-std=c11", "-Wall", "-Wextra", "-Werror", "-pedantic"]
SANITIZE = ["-g", "-O1", "-fno-omit-frame-pointer", "-fsanitize=address,undefined",
            "-fno-sanitize-recover=all"]


def core_sources() -> list[Path]:
    return sorted(CORE.glob("*.c")) + sorted((CORE / "generated").glob("*.c"))


def _headers() -> list[Path]:
    return sorted(CORE.glob("*.h")) + sorted((CORE / "generated").glob("*.h")) + sorted(
        NATIVE.glob("*.h")) + sorted(CTESTS.glob("*.h"))


def compiler() -> str | None:
    return os.environ.get("CC") or shutil.which("gcc") or shutil.which("cc")


def _build(target: Path, sources: list[Path], flags: list[str]) -> Path:
    deps = sources + _headers() + [Path(__file__)]
    if target.exists() and all(d.stat().st_mtime <= target.stat().st_mtime for d in deps):
        return target
    cc = compiler()
    if cc is None:
        raise RuntimeError("no C compiler found (install build-essential)")
    target.parent.mkdir(parents=True, exist_ok=True)
    tmp = target.with_suffix(target.suffix + ".tmp")
    cmd = [cc, *WARN, *flags, f"-I{CORE}", f"-I{NATIVE}", f"-I{CTESTS}",
           *map(str, sources), "-o", str(tmp)]
    result = subprocess.run(cmd, capture_output=True, text=True, check=False)
    if result.returncode != 0:
        raise RuntimeError(f"compile failed: {' '.join(cmd)}\n{result.stdout}{result.stderr}")
    tmp.replace(target)
    return target


def build_lib(out: Path = DEFAULT_OUT, build_id: str = "native") -> Path:
    """The core plus the native port as a shared library exporting only the stac_sim_* ABI."""
    return _build(out / "libstac_sim.so",
                  [*core_sources(), NATIVE / "stac_sim.c", NATIVE / "veml_model.c"],
                  ["-O2", "-Wconversion", "-fPIC", "-shared", "-fvisibility=hidden",
                   f'-DSTAC_BUILD_ID="{build_id}"'])


def build_lib_sanitized(out: Path = DEFAULT_OUT) -> Path:
    """The shared library with AddressSanitizer and UBSan, for host tests of the port and its
    sensor models (load it with libasan preloaded: tests/device/test_sim_sanitizers.py)."""
    return _build(out / "libstac_sim_asan.so",
                  [*core_sources(), NATIVE / "stac_sim.c", NATIVE / "veml_model.c"],
                  [*SANITIZE, "-fPIC", "-shared", "-fvisibility=hidden",
                   '-DSTAC_BUILD_ID="native"'])


def build_unit(out: Path = DEFAULT_OUT) -> Path:
    """The C unit tests against the fake board, with ASan and UBSan."""
    tests = sorted(p for p in CTESTS.glob("*.c") if p.name not in {"vector_check.c"})
    return _build(out / "unit_tests", core_sources() + tests, SANITIZE)


def build_vector_check(out: Path = DEFAULT_OUT) -> Path:
    return _build(out / "vector_check", [*core_sources(), CTESTS / "vector_check.c"], SANITIZE)


def build_bench(out: Path = DEFAULT_OUT) -> Path:
    """Timing program for tools/bench/firmware.py (optimised like a release build)."""
    return _build(out / "stac_bench", [*core_sources(), NATIVE / "bench" / "stac_bench.c"], ["-O2"])


BUILDERS = {"lib": build_lib, "lib-asan": build_lib_sanitized, "unit": build_unit,
            "vectors": build_vector_check, "bench": build_bench}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=DEFAULT_OUT)
    ap.add_argument("targets", nargs="*", help=f"any of {', '.join(BUILDERS)} (default: lib)")
    args = ap.parse_args()
    for name in args.targets or ["lib"]:
        if name not in BUILDERS:
            ap.error(f"unknown target {name!r}; choose from {', '.join(BUILDERS)}")
        print(BUILDERS[name](args.out))
    return 0


if __name__ == "__main__":
    sys.exit(main())
