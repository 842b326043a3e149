"""Every register address, offset and bit field of the STM32F411 port, checked against ST's SVD.

The checker (regs_svd.py) finds the macros by parsing firmware/ports/stm32f411/regs.h and
flash_store.h, so a macro added tomorrow is checked too; these tests also show that it catches
an injected typo of each kind, and that the drivers write no register address of their own.
"""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from . import regs_svd
from .regs_svd import PORT, REGISTER_HEADERS, check, svd_path


def sources() -> dict[str, str]:
    return {name: (PORT / name).read_text(encoding="utf-8") for name in REGISTER_HEADERS}


def test_the_svd_is_sts_description_of_the_f411() -> None:
    # pyocd's STM32F41x.svd describes the F415/F417: a check against it would prove nothing.
    root = ET.parse(svd_path()).getroot()
    assert root.findtext("name") == "STM32F411xx"
    assert root.findtext("vendor", "STMicroelectronics").startswith("STM")


def test_every_register_macro_matches_st_svd() -> None:
    problems = check()
    assert problems == [], "\n".join(problems)


def test_the_check_covers_every_macro_of_the_register_headers() -> None:
    macros: dict[str, regs_svd.Macro] = {}
    for name, text in sources().items():
        macros.update(regs_svd.parse_macros(text, name))
    checker = regs_svd.Checker(
        macros,
        {},
        regs_svd.Device(
            {**regs_svd.svd_device().peripherals, **regs_svd.core_device().peripherals},
            regs_svd.svd_device().interrupts,
        ),
    )
    checker.run()
    unchecked = set(macros) - set(checker.checked) - set(regs_svd.NOT_REGISTERS)
    assert unchecked == set()
    assert len(checker.checked) > 150, "the headers were not parsed"


MUTATIONS = [
    # (file, text in the header, replacement, the macro the checker must name)
    (
        "regs.h",
        "#define RCC_CR_HSERDY (1u << 17)",
        "#define RCC_CR_HSERDY (1u << 18)",
        "RCC_CR_HSERDY",
    ),
    (
        "regs.h",
        "OTG_DCTL REG32(OTG_FS_BASE + 0x804u)",
        "OTG_DCTL REG32(OTG_FS_BASE + 0x808u)",
        "OTG_DCTL",
    ),
    (
        "regs.h",
        "#define I2C2 ((i2c_t *)0x40005800u)",
        "#define I2C2 ((i2c_t *)0x40005C00u)",
        "I2C2",
    ),
    (
        "regs.h",
        "volatile uint32_t SR, DR, BRR, CR1",
        "volatile uint32_t DR, SR, BRR, CR1",
        "USART1",
    ),
    (
        "regs.h",
        "#define SYSTICK_CSR_TICKINT (1u << 1)",
        "#define SYSTICK_CSR_TICKINT (1u << 2)",
        "SYSTICK_CSR_TICKINT",
    ),
    ("regs.h", "#define OTG_FS_IRQN 67u", "#define OTG_FS_IRQN 68u", "OTG_FS_IRQN"),
    ("regs.h", "#define UID_BASE 0x1FFF7A10u", "#define UID_BASE 0x1FFF7A14u", "UID_BASE"),
    (
        "regs.h",
        "#define PWR_CSR_VOSRDY (1u << 14)",
        "#define PWR_CSR_VOSRDY (1u << 15)",
        "PWR_CSR_VOSRDY",
    ),
    (
        "regs.h",
        "#define OTG_GCCFG_NOVBUSSENS (1u << 21)",
        "#define OTG_GCCFG_NOVBUSSENS (1u << 20)",
        "OTG_GCCFG_NOVBUSSENS",
    ),
    (
        "regs.h",
        "#define NVIC_ISER(n) REG32(0xE000E100u",
        "#define NVIC_ISER(n) REG32(0xE000E180u",
        "NVIC_ISER",
    ),
    (
        "regs.h",
        "#define RCC_PLLCFGR_PLLN_SHIFT 6u",
        "#define RCC_PLLCFGR_PLLN_SHIFT 5u",
        "RCC_PLLCFGR_PLLN_SHIFT",
    ),
    (
        "flash_store.h",
        "#define FLASH_CR_SNB_SHIFT 3u",
        "#define FLASH_CR_SNB_SHIFT 4u",
        "FLASH_CR_SNB_SHIFT",
    ),
    (
        "flash_store.h",
        "#define FLASH_KEY2 0xCDEF89ABu",
        "#define FLASH_KEY2 0xCDEF98ABu",
        "FLASH_KEY2",
    ),
    # A new macro is checked without being listed anywhere.
    (
        "regs.h",
        "#endif /* STM32F411_REGS_H */",
        "#define RCC_CR_HSEONN (1u << 16)\n#endif",
        "RCC_CR_HSEONN",
    ),
]


@pytest.mark.parametrize(("file", "old", "new", "macro"), MUTATIONS, ids=[m[3] for m in MUTATIONS])
def test_checker_reports_an_injected_typo(file: str, old: str, new: str, macro: str) -> None:
    texts = sources()
    assert texts[file].count(old) == 1, f"{old!r} is no longer in {file}: update the mutation"
    texts[file] = texts[file].replace(old, new)
    problems = check(texts)
    assert any(p.startswith(f"{macro} ") for p in problems), problems


SINGLE_BITS = sorted(
    (m.group(1), int(m.group(2)))
    for text in sources().values()
    for m in re.finditer(r"^#define (\w+) \(1u << (\d+)\)$", text, re.M)
)


@settings(max_examples=80, deadline=None)
@given(st.sampled_from(SINGLE_BITS), st.integers(0, 31))
def test_any_single_bit_moved_elsewhere_is_reported(bit: tuple[str, int], moved_to: int) -> None:
    name, position = bit
    if moved_to == position:
        return
    texts = sources()
    for file, text in texts.items():
        line = f"#define {name} (1u << {position})\n"
        if line in text:
            texts[file] = text.replace(line, f"#define {name} (1u << {moved_to})\n")
    problems = check(texts)
    assert any(p.startswith(f"{name} ") for p in problems), f"{name} at bit {moved_to}: {problems}"


def test_manual_wins_where_the_svd_reset_value_is_wrong() -> None:
    # The clock relies on PWR_CR.VOS resetting to scale 2 (why 96 MHz needs scale 1 set); ST's
    # SVD says 0 there. The manual wins; this test names the disagreement and would flag the
    # exception once a corrected SVD agrees with the manual.
    root = ET.parse(svd_path()).getroot()
    ((peripheral, register), (manual, reference)) = next(iter(regs_svd.MANUAL_WINS_RESET.items()))
    node = next(p for p in root.iter("peripheral") if p.findtext("name") == peripheral)
    reg = next(r for r in node.iter("register") if r.findtext("name") == register)
    svd_reset = int(reg.findtext("resetValue", "0"), 0)
    assert svd_reset != manual, f"the SVD now agrees ({reference}): drop the exception"
    clock = regs_svd.facts()["stm32f411"]["clock"]  # type: ignore[index]
    scale = clock["vos_reset_scale"]["value"]
    vos = regs_svd.svd_device().peripherals["PWR"].registers["CR"].fields["VOS"]
    assert (manual & vos.mask) >> vos.offset == clock["vos_code_by_scale"]["value"][str(scale)]


def test_vector_table_holds_every_interrupt_of_the_svd() -> None:
    startup = (PORT / "startup.c").read_text(encoding="utf-8")
    m = re.search(r"#define IRQ_COUNT (\d+)u", startup)
    assert m, "startup.c defines IRQ_COUNT"
    assert int(m.group(1)) > max(regs_svd.svd_device().interrupts.values())


# Peripheral, system and core address ranges: an address written in a driver bypasses the check.
ADDRESS = re.compile(r"\b0x(4[0-9A-F]{7}|5[0-9A-F]{7}|E00[0-9A-F]{5}|1FFF[0-9A-F]{4})u?\b", re.I)


def test_drivers_take_every_register_address_from_the_checked_headers() -> None:
    found = []
    for path in sorted(PORT.glob("*.c")):
        text = regs_svd.strip_comments(path.read_text(encoding="utf-8"))
        found += [f"{path.name}: {m.group(0)}" for m in ADDRESS.finditer(text)]
    assert found == [], "name these in regs.h, where tests/firmware/test_regs_svd.py checks them"
