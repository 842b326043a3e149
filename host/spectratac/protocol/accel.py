"""Refuse to run on the pure-Python fallbacks of cobs and crcmod.

Both packages build C extensions at install time and silently fall back to Python when that
build fails, which makes framing ~35x slower. We check once at import and fail loudly, so that
a slow install is noticed at set-up rather than as dropped samples in an experiment.
Run ``python -m spectratac.protocol.accel_check`` to check an installation (a module of its
own: this one is imported by the package, so running it with -m would load it twice).
"""

from __future__ import annotations

import importlib
import os

from spectratac.errors import SpectraTacError

ALLOW_SLOW_ENV = "SPECTRATAC_ALLOW_PURE_PYTHON"


class AccelerationError(SpectraTacError, ImportError):
    """The C extension of cobs or crcmod is missing."""


def missing_extensions() -> list[str]:
    """Names of the packages that run on their pure-Python fallback."""
    missing = []
    if not getattr(importlib.import_module("cobs.cobs"), "_using_extension", False):
        missing.append("cobs")
    if not getattr(importlib.import_module("crcmod.crcmod"), "_usingExtension", False):
        missing.append("crcmod")
    return missing


def require_extensions() -> None:
    """Raise AccelerationError unless both C extensions are in use (or explicitly waived)."""
    missing = missing_extensions()
    if not missing or os.environ.get(ALLOW_SLOW_ENV) == "1":
        return
    names = " and ".join(missing)
    raise AccelerationError(
        f"{names} is running without its C extension, which makes frame decoding ~35x slower. "
        f"Install a C compiler and the Python headers (Debian: apt install build-essential "
        f"python3-dev), then reinstall: pip install --force-reinstall --no-binary :all: "
        f"{' '.join(missing)}. To accept the slow path anyway set {ALLOW_SLOW_ENV}=1."
    )
