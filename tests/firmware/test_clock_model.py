"""clock_init() run against a register-level model of the chip's RCC, PWR and flash interface.

tests/firmware/clock/clock_model.c compiles the port's real clock.c natively, maps memory at the
peripherals' bus addresses and single-steps clock_init under ptrace, answering every register
write as the chip would and holding each switch to the PLL to the limits of
hardware/datasheet_facts.toml ([stm32f411.clock]). QEMU models no RCC or PWR, so this is where
the PLL path runs at all before a board does.
"""

from __future__ import annotations

import re
import shutil
import subprocess
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest

from .regs_svd import PORT, REPO, facts

pytestmark = [pytest.mark.firmware, pytest.mark.subprocess]  # compiles and runs the model

MODEL_C = REPO / "tests" / "firmware" / "clock" / "clock_model.c"
RUN_TIMEOUT_S = 120  # a clock_init that never returns is reported by the model itself first
LIMITS: dict[str, Any] = facts()["stm32f411"]["clock"]  # type: ignore[index]


def limit_args() -> list[str]:
    hclk = LIMITS["hclk_max_mhz_by_scale"]["value"]
    return [
        ",".join(str(hclk[str(s)]) for s in (1, 2, 3)),
        ",".join(str(w) for w in LIMITS["flash_ws_hclk_max_mhz"]["value"]),
        str(LIMITS["apb1_max_mhz"]["value"]),
        str(LIMITS["apb2_max_mhz"]["value"]),
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
    state: dict[str, int]
    violations: list[str]
    text: str


def run(binary: Path, fault: str = "none") -> Run:
    done = subprocess.run(
        [str(binary), fault, *limit_args()], capture_output=True, text=True, timeout=RUN_TIMEOUT_S
    )
    assert done.returncode in (0, 1), f"the model could not run clock_init: {done.stderr}"
    result = re.search(r"^result (.*)$", done.stdout, re.M)
    state = re.search(r"^state (.*)$", done.stdout, re.M)
    assert result and state, done.stdout
    return Run(
        done.returncode,
        [int(v) for v in result.group(1).split()],
        {k: int(v) for k, v in (kv.split("=") for kv in state.group(1).split())},
        re.findall(r"^violation: (.*)$", done.stdout, re.M),
        done.stdout,
    )


@pytest.fixture(scope="module")
def model(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return build(PORT / "clock.c", tmp_path_factory.mktemp("clock") / "clock_model")


def test_clock_init_reaches_96_mhz_within_every_limit(model: Path) -> None:
    r = run(model)
    assert r.violations == [], r.text
    assert r.result == [96_000_000, 48_000_000, 96_000_000, 96_000_000, 1]
    codes = LIMITS["vos_code_by_scale"]["value"]
    assert r.state["sws"] == LIMITS["sw_code_pll"]["value"]
    assert r.state["vos"] == codes["1"] and r.state["latency"] == 3


@pytest.mark.parametrize("fault", ["no-hse", "no-pll", "no-vosrdy"])
def test_a_missing_ready_flag_leaves_the_core_on_hsi(model: Path, fault: str) -> None:
    r = run(model, fault)
    assert r.violations == [], r.text
    assert r.result == [16_000_000] * 4 + [0], "clock_init must report the HSI clocks it left"
    assert (r.state["sws"], r.state["pllon"], r.state["hseon"]) == (0, 0, 0), r.text


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
        "        fall_back();\n        return;\n    }\n",
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
    r = run(build(broken, tmp_path / "clock_model"))
    assert r.code == 1 and any(complaint in v for v in r.violations), r.text
