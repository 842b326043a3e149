"""Fixtures for the firmware tests: native builds (made once per session) and tool checks."""

from __future__ import annotations

import importlib
import shutil
import socket
import subprocess
import time
from collections.abc import Iterator
from pathlib import Path
from types import ModuleType

import pytest

from tools.platformio import pio  # the offline PlatformIO runner

REPO = Path(__file__).resolve().parents[2]
OUT = REPO / "build" / "firmware" / "native"
# The two Black Pill images: USB CDC-ACM host link (env blackpill, what a board normally runs)
# and USART1 host link (env blackpill_uart). QEMU's netduinoplus2 models no OTG_FS controller,
# so the boot and conformance tests run the UART image.
ELF = REPO / "build" / "pio" / "blackpill_uart" / "firmware.elf"
USB_ELF = REPO / "build" / "pio" / "blackpill" / "firmware.elf"
# The UART image built as a test image (STAC_TEST_COMMANDS: DEBUG_FAULT faults or hangs).
TEST_ELF = REPO / "build" / "pio" / "blackpill_uart_test" / "firmware.elf"
BUILD_TIMEOUT_S = 600



def need(tool: str, package: str) -> None:
    if shutil.which(tool) is None:
        pytest.skip(f"{tool} not installed (apt install {package}; .ci/run installs it)")


C_TEST_TIMEOUT_S = 120  # a hung C test fails instead of blocking the suite


def listed_c_tests(binary: Path) -> list[str]:
    """The tests a C test program (tests/firmware/c/check_runner.c) names with --list."""
    return subprocess.run(
        [str(binary), "--list"], capture_output=True, text=True, timeout=C_TEST_TIMEOUT_S
    ).stdout.split()


def run_c_test(binary: Path, name: str) -> None:
    """Run one C test; fail with its output unless it passed with no sanitizer report."""
    result = subprocess.run(
        [str(binary), name], capture_output=True, text=True, timeout=C_TEST_TIMEOUT_S
    )
    output = result.stdout + result.stderr
    assert result.returncode == 0, output
    assert f"PASS {name}" in result.stdout, output
    assert "runtime error" not in output, output  # UBSan report


def build_image(env: str, elf: Path) -> Path:
    need("arm-none-eabi-gcc", "gcc-arm-none-eabi")
    result = pio.run(["run", "-e", env], timeout=BUILD_TIMEOUT_S)
    assert result.returncode == 0, result.stdout[-4000:] + result.stderr[-4000:]
    return elf


@pytest.fixture(scope="session")
def image() -> Path:
    """The STM32F411 image with the USART1 host link (the one QEMU can run), built offline
    through PlatformIO (once per session)."""
    return build_image("blackpill_uart", ELF)


@pytest.fixture(scope="session")
def usb_image() -> Path:
    """The STM32F411 image with the USB CDC-ACM host link."""
    return build_image("blackpill", USB_ELF)


@pytest.fixture(scope="session")
def test_image() -> Path:
    """The UART image as a test image (env blackpill_uart_test: DEBUG_FAULT compiled in)."""
    return build_image("blackpill_uart_test", TEST_ELF)


@pytest.fixture
def qemu_port(image: Path) -> Iterator[int]:
    """The image running in QEMU (-M netduinoplus2), USART1 on a local TCP port. QEMU holds
    the guest until the host connects (wait=on)."""
    yield from run_qemu(image)


@pytest.fixture
def qemu_test_port(test_image: Path) -> Iterator[int]:
    """The test image running in QEMU, as qemu_port."""
    yield from run_qemu(test_image)


def run_qemu(image: Path) -> Iterator[int]:
    need("qemu-system-arm", "qemu-system-arm")
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    qemu = subprocess.Popen(
        [
            "qemu-system-arm",
            "-M",
            "netduinoplus2",
            "-nographic",
            "-monitor",
            "none",
            # Virtual time counts instructions, not host time: the guest's rates then do not
            # depend on how loaded the host is. QEMU's TIM5 (the device clock) counts 1 GHz of
            # virtual time through the prescaler, which the firmware sets for its 16 MHz HSI
            # fallback (QEMU has no PLL): 1 ns an instruction makes that a 16 MHz core at one
            # instruction a cycle, as the board on its HSI.
            "-icount",
            "shift=0,align=off,sleep=off",
            "-kernel",
            str(image),
            "-serial",
            f"tcp:127.0.0.1:{port},server=on,wait=on",
        ],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
    )
    try:
        deadline = time.monotonic() + 20.0
        while True:  # until QEMU listens; this first connection releases the guest (wait=on)
            try:
                socket.create_connection(("127.0.0.1", port), timeout=1.0).close()
                break
            except OSError:
                if time.monotonic() > deadline or qemu.poll() is not None:
                    raise
                time.sleep(0.05)
        yield port
    finally:
        qemu.kill()
        qemu.wait(timeout=30)


def load_native_build() -> ModuleType:
    """tools/firmware/build.py: compiles the host targets of tools/firmware/build.toml."""
    return importlib.import_module("tools.firmware.build")


@pytest.fixture(scope="session")
def native_build() -> ModuleType:
    module = load_native_build()
    if module.compiler() is None:
        pytest.skip("no host C compiler (apt install build-essential; .ci/run installs it)")
    return module


@pytest.fixture(scope="session")
def unit_binary(native_build: ModuleType) -> Path:
    return native_build.build("unit-tests", OUT)


@pytest.fixture(scope="session")
def vector_binary(native_build: ModuleType) -> Path:
    return native_build.build("vector-check", OUT)


@pytest.fixture(scope="session")
def usb_binary(native_build: ModuleType) -> Path:
    return native_build.build("usb-tests", OUT)


@pytest.fixture(scope="session")
def sim_library(native_build: ModuleType) -> Path:
    return native_build.build("simlib", OUT)
