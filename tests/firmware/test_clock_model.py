"""clock_init() run against a register-level model of the chip's RCC, PWR and flash interface.

tests/firmware/clock/clock_model.c compiles the port's real clock.c natively, maps memory at the
peripherals' bus addresses and single-steps clock_init under ptrace, answering every register
write as the chip would and holding each switch to the PLL to the limits of
hardware/datasheet_facts.toml ([stm32f411.clock]). QEMU models no RCC or PWR, so this is where
the PLL paths (from the crystal, and from HSI when the crystal is dead) run at all before a
board does.
"""

from __future__ import annotations

import re
import shutil
import subprocess
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from .regs_svd import PORT, REPO, facts

pytestmark = [pytest.mark.firmware, pytest.mark.subprocess]  # compiles and runs the model

MODEL_C = REPO / "tests" / "firmware" / "clock" / "clock_model.c"
RUN_TIMEOUT_S = 120  # a clock_init that never returns is reported by the model itself first
LIMITS: dict[str, Any] = facts()["stm32f411"]["clock"]  # type: ignore[index]


BAUD = 921_600  # BOARD_BAUD, the UART image's link
#: what clock.h's CLOCK_SRC_* codes mean
HSI, HSI_PLL, HSE_PLL = 0, 1, 2
#: a UART receiver samples mid-bit: a few per cent of mismatch over a 10-bit frame, shared
#: between both ends, is its whole margin; the crystal's path sits at +0.16 %
UART_ERROR_MAX = 0.005


def limit_args() -> list[str]:
    hclk = LIMITS["hclk_max_mhz_by_scale"]["value"]
    pll = [LIMITS[k]["value"] for k in ("pll_vco_in_mhz", "pll_vco_out_mhz", "pll_q")]
    return [
        ",".join(str(hclk[str(s)]) for s in (1, 2, 3)),
        ",".join(str(w) for w in LIMITS["flash_ws_hclk_max_mhz"]["value"]),
        str(LIMITS["apb1_max_mhz"]["value"]),
        str(LIMITS["apb2_max_mhz"]["value"]),
        ",".join(str(v) for pair in pll for v in pair),
    ]


def build(clock_c: Path, out: Path) -> Path:
    gcc = shutil.which("gcc")
    assert gcc, "gcc is needed to build the clock model (apt install gcc)"
    cmd = [gcc, "-std=c11", "-O0", "-Wall", "-Wextra", "-Werror", "-Wno-int-to-pointer-cast"]
    cmd += [f"-I{PORT}", "-DREADY_SPINS=2000u", str(clock_c), str(MODEL_C), "-o", str(out)]
    done = subprocess.run(cmd, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    return out


@dataclass(frozen=True)
class Run:
    code: int
    result: list[int]
    note: str
    state: dict[str, int]
    violations: list[str]
    text: str


def run(binary: Path, fault: str = "none") -> Run:
    done = subprocess.run(
        [str(binary), fault, *limit_args()], capture_output=True, text=True, timeout=RUN_TIMEOUT_S
    )
    assert done.returncode in (0, 1), f"the model could not run clock_init: {done.stderr}"
    result = re.search(r"^result (.*)$", done.stdout, re.M)
    note = re.search(r"^note (.*)$", done.stdout, re.M)
    state = re.search(r"^state (.*)$", done.stdout, re.M)
    assert result and note and state, done.stdout
    return Run(
        done.returncode,
        [int(v) for v in result.group(1).split()],
        note.group(1),
        {k: int(v) for k, v in (kv.split("=") for kv in state.group(1).split())},
        re.findall(r"^violation: (.*)$", done.stdout, re.M),
        done.stdout,
    )


@pytest.fixture(scope="module")
def model(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return build(PORT / "clock.c", tmp_path_factory.mktemp("clock") / "clock_model")


def uart_error(apb2_hz: int, brr: int, baud: int = BAUD) -> float:
    """Relative error of the rate USART1 runs at (16x oversampling: apb2_hz / BRR)."""
    return apb2_hz / brr / baud - 1


def test_clock_init_reaches_96_mhz_within_every_limit(model: Path) -> None:
    r = run(model)
    assert r.violations == [], r.text
    assert r.result[:6] == [96_000_000, 48_000_000, 96_000_000, 96_000_000, HSE_PLL, 1]
    codes = LIMITS["vos_code_by_scale"]["value"]
    assert r.state["sws"] == LIMITS["sw_code_pll"]["value"]
    assert r.state["vos"] == codes["1"] and r.state["latency"] == 3
    assert r.state["pllsrc"] == 1 and r.state["hseon"] == 1
    assert abs(uart_error(r.result[2], r.result[6])) < UART_ERROR_MAX
    assert r.note == "-", "the crystal's path is a normal start: no boot LOG line"


def test_a_dead_crystal_runs_the_pll_from_hsi_at_96_mhz_with_usb_off(model: Path) -> None:
    # Issue 34 (Low): on raw 16 MHz HSI no divider gives 921600 baud (16 MHz / 17: +2.1 %).
    r = run(model, "no-hse")
    assert r.violations == [], r.text
    assert r.result[:4] == [96_000_000, 48_000_000, 96_000_000, 96_000_000], r.text
    assert r.result[4] == HSI_PLL, "clock_init must say it runs the PLL from HSI"
    assert r.result[5] == 0, "USB must stay off: HSI is far outside USB's +-0.25 %"
    assert r.state["sws"] == LIMITS["sw_code_pll"]["value"]
    assert (r.state["pllsrc"], r.state["pllm"], r.state["hseon"]) == (0, 16, 0), r.text
    lo, hi = LIMITS["pll_q"]["value"]
    assert lo <= r.state["pllq"] <= hi
    codes = LIMITS["vos_code_by_scale"]["value"]
    assert r.state["vos"] == codes["1"] and r.state["latency"] == 3
    error = uart_error(r.result[2], r.result[6])
    assert abs(error) < UART_ERROR_MAX, f"UART {error:+.2%} off 921600 baud"
    assert r.note == f"clock HSI+PLL 96MHz (crystal failed): no USB, UART {error * 100:+.2f}%"


@pytest.mark.parametrize("fault", ["no-pll", "no-vosrdy", "no-hse,no-pll", "no-hse,no-vosrdy"])
def test_a_pll_that_never_starts_leaves_the_core_on_raw_hsi(model: Path, fault: str) -> None:
    # Both PLL attempts (from the crystal when it runs, then from HSI) end at their bound.
    r = run(model, fault)
    assert r.violations == [], r.text
    assert r.result[:6] == [16_000_000] * 4 + [HSI, 0], "clock_init must report the HSI it left"
    assert (r.state["sws"], r.state["pllon"], r.state["hseon"]) == (0, 0, 0), r.text
    assert r.state["latency"] == 0, "no wait states left on at 16 MHz"
    error = uart_error(r.result[2], r.result[6])
    assert error == pytest.approx(16e6 / 17 / BAUD - 1)
    assert r.note == f"clock HSI 16MHz (PLL failed): no USB, UART {error * 100:+.2f}%"


@st.composite
def uart_clocks(draw: st.DrawFn) -> tuple[int, int]:
    """An APB2 clock and a baud rate USART1 can divide it to (BRR >= 16, up to 4 Mbaud)."""
    apb2 = draw(st.integers(1_000_000, 100_000_000))
    return apb2, draw(st.integers(1200, min(apb2 // 16, 4_000_000)))


@settings(max_examples=30, deadline=None)  # deadline: one subprocess per example
@given(st.lists(uart_clocks(), min_size=1, max_size=40))
def test_the_boot_log_states_the_uarts_error_to_a_hundredth_of_a_percent(
    model: Path, cases: list[tuple[int, int]]
) -> None:
    lines = "".join(f"{HSI_PLL} {apb2} {baud}\n" for apb2, baud in cases)
    done = subprocess.run(
        [str(model), "notes"], input=lines, capture_output=True, text=True, timeout=RUN_TIMEOUT_S
    )
    assert done.returncode == 0, done.stderr
    for (apb2, baud), note in zip(cases, done.stdout.splitlines(), strict=True):
        said = re.fullmatch(
            r"clock HSI\+PLL 96MHz \(crystal failed\): no USB, UART ([+-]\d+\.\d\d)%", note
        )
        assert said, note
        exact = uart_error(apb2, (apb2 + baud // 2) // baud, baud) * 100
        # truncated to a thousandth of a per cent, then rounded to a hundredth
        assert abs(float(said.group(1)) - exact) <= 0.0061, (apb2, baud, note, exact)


MUTATIONS = [
    # (what the code no longer does, text removed or replaced, replacement, the model's complaint)
    (
        "select scale 1 (the issue's defect)",
        "    PWR->CR = (PWR->CR & ~PWR_CR_VOS_MASK) | CLOCK_VOS;\n",
        "",
        "above voltage scale 2's 84 MHz",
    ),
    (
        "enable the PWR clock",
        "    RCC->APB1ENR |= RCC_APB1ENR_PWR;\n",
        "",
        "PWR_CR written while the PWR clock is off",
    ),
    (
        "wait for VOSRDY",
        "    if (!wait_set(&PWR->CSR, PWR_CSR_VOSRDY, PWR_CSR_VOSRDY)) {\n"
        "        return 0;\n    }\n",
        "",
        "switched to the PLL before VOSRDY",
    ),
    (
        "set 3 wait states",
        "#define CLOCK_FLASH_LATENCY FLASH_ACR_LATENCY_3WS",
        "#define CLOCK_FLASH_LATENCY 2u",
        "2 flash wait states at 96.0 MHz",
    ),
]


@pytest.mark.parametrize(
    ("what", "old", "new", "complaint"), MUTATIONS, ids=[m[0] for m in MUTATIONS]
)
def test_the_model_catches_clock_code_that_skips_a_step(
    tmp_path: Path, what: str, old: str, new: str, complaint: str
) -> None:
    source = (PORT / "clock.c").read_text(encoding="utf-8")
    assert source.count(old) == 1, f"clock.c no longer contains the step to remove: {old!r}"
    broken = tmp_path / "clock.c"
    broken.write_text(source.replace(old, new), encoding="utf-8")
    binary = build(broken, tmp_path / "clock_model")
    for fault in ("none", "no-hse"):  # both PLL paths share the steps
        r = run(binary, fault)
        assert r.code == 1 and any(complaint in v for v in r.violations), (fault, r.text)


HSI_MUTATIONS = [
    # (what the HSI path gets wrong, text replaced, replacement, the model's complaint); each
    # wrong value is written after clock.c's compile-time checks, as a slip in the register
    # value would be
    (
        "keep PLLSRC on the dead crystal",
        "#define PLLCFGR_FROM_HSI ((HSI_PLL_M << RCC_PLLCFGR_PLLM_SHIFT) | PLLCFGR_FACTORS)",
        "#define PLLCFGR_FROM_HSI ((HSI_PLL_M << RCC_PLLCFGR_PLLM_SHIFT) | PLLCFGR_FACTORS | "
        "RCC_PLLCFGR_PLLSRC_HSE)",
        None,  # the PLL never locks: raw HSI, which the result shows
    ),
    (
        "divide HSI by the crystal's M",
        "#define PLLCFGR_FROM_HSI (",
        "#undef HSI_PLL_M\n#define HSI_PLL_M 25u\n#define PLLCFGR_FROM_HSI (",
        "VCO input 0.640 / VCO 122.9 MHz outside their ranges",
    ),
    (
        "a PLLQ of 1",
        "    (PLL_Q << RCC_PLLCFGR_PLLQ_SHIFT))\n#define PLLCFGR_FROM_HSE",
        "    (PLL_Q << RCC_PLLCFGR_PLLQ_SHIFT))\n#undef PLL_Q\n#define PLL_Q 1u\n"
        "#define PLLCFGR_FROM_HSE",
        "PLLQ 1 is not a legal divider",
    ),
]


@pytest.mark.parametrize(
    ("what", "old", "new", "complaint"), HSI_MUTATIONS, ids=[m[0] for m in HSI_MUTATIONS]
)
def test_the_model_catches_a_wrong_pll_from_hsi(
    tmp_path: Path, what: str, old: str, new: str, complaint: str | None
) -> None:
    source = (PORT / "clock.c").read_text(encoding="utf-8")
    assert source.count(old) == 1, f"clock.c no longer contains {old!r}"
    broken = tmp_path / "clock.c"
    broken.write_text(source.replace(old, new), encoding="utf-8")
    r = run(build(broken, tmp_path / "clock_model"), "no-hse")
    if complaint is None:
        assert r.violations == [] and r.result[4] == HSI, r.text
    else:
        assert r.code == 1 and any(complaint in v for v in r.violations), r.text
