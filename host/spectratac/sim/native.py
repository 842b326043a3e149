"""Build (once, cached) and load the firmware core as a host shared library.

The simulated device is the real firmware: firmware/core plus firmware/ports/native compiled
with the system C compiler into build/native/libstac_sim-<hash>.so, where <hash> covers every
source, so an edited firmware is rebuilt on next use and never loaded stale.
"""

from __future__ import annotations

import ctypes
import hashlib
import os
import shutil
import subprocess
import threading
from ctypes import POINTER, c_int32, c_uint8, c_uint16, c_uint32, c_void_p
from pathlib import Path

from spectratac.errors import SpectraTacError

REPO = Path(__file__).resolve().parents[3]
FIRMWARE = REPO / "firmware"
SOURCE_DIRS = ("core", "core/generated", "ports/native")
BUILD_DIR = REPO / "build" / "native"
ABI_VERSION = 1

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


def sources() -> list[Path]:
    files: list[Path] = []
    for sub in SOURCE_DIRS:
        folder = FIRMWARE / sub
        files += sorted(folder.glob("*.c")) + sorted(folder.glob("*.h"))
    if not files:
        raise NativeBuildError(
            f"no firmware sources under {FIRMWARE}: the simulated device needs the repository "
            f"checkout (firmware/ next to host/)"
        )
    return files


def library_path() -> Path:
    digest = hashlib.sha256()
    for path in sources():
        digest.update(path.relative_to(FIRMWARE).as_posix().encode())
        digest.update(path.read_bytes())
    return BUILD_DIR / f"libstac_sim-{digest.hexdigest()[:12]}.so"


def build() -> Path:
    """Compile the native port if this exact source set has not been built yet."""
    target = library_path()
    if target.exists():
        return target
    cc = os.environ.get("CC") or shutil.which("cc") or shutil.which("gcc")
    if cc is None:
        raise NativeBuildError(
            "no C compiler found: the simulated device compiles the firmware for this host. "
            "Install one (Debian: apt install build-essential) or set CC."
        )
    target.parent.mkdir(parents=True, exist_ok=True)
    c_files = [str(p) for p in sources() if p.suffix == ".c"]
    includes = [f"-I{FIRMWARE / sub}" for sub in SOURCE_DIRS]
    tmp = target.with_suffix(f".{os.getpid()}.tmp")
    cmd = [
        cc,
        "-std=c11",
        "-O2",
        "-fPIC",
        "-shared",
        "-fvisibility=hidden",
        "-Wall",
        "-Wextra",
        "-Werror",
        *includes,
        *c_files,
        "-o",
        str(tmp),
    ]
    done = subprocess.run(cmd, capture_output=True, text=True)
    if done.returncode != 0:
        raise NativeBuildError(f"compiling the native firmware failed:\n{done.stderr[-4000:]}")
    tmp.replace(target)  # atomic: concurrent builders never load a half-written file
    return target


def load() -> ctypes.CDLL:
    """The loaded library with argument types declared (built on first use)."""
    global _lib
    with _lock:
        if _lib is not None:
            return _lib
        lib = ctypes.CDLL(str(build()))
        lib.stac_sim_abi_version.restype = c_uint32
        if lib.stac_sim_abi_version() != ABI_VERSION:
            raise NativeBuildError(
                f"native firmware ABI {lib.stac_sim_abi_version()} != {ABI_VERSION} expected by "
                f"this host library: update both from one checkout"
            )
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
        _lib = lib
        return lib
