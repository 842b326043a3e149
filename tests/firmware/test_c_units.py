"""The C unit tests (tests/firmware/c) under AddressSanitizer and UBSan, one pytest case each:
the VEML3328 driver against a fake register-level bus (NACK, stall, wrong id, saturation),
sequencer and scheduler timing, command validation, codec, and random bytes into the decoder."""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

import pytest

pytestmark = [pytest.mark.firmware, pytest.mark.subprocess]

C_DIR = Path(__file__).resolve().parent / "c"
TIMEOUT_S = 120  # a hang fails the test instead of blocking the suite


def registered_tests() -> list[str]:
    names: list[str] = []
    for path in sorted(C_DIR.glob("test_*.c")):
        names += re.findall(r'^\s*\{"(\w+)", \w+\},?$', path.read_text(), flags=re.M)
        # Entries wrapped over two lines by the formatter.
        names += re.findall(r'^\s*\{"(\w+)",\s*$', path.read_text(), flags=re.M)
    return names


NAMES = registered_tests()


def test_every_c_test_is_collected(unit_binary: Path) -> None:
    listed = subprocess.run(
        [str(unit_binary), "--list"], capture_output=True, text=True, timeout=TIMEOUT_S
    ).stdout.split()
    assert sorted(listed) == sorted(NAMES)
    assert len(NAMES) >= 40


@pytest.mark.parametrize("name", NAMES)
def test_c(unit_binary: Path, name: str) -> None:
    result = subprocess.run(
        [str(unit_binary), name], capture_output=True, text=True, timeout=TIMEOUT_S
    )
    output = result.stdout + result.stderr
    assert result.returncode == 0, output
    assert f"PASS {name}" in result.stdout, output
    assert "runtime error" not in output, output  # UBSan report
