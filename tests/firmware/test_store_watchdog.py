"""The model store's commit and boot never starve the watchdog (issue 23 item 3).

MODEL_COMMIT (and the boot's check of an installed model) runs one CRC-32C pass over the
image in blocks of STAC_STORE_CRC_BLOCK bytes with a watchdog refresh after each, then the
interpreter's checks, then another refresh (tests/firmware/c/test_store.c counts the
refreshes). This bounds, for a full 448 KiB store, the longest stretch without a refresh and
the whole pass, with the decode bench's cycle model (tools/bench/ondevice.py: Cortex-M4 TRM
cycles of the compiled loop, branch refill P = 2, three flash wait states per 16-byte line),
against the shortest watchdog period the port allows: its IWDG prescaler and reload
(ports/stm32f411/watchdog.h) at the LSI's fastest (hardware/datasheet_facts.toml).

The interpreter's checks are measured, not modelled: the QEMU timeline image boots with the
paper's float32 model installed and reports the boot's instructions; less the CRC loop's
instructions for the image, that is the interpreter's part, scaled to a full store and
costed at 2 cycles an instruction (the top of the bench's CPI range).
"""

from __future__ import annotations

import math
import re
import struct
import tomllib
from pathlib import Path

import pytest
from spectratac.decode import Decoder
from spectratac.decode.export import model_image as mi

from tools.bench import ondevice  # the decode bench's cycle model

from .conftest import REPO
from .test_decode_timeline import paper  # noqa: F401  (the module's fixture)
from .test_decode_timeline_qemu import elf, run, store_region  # noqa: F401

pytestmark = [pytest.mark.train, pytest.mark.firmware, pytest.mark.qemu, pytest.mark.slow]

CLOCK_HZ = 96e6
STORE_BYTES = mi.MAX_IMAGE_BYTES  # 448 KiB less the commit record
CPI_MAX = 2.0  # ondevice.py's cycles_range upper end for code outside the inner loops


def define(path: Path, name: str) -> int:
    m = re.search(rf"#define {name} (\d+)u", path.read_text(encoding="utf-8"))
    assert m, f"{name} not found in {path}"
    return int(m.group(1))


def watchdog_period_s() -> float:
    """The running IWDG period at the LSI's maximum frequency (RM0383 17.3: the counter runs
    at LSI / (4 << PR) and resets after RLR + 1 counts)."""
    main = REPO / "firmware" / "ports" / "stm32f411" / "watchdog.h"
    pr, rlr = define(main, "IWDG_RUN_PR"), define(main, "IWDG_RUN_RLR")
    facts = tomllib.loads((REPO / "hardware" / "datasheet_facts.toml").read_text("utf-8"))
    lsi_max = facts["stm32f411"]["lsi_hz"]["value"]["max"]
    return (4 << pr) * (rlr + 1) / lsi_max


def crc_loop(image: Path) -> tuple[float, int]:
    """(TRM cycles, instructions) per byte of stac_crc32c_update's loop: a rotated loop, the
    test at its head (cmp, a taken bne into the body) and a `b` back to it."""
    rows = ondevice.disassembly(image, "stac_crc32c_update")
    back = [
        (i, ondevice._target(ops))
        for i, (addr, mn, ops) in enumerate(rows)
        if mn in ("b", "b.n", "b.w") and (ondevice._target(ops) or addr) < addr
    ]
    assert len(back) == 1, f"expected one loop in stac_crc32c_update: {rows}"
    at = {addr: i for i, (addr, _, _) in enumerate(rows)}
    j, head = back[0]
    k = next(i for i in range(at[head], j) if rows[i][1] in ondevice.BRANCHES)
    body = rows[at[head] : k + 1] + rows[at[ondevice._target(rows[k][2])] : j + 1]
    cycles = sum(ondevice._cycles(mn, ops) for _, mn, ops in body)
    assert [mn for _, mn, _ in body].count("ldrb.w") == 1, "one byte per iteration expected"
    return cycles + ondevice.FLASH_WAIT_STATES / 16, len(body)


def test_full_store_commit_refreshes_the_watchdog_in_time(
    elf: Path,  # noqa: F811
    paper: Decoder,  # noqa: F811
    tmp_path: Path,
) -> None:
    period = watchdog_period_s()
    per_byte, insns_per_byte = crc_loop(elf)
    block = define(REPO / "firmware" / "core" / "stac_model_store.h", "STAC_STORE_CRC_BLOCK")

    # The interpreter's checks, measured at boot on the paper's float32 image.
    image = mi.encode(paper, "f32")
    region = tmp_path / "store.bin"
    region.write_bytes(store_region(image, 0x5EED))
    run(elf, region, tmp_path / "boot", 1.5, estimates=False)
    (boot_insns,) = struct.unpack("<Q", (tmp_path / "boot" / "timeline.boot").read_bytes())
    open_insns = boot_insns - insns_per_byte * len(image)
    assert 0 < open_insns < boot_insns
    open_s = (
        open_insns * STORE_BYTES / len(image) * CPI_MAX
        + STORE_BYTES / 16 * ondevice.FLASH_WAIT_STATES
    ) / CLOCK_HZ

    crc_s = STORE_BYTES * per_byte / CLOCK_HZ
    gap_s = max(block * per_byte / CLOCK_HZ, open_s)  # refreshes: after each block and the open
    print(
        f"\nwatchdog {period * 1e3:.0f} ms at LSI max; CRC loop {per_byte:.2f} cycles/B; "
        f"full store: CRC pass {crc_s * 1e3:.1f} ms, interpreter checks {open_s * 1e3:.1f} ms, "
        f"refreshes {math.ceil(STORE_BYTES / block) + 1}, longest gap {gap_s * 1e3:.1f} ms; "
        f"four passes without a refresh (before): {4 * crc_s * 1e3:.0f} ms"
    )
    assert period == pytest.approx(0.3408, rel=1e-3)  # PR 2, RLR 1000 at 47 kHz
    assert gap_s < period / 10, f"{gap_s * 1e3:.1f} ms without a refresh"
    # Even with no refresh at all the single pass would fit: the refreshes are the margin.
    assert crc_s + open_s < period / 2
