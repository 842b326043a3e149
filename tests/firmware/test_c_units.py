"""The C unit tests (tests/firmware/c) under AddressSanitizer and UBSan, one pytest case each:
the VEML3328 driver against a fake register-level bus (NACK, stall, wrong id, saturation),
acquisition timing, command validation, codec, and random bytes into the decoder."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from .conftest import listed_c_tests, run_c_test

pytestmark = [pytest.mark.firmware, pytest.mark.subprocess]

C_DIR = Path(__file__).resolve().parent / "c"


def registered_tests() -> list[str]:
    names: list[str] = []
    for path in sorted(C_DIR.glob("test_*.c")):
        names += re.findall(r'^\s*\{"(\w+)", \w+\},?$', path.read_text(), flags=re.M)
        # Entries wrapped over two lines by the formatter.
        names += re.findall(r'^\s*\{"(\w+)",\s*$', path.read_text(), flags=re.M)
    return names


NAMES = registered_tests()


def test_every_c_test_is_collected(unit_binary: Path) -> None:
    assert sorted(listed_c_tests(unit_binary)) == sorted(NAMES)
    assert len(NAMES) >= 40


@pytest.mark.parametrize("name", NAMES)
def test_c(unit_binary: Path, name: str) -> None:
    run_c_test(unit_binary, name)
