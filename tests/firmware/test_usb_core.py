"""The USB device core (firmware/usb) under AddressSanitizer and UBSan, one pytest case per C
test (tests/firmware/usb/test_usb.c): every standard request in each device state, request
errors answered with STALL, the address taking effect after the status stage, configuration
set and cleared, CDC line coding round trip, DTR, the zero-length-packet rule and wLength
truncation, and the configuration descriptor's chain of lengths."""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

import pytest

from .conftest import BUILD_TIMEOUT_S, C_TEST_TIMEOUT_S, listed_c_tests, need, pio, run_c_test

pytestmark = [pytest.mark.firmware, pytest.mark.subprocess]

SOURCE = Path(__file__).resolve().parent / "usb" / "test_usb.c"

NAMES = re.findall(r'^\s*\{"(usb_\w+)",', SOURCE.read_text(), flags=re.M)


def test_every_usb_test_is_collected(usb_binary: Path) -> None:
    assert sorted(listed_c_tests(usb_binary)) == sorted(NAMES)
    assert len(NAMES) >= 20


@pytest.mark.parametrize("name", NAMES)
def test_usb(usb_binary: Path, name: str) -> None:
    run_c_test(usb_binary, name)


def test_unknown_test_name_fails(usb_binary: Path) -> None:
    result = subprocess.run(
        [str(usb_binary), "usb_no_such_test"],
        capture_output=True,
        text=True,
        timeout=C_TEST_TIMEOUT_S,
    )
    assert result.returncode == 2 and "no test named" in result.stdout


def test_platformio_env_runs_usb_tests() -> None:
    """`pio run -e native_usb -t exec` builds the same target and runs every test."""
    need("gcc", "build-essential")
    result = pio.run(["run", "-e", "native_usb", "-t", "exec"], timeout=BUILD_TIMEOUT_S)
    assert result.returncode == 0, result.stdout[-4000:] + result.stderr[-4000:]
    assert re.search(rf"^{len(NAMES)} tests, 0 failed$", result.stdout, flags=re.M), result.stdout[
        -2000:
    ]
