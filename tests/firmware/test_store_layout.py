"""One flash layout everywhere: the STM32F411's program in sectors 0-3 and the model store
in sectors 4-7 (RM0383 table 4), as the linker script, the flash driver, the PlatformIO
board file, the simulator's store and the model image writer each state it."""

from __future__ import annotations

import json
import re

import pytest
from spectratac.decode.export import model_image as mi
from spectratac.sim.generated.native_abi import STORE_CAPACITY

from .conftest import REPO

pytestmark = [pytest.mark.firmware]

PORT = REPO / "firmware" / "ports" / "stm32f411"
KIB = 1024


def c_define(path, name: str) -> int:
    found = re.search(rf"^#define {name} (0x[0-9A-Fa-f]+|\d+)u\b", path.read_text(), re.M)
    assert found, f"{name} not in {path}"
    return int(found[1], 0)


def memory_regions() -> dict[str, tuple[int, int]]:
    text = (PORT / "stm32f411ce.ld").read_text()
    return {
        name: (int(origin, 0), int(length) * KIB)
        for name, origin, length in re.findall(
            r"^\s*(\w+) \(\w+\)\s*: ORIGIN = (0x[0-9A-Fa-f]+), LENGTH = (\d+)K", text, re.M
        )
    }


def test_program_and_store_split_the_flash_at_sector_4() -> None:
    regions = memory_regions()
    assert regions["FLASH"] == (0x08000000, 64 * KIB)  # sectors 0-3: 4 x 16 KiB
    assert regions["MODEL_STORE"] == (0x08010000, 448 * KIB)  # sector 4 + sectors 5-7
    assert sum(length for _, length in (regions["FLASH"], regions["MODEL_STORE"])) == 512 * KIB
    board = json.loads((REPO / "tools/platformio/boards/stac_blackpill_f411ce.json").read_text())
    assert board["upload"]["maximum_size"] == 64 * KIB


def test_every_side_agrees_on_the_store_size() -> None:
    header = PORT / "flash_store.h"
    assert c_define(header, "FLASH_STORE_ADDR") == memory_regions()["MODEL_STORE"][0]
    assert c_define(header, "FLASH_STORE_SIZE") == memory_regions()["MODEL_STORE"][1]
    assert STORE_CAPACITY == 458_752  # the simulator's store is the STM32's size
    record = c_define(REPO / "firmware" / "core" / "stac_model_store.h", "STAC_STORE_RECORD_AREA")
    assert mi.MAX_IMAGE_BYTES == STORE_CAPACITY - record == 458_688
