"""Build (once, cached) and load the firmware core as a host shared library.

The simulated device is the real firmware: firmware/core plus firmware/ports/native compiled
with the system C compiler by firmware/ports/native/build.py (rebuilt when a source changes).
"""

from __future__ import annotations

import ctypes
import importlib.util
import os
import threading
from ctypes import POINTER, c_int32, c_uint8, c_uint16, c_uint32, c_uint64, c_void_p
from pathlib import Path
from types import ModuleType

import numpy as np

from spectratac.errors import SpectraTacError
from spectratac.hardware.veml3328 import CONF_WINDOW

REPO = Path(__file__).resolve().parents[3]
FIRMWARE = REPO / "firmware"
ABI_VERSION = 1
#: Use this prebuilt library instead of building one (e.g. the sanitizer build in tests).
LIB_ENV = "SPECTRATAC_SIM_LIB"

I2C_OK, I2C_NACK, I2C_TIMEOUT, I2C_BUS_ERROR = 0, 1, 2, 3

I2C_FN = ctypes.CFUNCTYPE(
    c_int32,
    c_void_p,
    c_uint32,
    c_uint8,
    c_uint8,
    POINTER(c_uint8),
    c_uint32,
    POINTER(c_uint8),
    c_uint32,
    c_uint32,
)
PWM_FN = ctypes.CFUNCTYPE(None, c_void_p, c_uint32, c_uint8, c_uint8, c_uint16)
TX_FN = ctypes.CFUNCTYPE(c_uint32, c_void_p, c_uint32, POINTER(c_uint8), c_uint32)
CLOCK_FN = ctypes.CFUNCTYPE(c_uint32, c_void_p)
WINDOW_FN = ctypes.CFUNCTYPE(
    c_int32, c_void_p, c_uint8, c_uint64, c_uint64, c_uint16, POINTER(c_uint16), POINTER(c_uint8)
)
PLAN_MAX = 256  # STAC_SIM_PLAN_MAX
SHARED_WINDOWS = 8  # STAC_SIM_SHARED_WINDOWS
WINDOW_BITS = CONF_WINDOW  # CONF bits a window's counts depend on (IT, SENS, gain, DG, SD_ALS)
#: stac_sim_window_t: one window computed ahead, as the library stores it
WINDOW_DTYPE = np.dtype(
    [
        ("t0_us", "<u8"),
        ("t1_us", "<u8"),
        ("conf", "<u2"),
        ("counts", "<u2", (3, 5)),
        ("saturated", "u1", (3,)),
        ("reserved", "u1", (5,)),
    ]
)
assert WINDOW_DTYPE.itemsize == 56


class Callbacks(ctypes.Structure):
    _fields_ = (
        ("user", c_void_p),
        ("i2c_transfer", I2C_FN),
        ("pwm_set", PWM_FN),
        ("uart_tx", TX_FN),
        ("clock_us", CLOCK_FN),
    )


class NativeBuildError(SpectraTacError):
    """The firmware could not be compiled for the host."""


_lock = threading.Lock()
_lib: ctypes.CDLL | None = None


def _builder() -> ModuleType:
    """firmware/ports/native/build.py: the one place that knows how to compile the core."""
    path = FIRMWARE / "ports" / "native" / "build.py"
    if not path.exists():
        raise NativeBuildError(
            f"{path} is missing: the simulated device compiles the firmware from the repository "
            f"checkout (firmware/ next to host/)"
        )
    spec = importlib.util.spec_from_file_location("stac_native_build", path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def build() -> Path:
    """Compile the native port unless an up-to-date build exists; return the library."""
    builder = _builder()
    if builder.compiler() is None:
        raise NativeBuildError(
            "no C compiler found: the simulated device compiles the firmware for this host. "
            "Install one (Debian: apt install build-essential) or set CC."
        )
    try:
        return Path(builder.build_lib())
    except RuntimeError as exc:
        raise NativeBuildError(f"compiling the native firmware failed: {exc}") from None


def load() -> ctypes.CDLL:
    """The loaded library with argument types declared (built on first use).

    Loaded as a PyDLL: calls keep the GIL. A CDLL call releases it and every Python callback
    takes it back, so with another thread waiting (the host reading the stream) each of a
    step's callbacks became a thread switch; a step is microseconds of C, holding is cheaper."""
    global _lib
    with _lock:
        if _lib is not None:
            return _lib
        path = os.environ.get(LIB_ENV) or str(build())
        lib = declare(ctypes.PyDLL(path))
        if lib.stac_sim_abi_version() != ABI_VERSION:
            raise NativeBuildError(
                f"native firmware ABI {lib.stac_sim_abi_version()} != {ABI_VERSION} expected by "
                f"this host library: update both from one checkout"
            )
        _lib = lib
        return lib


def declare(lib: ctypes.CDLL) -> ctypes.CDLL:
    """Declare the stac_sim_* argument and result types on a loaded library."""
    lib.stac_sim_abi_version.restype = c_uint32
    lib.stac_sim_sizeof.restype = c_uint32
    lib.stac_sim_default_capabilities.restype = c_uint32
    lib.stac_sim_init.restype = c_int32
    lib.stac_sim_init.argtypes = [
        c_void_p,
        POINTER(Callbacks),
        ctypes.c_char_p,
        c_uint32,
        c_void_p,
        c_uint32,
        c_uint32,
    ]
    lib.stac_sim_step.restype = None
    lib.stac_sim_step.argtypes = [c_void_p, c_uint32]
    lib.stac_sim_rx_feed.restype = c_uint32
    lib.stac_sim_rx_feed.argtypes = [c_void_p, ctypes.c_char_p, c_uint32]
    lib.stac_sim_next_wake_us.restype = c_uint32
    lib.stac_sim_next_wake_us.argtypes = [c_void_p]
    lib.stac_sim_streaming.restype = c_uint32
    lib.stac_sim_streaming.argtypes = [c_void_p]
    # Additions within ABI 1: 64-bit time, free-running, native sensor models with a plan.
    lib.stac_sim_step64.restype = None
    lib.stac_sim_step64.argtypes = [c_void_p, c_uint64]
    lib.stac_sim_now64.restype = c_uint64
    lib.stac_sim_now64.argtypes = [c_void_p]
    lib.stac_sim_run.restype = c_uint32
    lib.stac_sim_run.argtypes = [c_void_p, c_uint32]
    lib.stac_sim_init_models.restype = c_int32
    lib.stac_sim_init_models.argtypes = [
        c_void_p,
        POINTER(Callbacks),
        WINDOW_FN,
        c_uint32,
        ctypes.c_char_p,
        c_uint32,
        c_void_p,
        c_uint32,
        c_uint32,
    ]
    lib.stac_sim_plan.restype = c_uint32
    lib.stac_sim_plan.argtypes = [c_void_p, c_void_p, c_uint32, POINTER(c_uint32), c_uint32]
    lib.stac_sim_plan_progress.restype = None
    lib.stac_sim_plan_progress.argtypes = [c_void_p, POINTER(c_uint32), POINTER(c_uint32)]
    lib.stac_sim_sensor_transfer.restype = c_int32
    lib.stac_sim_sensor_transfer.argtypes = [
        c_void_p,
        c_uint8,
        c_uint64,
        ctypes.c_char_p,
        c_uint32,
        c_void_p,
        c_uint32,
    ]
    return lib
