"""Package build step that pyproject.toml cannot express: compile the simulator library.

The project metadata lives in pyproject.toml. Here `build_py` additionally compiles the
`simlib` target of tools/firmware/build.toml (the firmware core, the native port and the
VEML3328 models) with the host C compiler into the package as spectratac/sim/libstac_sim.so,
where spectratac.sim.native loads it, so an installed wheel opens sim:// without a checkout.
The wheel is therefore tagged for this platform.

Editable installs skip the step: there spectratac.sim.native finds the checkout and compiles
into build/firmware/native/ on use, again whenever a C source changes.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path
from types import ModuleType

from setuptools import setup
from setuptools.command.build_py import build_py
from setuptools.dist import Distribution

ROOT = Path(__file__).resolve().parent
LIBRARY = Path("spectratac") / "sim" / "libstac_sim.so"


def native_build() -> ModuleType:
    """tools/firmware/build.py, the builder of tools/firmware/build.toml (standard library only)."""
    script = ROOT / "tools" / "firmware" / "build.py"
    spec = importlib.util.spec_from_file_location("stac_native_build", script)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


class BuildPyWithSimulator(build_py):
    """build_py, plus the simulator library compiled into the built package."""

    def run(self) -> None:
        super().run()
        if self.editable_mode:
            return  # the checkout compiles on demand (spectratac.sim.native)
        builder = native_build()
        if builder.compiler() is None:
            raise SystemExit(
                "building spectratac needs a C compiler for the simulated device's firmware "
                "(Debian: apt install build-essential; or set CC)"
            )
        target = Path(self.build_lib) / LIBRARY
        built = builder.build("simlib", target.parent)
        assert built == target, f"{built} is not where spectratac.sim.native looks ({target})"

    def get_outputs(self, include_bytecode: bool = True) -> list[str]:
        outputs = super().get_outputs(include_bytecode)
        return outputs if self.editable_mode else [*outputs, str(Path(self.build_lib) / LIBRARY)]


class PlatformDistribution(Distribution):
    """The wheel holds a compiled library: tag it for this platform, not py3-none-any."""

    def has_ext_modules(self) -> bool:
        return True


setup(cmdclass={"build_py": BuildPyWithSimulator}, distclass=PlatformDistribution)
