"""Find and load the simulator library: the firmware core compiled for this host.

The simulated device is the real firmware: firmware/core, the native port's HAL glue and the
VEML3328 register models beside it (firmware/ports/native), built as described once in
tools/firmware/build.toml.
The library comes from, in this order:

1. ``$SPECTRATAC_SIM_LIB``: a prebuilt library (the tests load the sanitizer build this way);
2. a source checkout (this package imported from ``host/`` beside ``firmware/``):
   build/firmware/native/libstac_sim.so, compiled by tools/firmware/build.py on first use and
   again whenever a C source, header or the build description is newer;
3. an installed package: libstac_sim.so beside this module, compiled when the wheel was built
   (setup.py). An installed package never runs a build script.

The ctypes declarations of the library's C ABI are generated (spectratac.sim.generated.native_abi).
"""

from __future__ import annotations

import ctypes
import importlib.util
import os
import threading
from pathlib import Path
from types import ModuleType

from spectratac.errors import SpectraTacError
from spectratac.sim.generated.native_abi import (
    ABI_VERSION,
    CLOCK_FN,
    I2C_BUS_ERROR,
    I2C_FN,
    I2C_NACK,
    I2C_OK,
    I2C_TIMEOUT,
    PLAN_MAX,
    PWM_FN,
    SHARED_WINDOWS,
    TX_FN,
    WINDOW_BITS,
    WINDOW_DTYPE,
    WINDOW_FN,
    Callbacks,
    declare,
)

__all__ = [
    "ABI_VERSION",
    "CLOCK_FN",
    "I2C_BUS_ERROR",
    "I2C_FN",
    "I2C_NACK",
    "I2C_OK",
    "I2C_TIMEOUT",
    "LIB_ENV",
    "PACKAGED_LIBRARY",
    "PLAN_MAX",
    "PWM_FN",
    "SHARED_WINDOWS",
    "TX_FN",
    "WINDOW_BITS",
    "WINDOW_DTYPE",
    "WINDOW_FN",
    "Callbacks",
    "NativeBuildError",
    "checkout_builder",
    "declare",
    "library_path",
    "load",
]

#: Use this prebuilt library instead of the checkout's or the package's.
LIB_ENV = "SPECTRATAC_SIM_LIB"
#: Where an installed package holds the library (setup.py compiles it into the wheel).
PACKAGED_LIBRARY = Path(__file__).with_name("libstac_sim.so")
#: The library target of tools/firmware/build.toml.
TARGET = "simlib"


class NativeBuildError(SpectraTacError):
    """The simulator library could not be found, compiled or loaded."""


_lock = threading.Lock()
_lib: ctypes.CDLL | None = None


def checkout_builder() -> ModuleType | None:
    """tools/firmware/build.py when this package is imported from a source checkout, else None.

    A checkout is recognised by its layout: this file under ``host/spectratac/sim/`` and the
    build description in ``tools/firmware/`` of the same tree. Installed copies (site-packages)
    never match, so they never compile anything."""
    here = Path(__file__).resolve()
    root = here.parents[3]
    script = root / "tools" / "firmware" / "build.py"
    description = root / "tools" / "firmware" / "build.toml"
    if here.parents[2].name != "host" or not description.is_file():
        return None
    spec = importlib.util.spec_from_file_location("stac_native_build", script)
    if spec is None or spec.loader is None:
        return None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def library_path() -> Path:
    """The library `load()` uses (compiled first in a checkout when a source is newer)."""
    prebuilt = os.environ.get(LIB_ENV)
    if prebuilt:
        return Path(prebuilt)
    builder = checkout_builder()
    if builder is None:
        if not PACKAGED_LIBRARY.is_file():
            raise NativeBuildError(
                f"{PACKAGED_LIBRARY} is missing: this installation of spectratac has no simulator "
                f"library. Install a wheel built on a machine with a C compiler (`pip wheel .` in "
                f"a checkout), or point {LIB_ENV} at a built libstac_sim.so."
            )
        return PACKAGED_LIBRARY
    if builder.compiler() is None:
        raise NativeBuildError(
            "no C compiler found: a source checkout compiles the simulated device's firmware for "
            "this host. Install one (Debian: apt install build-essential) or set CC."
        )
    try:
        return Path(builder.build(TARGET))
    except RuntimeError as exc:
        raise NativeBuildError(f"compiling the native firmware failed: {exc}") from None


def load() -> ctypes.CDLL:
    """The loaded library with argument types declared (compiled first in a checkout).

    >>> load().stac_sim_abi_version() == ABI_VERSION
    True

    Loaded as a PyDLL: calls keep the GIL. A CDLL call releases it and every Python callback
    takes it back, so with another thread waiting (the host reading the stream) each of a
    step's callbacks became a thread switch; a step is microseconds of C, holding is cheaper."""
    global _lib
    with _lock:
        if _lib is not None:
            return _lib
        path = library_path()
        try:
            lib = declare(ctypes.PyDLL(str(path)))
        except (OSError, AttributeError) as exc:
            raise NativeBuildError(
                f"cannot load the simulator library {path}: {exc}. Rebuild it from the same "
                f"checkout as this package (`make firmware-native`) or reinstall the package."
            ) from None
        if lib.stac_sim_abi_version() != ABI_VERSION:
            raise NativeBuildError(
                f"{path} has ABI {lib.stac_sim_abi_version()}, this package expects "
                f"{ABI_VERSION}: build both from one checkout"
            )
        _lib = lib
        return lib
