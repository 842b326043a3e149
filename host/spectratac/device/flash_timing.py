"""How long the device may stall in a flash erase, from the datasheet's worst case: the host's
ACK timeout for MODEL_BEGIN and MODEL_CLEAR (device/model_store.py).

A sector erase stalls the STM32F411's instruction fetch (code runs from the same flash bank),
so the device answers only when every sector the command erases is done. The worst case is
each sector's maximum erase time (hardware/datasheet_facts.toml, [stm32f411.flash]; mirrored
here because the installed package does not ship that file, and tests/device/
test_flash_timing.py checks the mirror) summed over the whole model store, times a margin for
the datasheet's figures being unverified, plus the link's own round trip.

>>> round(worst_case_erase_s(), 2)
7.1
>>> round(erase_ack_timeout_s(), 2)
11.65
"""

from __future__ import annotations

#: t_ERASE maxima by sector size (KiB) at x32 parallelism, seconds (DS10314)
ERASE_MAX_S: dict[int, float] = {16: 0.5, 64: 1.1, 128: 2.0}
#: the model store's sectors (sectors 4-7 of the STM32F411), KiB
STORE_SECTORS_KIB: tuple[int, ...] = (64, 128, 128, 128)
#: the datasheet maxima are unverified: allow half as much again
MARGIN = 1.5
#: the command and its ACK on a busy link, and the device's own work besides the erase
LINK_ALLOWANCE_S = 1.0


def worst_case_erase_s(sectors: tuple[int, ...] = STORE_SECTORS_KIB) -> float:
    """The longest one MODEL_BEGIN or MODEL_CLEAR can stall: every sector at its maximum."""
    return sum(ERASE_MAX_S[kib] for kib in sectors)


def erase_ack_timeout_s() -> float:
    """How long to wait for the ACK of a command that erases the model store."""
    return worst_case_erase_s() * MARGIN + LINK_ALLOWANCE_S
