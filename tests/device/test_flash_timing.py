"""The host's wait for an erasing command's ACK comes from the datasheet's worst case: the
mirror in device/flash_timing.py equals hardware/datasheet_facts.toml, the firmware's own
per-sector bounds cover those maxima, and model_store waits at least the whole store's worst
case with margin (the constant 10 s it replaced was below 7.1 s x 1.5)."""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

from spectratac.device import flash_timing, model_store

REPO = Path(__file__).resolve().parents[2]
FLASH = tomllib.loads((REPO / "hardware" / "datasheet_facts.toml").read_text("utf-8"))["stm32f411"][
    "flash"
]


def test_the_mirror_is_the_facts_table() -> None:
    assert {int(k): v for k, v in FLASH["erase_max_s"]["value"].items()} == flash_timing.ERASE_MAX_S
    assert list(flash_timing.STORE_SECTORS_KIB) == FLASH["store_sectors_kib"]["value"]


def test_firmware_sector_bounds_cover_the_datasheet_maxima() -> None:
    header = (REPO / "firmware" / "ports" / "stm32f411" / "flash_store.h").read_text("utf-8")
    for kib in (64, 128):
        m = re.search(rf"#define FLASH_ERASE{kib}K_TIMEOUT_US (\d+)u", header)
        assert m, kib
        assert int(m.group(1)) >= flash_timing.ERASE_MAX_S[kib] * 1e6


def test_erasing_commands_wait_for_the_worst_case_with_margin() -> None:
    worst = sum(flash_timing.ERASE_MAX_S[k] for k in FLASH["store_sectors_kib"]["value"])
    assert flash_timing.worst_case_erase_s() == worst
    assert worst * 1.5 <= model_store.FLASH_TIMEOUT
    assert flash_timing.erase_ack_timeout_s() == model_store.FLASH_TIMEOUT
