"""Host builds of the firmware as described by tools/firmware/build.toml: the simulator library
(libstac_sim.so and its sanitized twin), the C unit tests, the golden-vector probe and the
benchmark program, compiled with the system C compiler.

Used by the package build (setup.py), by PlatformIO's stac-native platform (which reads a
target through `target()` and compiles it with SCons), by the tests and benchmarks of a
checkout, and by spectratac.sim.native in a checkout. `build()` recompiles a target only when
one of its inputs is newer than the output, so edited C sources are picked up on the next use.
Standard library only: setup.py imports it before any dependency is installed.

    python -m tools.firmware.build [--out build/firmware/native] [simlib simlib-asan unit-tests ...]
"""

from __future__ import annotations

import argparse
import contextlib
import fcntl
import glob
import os
import shutil
import subprocess
import sys
import tomllib
from collections.abc import Iterator
from pathlib import Path
from typing import NamedTuple

REPO = Path(__file__).resolve().parents[2]
DESCRIPTION = Path(__file__).resolve().with_name("build.toml")
DEFAULT_OUT = REPO / "build" / "firmware" / "native"
KINDS = ("shared", "program")
#: What a shared library adds to every compile and link (SCons adds its own equivalents).
SHARED_FLAGS = ("-fPIC", "-shared")


class BuildDescriptionError(ValueError):
    """tools/firmware/build.toml does not say what a target needs."""


class Target(NamedTuple):
    """One output of the description, with every path resolved against the repository.
    (A NamedTuple, not a dataclass: loaders import this file without registering a module.)"""

    name: str
    kind: str
    output: str
    sources: tuple[Path, ...]
    include_dirs: tuple[Path, ...]
    defines: tuple[tuple[str, str], ...]
    flags: tuple[str, ...]
    link_flags: tuple[str, ...]
    compiler: str | None = None  # a compiler this target needs (e.g. clang for libFuzzer)

    def headers(self) -> list[Path]:
        """Every header in the include folders (what a source may depend on)."""
        return sorted(h for d in self.include_dirs for h in d.rglob("*.h"))

    def command(self, cc: str, output: Path) -> list[str]:
        """One compiler invocation that compiles and links the target into `output`."""
        shared = list(SHARED_FLAGS) if self.kind == "shared" else []
        defines = [f'-D{name}="{value}"' for name, value in self.defines]
        includes = [f"-I{d}" for d in self.include_dirs]
        return [
            cc,
            *self.flags,
            *shared,
            *defines,
            *includes,
            *map(str, self.sources),
            *self.link_flags,
            "-o",
            str(output),
        ]


def _expand(entries: list[str], lists: dict[str, list[str]], where: str) -> list[str]:
    out: list[str] = []
    for entry in entries:
        if entry.startswith("@"):
            if entry[1:] not in lists:
                raise BuildDescriptionError(
                    f"{where}: {entry!r} names no list; define [lists].{entry[1:]} in "
                    f"{DESCRIPTION.name}"
                )
            out += _expand(lists[entry[1:]], lists, where)
        else:
            out.append(entry)
    return out


def _paths(patterns: list[str], root: Path, where: str) -> list[Path]:
    paths: list[Path] = []
    for pattern in patterns:
        found = sorted(Path(p) for p in glob.glob(str(root / pattern)))
        if not found:
            raise BuildDescriptionError(f"{where}: {pattern!r} matches no file under {root}")
        paths += found
    return paths


def target_names(description: Path = DESCRIPTION) -> list[str]:
    """The targets a description defines.

    >>> target_names()  # doctest: +NORMALIZE_WHITESPACE
    ['simlib', 'simlib-asan', 'unit-tests', 'builtin-tests', 'vector-check', 'bench',
     'usb-tests', 'fuzz-core', 'model-check']
    """
    return list(tomllib.loads(description.read_text(encoding="utf-8")).get("targets", {}))


def target(name: str, description: Path = DESCRIPTION, root: Path = REPO) -> Target:
    """Target `name` of a description, its paths resolved against `root` (only this target's
    files need to exist: an sdist carries just what the library needs).

    >>> lib = target("simlib")
    >>> lib.kind, lib.output, [p.name for p in lib.sources][-2:]
    ('shared', 'libstac_sim.so', ['stac_sim.c', 'veml_model.c'])
    """
    raw = tomllib.loads(description.read_text(encoding="utf-8"))
    lists: dict[str, list[str]] = raw.get("lists", {})
    targets = raw.get("targets", {})
    if name not in targets:
        raise BuildDescriptionError(
            f"{description.name} has no target {name!r}; choose from {', '.join(targets)}"
        )
    spec = targets[name]
    where = f"{description.name} [targets.{name}]"
    if spec.get("kind") not in KINDS:
        raise BuildDescriptionError(f"{where}: kind must be one of {', '.join(KINDS)}")
    excluded = set(_paths(_expand(spec.get("exclude", []), lists, where), root, where))
    sources = _paths(_expand(spec["sources"], lists, where), root, where)
    includes = _expand(spec.get("include_dirs", []), lists, where)
    return Target(
        name=name,
        kind=spec["kind"],
        output=spec["output"],
        sources=tuple(p for p in sources if p not in excluded),
        include_dirs=tuple(root / d for d in includes),
        defines=tuple((k, str(v)) for k, v in spec.get("defines", {}).items()),
        flags=tuple(_expand(spec.get("flags", []), lists, where)),
        link_flags=tuple(_expand(spec.get("link_flags", []), lists, where)),
        compiler=spec.get("compiler"),
    )


def compiler() -> str | None:
    """The host C compiler: $CC, else gcc, else cc; None when there is none."""
    return os.environ.get("CC") or shutil.which("gcc") or shutil.which("cc")


def build(name: str, out: Path = DEFAULT_OUT) -> Path:
    """Compile target `name` into folder `out` unless it is newer than all its inputs (sources,
    headers, the description and this script); return the output file."""
    chosen = target(name)
    output = out / chosen.output
    inputs = [*chosen.sources, *chosen.headers(), DESCRIPTION, Path(__file__)]
    out.mkdir(parents=True, exist_ok=True)
    # Several processes (pytest-xdist workers, a test beside `make demo`) may want the same
    # output at once: one compiles while the others wait, then find it up to date.
    with _exclusive(output.with_name(output.name + ".lock")):
        if output.exists() and all(p.stat().st_mtime <= output.stat().st_mtime for p in inputs):
            return output
        cc = shutil.which(chosen.compiler) if chosen.compiler else compiler()
        if cc is None:
            apt = "clang libclang-rt-14-dev" if chosen.compiler == "clang" else "build-essential"
            raise RuntimeError(
                f"no {chosen.compiler or 'C compiler'} found for target {name!r} (Debian: apt "
                f"install {apt})"
            )
        # A private partial file, renamed into place: a process that loaded the old library
        # keeps its copy, and no reader ever sees a half-written one.
        partial = output.with_name(f"{output.name}.{os.getpid()}.partial")
        cmd = chosen.command(cc, partial)
        done = subprocess.run(cmd, capture_output=True, text=True, check=False)
        if done.returncode != 0:
            partial.unlink(missing_ok=True)
            raise RuntimeError(f"compile failed: {' '.join(cmd)}\n{done.stdout}{done.stderr}")
        partial.replace(output)
        return output


@contextlib.contextmanager
def _exclusive(lock: Path) -> Iterator[None]:
    """Hold an exclusive advisory lock on file `lock` (created if missing) for the block."""
    with open(lock, "a") as handle:
        fcntl.flock(handle, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)


def main() -> int:
    targets = target_names()
    ap = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    ap.add_argument("--out", type=Path, default=DEFAULT_OUT)
    ap.add_argument("targets", nargs="*", help=f"any of {', '.join(targets)} (default: simlib)")
    args = ap.parse_args()
    for name in args.targets or ["simlib"]:
        if name not in targets:
            ap.error(f"unknown target {name!r}; choose from {', '.join(targets)}")
        print(build(name, args.out))
    return 0


if __name__ == "__main__":
    sys.exit(main())
