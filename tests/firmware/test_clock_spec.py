"""The Black Pill's clock tree against the chip's limits in hardware/datasheet_facts.toml.

firmware/ports/stm32f411/clock.c names its PLL factors, bus dividers, regulator scale and
flash wait states as macros; these tests evaluate them (with the board's crystal from
generated/board.h and the register values from regs.h, themselves checked against ST's SVD by
test_regs_svd.py) and hold them to [stm32f411.clock]: the core frequency within the selected
voltage scale, enough flash wait states, the PLL inside its ranges with 48 MHz for USB, and
the register sequence the reference manual asks for, and the PLL from HSI (the dead crystal's
fallback) inside the same ranges at the same core clock. QEMU models no RCC, so the image's boot
there (test_stm32.py) only shows the raw HSI fallback still runs.
"""

from __future__ import annotations

import re
from typing import Any

import pytest

from .regs_svd import PORT, evaluate, facts, parse_macros

CLOCK_C = (PORT / "clock.c").read_text(encoding="utf-8")
MACROS = {
    **parse_macros((PORT / "generated" / "board.h").read_text(encoding="utf-8"), "board.h"),
    **parse_macros((PORT / "regs.h").read_text(encoding="utf-8"), "regs.h"),
    **parse_macros(CLOCK_C, "clock.c"),
}
LIMITS: dict[str, Any] = facts()["stm32f411"]["clock"]  # type: ignore[index]


def const(name: str) -> int:
    assert name in MACROS, f"clock.c (or regs.h) must define {name}"
    value = evaluate(MACROS[name].body, MACROS)
    assert isinstance(value, int), name
    return value


def limit(key: str) -> Any:
    return LIMITS[key]["value"]


def sysclk_hz() -> int:
    return const("BOARD_HSE_HZ") // const("PLL_M") * const("PLL_N") // const("PLL_P")


def selected_scale() -> int:
    code = (const("CLOCK_VOS") & const("PWR_CR_VOS_MASK")) >> 14
    by_code = {c: int(scale) for scale, c in limit("vos_code_by_scale").items()}
    assert code in by_code, f"VOS code {code:#b} selects no scale"
    return by_code[code]


def test_core_clock_is_within_the_selected_voltage_scale() -> None:
    scale = selected_scale()
    hclk_max = limit("hclk_max_mhz_by_scale")[str(scale)] * 1_000_000
    assert sysclk_hz() <= hclk_max, f"{sysclk_hz()} Hz above scale {scale}'s {hclk_max} Hz"


def test_scale_1_is_selected_because_the_reset_scale_is_too_slow() -> None:
    # The defect of issue 23 item 1: 96 MHz at the reset scale (2, <= 84 MHz) is out of spec.
    reset = limit("vos_reset_scale")
    if sysclk_hz() > limit("hclk_max_mhz_by_scale")[str(reset)] * 1_000_000:
        assert selected_scale() != reset
        assert re.search(r"PWR->CR = \(PWR->CR & ~PWR_CR_VOS_MASK\) \| CLOCK_VOS;", CLOCK_C)


def test_flash_wait_states_match_the_frequency() -> None:
    assert limit("flash_ws_vdd_min") <= facts()["blackpill"]["vdd"]["value"]  # type: ignore[index]
    needed = next(
        ws
        for ws, top in enumerate(limit("flash_ws_hclk_max_mhz"))
        if sysclk_hz() <= top * 1_000_000
    )
    latency = const("CLOCK_FLASH_LATENCY") & const("FLASH_ACR_LATENCY_MASK")
    assert latency >= needed, f"{sysclk_hz()} Hz needs {needed} wait states, clock.c sets {latency}"
    assert latency == needed, "more wait states than needed cost speed for nothing"


def test_pll_factors_and_frequencies_are_in_range() -> None:
    m, n, p, q = (const(f"PLL_{x}") for x in "MNPQ")
    lo, hi = limit("pll_m")
    assert lo <= m <= hi
    lo, hi = limit("pll_n")
    assert lo <= n <= hi
    assert p in limit("pll_p")
    lo, hi = limit("pll_q")
    assert lo <= q <= hi
    vco_in = const("BOARD_HSE_HZ") / m
    lo, hi = limit("pll_vco_in_mhz")
    assert lo * 1e6 <= vco_in <= hi * 1e6
    lo, hi = limit("pll_vco_out_mhz")
    assert lo * 1e6 <= vco_in * n <= hi * 1e6
    assert vco_in * n / q == limit("usb_clock_hz"), "USB OTG FS needs exactly 48 MHz"


def test_the_pll_from_hsi_gives_the_crystal_paths_clocks_within_range() -> None:
    # The dead crystal's fallback shares N, P, Q, the buses and wait states, so its M alone
    # must bring HSI to the same VCO input (and the UART keeps its divider).
    hsi, m = const("HSI_HZ"), const("HSI_PLL_M")
    lo, hi = limit("pll_m")
    assert lo <= m <= hi
    assert hsi % m == 0 and hsi // m == const("BOARD_HSE_HZ") // const("PLL_M")
    lo, hi = limit("pll_vco_in_mhz")
    assert lo * 1e6 <= hsi / m <= hi * 1e6
    assert hsi // m * const("PLL_N") // const("PLL_P") == sysclk_hz()
    lo, hi = limit("pll_q")
    assert lo <= const("PLL_Q") <= hi, "PLLQ must be a legal divider even with USB off"
    body = pll_body()
    assert "RCC->PLLCFGR = pllcfgr;" in body
    assert "RCC_PLLCFGR_PLLSRC_HSE" not in MACROS["PLLCFGR_FROM_HSI"].body


@pytest.mark.parametrize(
    ("divider", "key", "cfgr"),
    [
        ("APB1_DIV", "apb1_max_mhz", "RCC_CFGR_PPRE1_DIV"),
        ("APB2_DIV", "apb2_max_mhz", "RCC_CFGR_PPRE2_DIV"),
    ],
)
def test_bus_clocks_are_within_their_limits(divider: str, key: str, cfgr: str) -> None:
    div = const(divider)
    assert sysclk_hz() / div <= limit(key) * 1_000_000
    if div > 1:
        assert f"{cfgr}{div}" in CLOCK_C, f"clock.c divides by {div} in RCC_CFGR"


def field_code(macro: str, shift: int) -> int:
    return const(macro) >> shift


def test_register_codes_mean_what_clock_c_intends() -> None:
    # Field positions are checked against the SVD (test_regs_svd.py); what each code means is
    # not in the SVD, so it is checked here against the manual's tables.
    assert (
        field_code(f"RCC_CFGR_PPRE1_DIV{const('APB1_DIV')}", 10)
        == (limit("ppre_code_by_divider")[str(const("APB1_DIV"))])
    )
    assert const("RCC_CFGR_SW_PLL") == limit("sw_code_pll")
    assert field_code("RCC_CFGR_SWS_PLL", 2) == limit("sw_code_pll")
    assert const("FLASH_ACR_LATENCY_3WS") == 3, "LATENCY is the number of wait states"
    p = const("PLL_P")
    assert "((PLL_P / 2u - 1u) << RCC_PLLCFGR_PLLP_SHIFT)" in CLOCK_C
    assert limit("pll_p").index(p) == p // 2 - 1, "PLLP is encoded as P / 2 - 1"


def function_body(signature: str) -> str:
    m = re.search(re.escape(signature) + r" \{(.*?)\n\}", CLOCK_C, re.S)
    assert m, f"clock.c defines {signature}"
    return m.group(1)


def pll_body() -> str:
    """The steps both PLL paths (crystal, HSI) take to switch the core to the PLL."""
    return function_body("static int switch_to_pll(uint32_t pllcfgr)")


def test_regulator_scale_sequence_follows_the_manual() -> None:
    body = pll_body()
    steps = [
        ("enable the PWR clock", "RCC->APB1ENR |= RCC_APB1ENR_PWR;"),
        ("let the enable take effect", "(void)RCC->APB1ENR;"),
        ("select the scale", "PWR->CR = (PWR->CR & ~PWR_CR_VOS_MASK) | CLOCK_VOS;"),
        ("start the PLL", "RCC->CR |= RCC_CR_PLLON;"),
        ("wait for the PLL", "wait_set(&RCC->CR, RCC_CR_PLLRDY, RCC_CR_PLLRDY)"),
        ("wait for the regulator", "wait_set(&PWR->CSR, PWR_CSR_VOSRDY, PWR_CSR_VOSRDY)"),
        ("set the wait states", "FLASH_ACR = CLOCK_FLASH_LATENCY"),
        ("switch to the PLL", "RCC_CFGR_SW_PLL"),
    ]
    assert limit("vos_written_with_pll_off") and limit("vosrdy_after_pll_on")
    at = []
    for what, text in steps:
        assert body.count(text) == 1, f"clock_init must {what} once: {text}"
        at.append(body.index(text))
    assert at == sorted(at), "steps out of order: " + ", ".join(
        w for (w, _), _ in sorted(zip(steps, at, strict=True), key=lambda s: s[1])
    )


def test_regulator_timeout_stays_on_the_slow_clock() -> None:
    m = re.search(
        r"if \(!wait_set\(&PWR->CSR, PWR_CSR_VOSRDY, PWR_CSR_VOSRDY\)\) \{([^}]*)\}", pll_body()
    )
    assert m, "the VOSRDY wait is bounded and checked"
    assert "return 0;" in m.group(1), "a regulator that never gets ready fails the switch"
    # ... and clock_init falls back to HSI whenever a switch fails (test_clock_model.py runs it)
    body = function_body("void clock_init(clocks_t *out)")
    assert body.count("switch_to_pll(") == 2 and body.count("fall_back()") == 2
