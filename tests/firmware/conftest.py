"""Fixtures for the firmware tests: native builds (made once per session) and tool checks."""

from __future__ import annotations

import importlib.util
import shutil
from pathlib import Path
from types import ModuleType

import pytest

REPO = Path(__file__).resolve().parents[2]
OUT = REPO / "build" / "firmware" / "native"


def load_native_build() -> ModuleType:
    """firmware/ports/native/build.py, the one place that knows how to compile the core."""
    path = REPO / "firmware" / "ports" / "native" / "build.py"
    spec = importlib.util.spec_from_file_location("stac_native_build", path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="session")
def native_build() -> ModuleType:
    module = load_native_build()
    if module.compiler() is None:
        pytest.skip("no host C compiler (apt install build-essential; .ci/run installs it)")
    return module


@pytest.fixture(scope="session")
def unit_binary(native_build: ModuleType) -> Path:
    return native_build.build_unit(OUT)


@pytest.fixture(scope="session")
def vector_binary(native_build: ModuleType) -> Path:
    return native_build.build_vector_check(OUT)


@pytest.fixture(scope="session")
def sim_library(native_build: ModuleType) -> Path:
    return native_build.build_lib(OUT)


def require_tool(name: str, package: str) -> str:
    path = shutil.which(name)
    if path is None:
        pytest.skip(f"{name} not installed (apt install {package}; .ci/run installs it)")
    return path
