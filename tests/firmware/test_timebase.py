"""The device clock is TIM5's 32-bit counter at 1 MHz (ports/stm32f411/timebase.c), so time
keeps running through a flash erase, which stalls the core (no instruction, no interrupt).

Where this can run: QEMU's STM32 has no flash controller, so an erase never stalls there, and
its TIM5 counts virtual time at a fixed 1 GHz, not the board's clock tree. So the port's real
timebase.c runs natively against a model of its registers (tests/firmware/clock/
timebase_model.c, as test_clock_model.py does for the clock): it must set TIM5 to 1 MHz from
either clock the board can run on, free-running over 32 bits, and read a stall's full length;
and the images must take their time from it, with nothing left of the SysTick clock, which
counted milliseconds in an interrupt that cannot run during a stall.
"""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest

from .regs_svd import PORT, REPO

pytestmark = [pytest.mark.firmware, pytest.mark.subprocess]

MODEL_C = REPO / "tests" / "firmware" / "clock" / "timebase_model.c"
TIM5EN = 1 << 3


@pytest.fixture(scope="module")
def model(tmp_path_factory: pytest.TempPathFactory) -> Path:
    gcc = shutil.which("gcc")
    assert gcc, "gcc is needed to build the timebase model (apt install gcc)"
    out = tmp_path_factory.mktemp("timebase") / "timebase_model"
    cmd = [gcc, "-std=c11", "-O0", "-Wall", "-Wextra", "-Werror", "-Wno-int-to-pointer-cast"]
    cmd += [f"-I{PORT}", str(PORT / "timebase.c"), str(MODEL_C), "-o", str(out)]
    done = subprocess.run(cmd, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    return out


def run(model: Path, tim_hz: int) -> dict[str, int]:
    done = subprocess.run([str(model), str(tim_hz)], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    words = done.stdout.split()
    return {k: int(v) for k, v in zip(words[::2], words[1::2], strict=True)}


@pytest.mark.parametrize("tim_hz", [96_000_000, 16_000_000])  # PLL, HSI fallback
def test_tim5_counts_microseconds_over_32_bits(model: Path, tim_hz: int) -> None:
    regs = run(model, tim_hz)
    assert regs["apb1enr"] & TIM5EN
    assert tim_hz // (regs["psc"] + 1) == 1_000_000
    assert regs["arr"] == 0xFFFF_FFFF  # wraps at 2^32 us, like the protocol's timestamps
    assert regs["egr"] & 1 and regs["cr1"] & 1  # prescaler loaded now (UG), counting (CEN)
    assert regs["cnt"] == 0


def test_a_stall_is_read_in_full(model: Path) -> None:
    assert run(model, 96_000_000)["across_stall"] == 7_100_000


def test_the_images_take_their_time_from_tim5(image: Path, usb_image: Path) -> None:
    for elf in (image, usb_image):
        syms = subprocess.run(
            ["arm-none-eabi-nm", "--defined-only", str(elf)],
            capture_output=True,
            text=True,
            check=True,
            timeout=60,
        ).stdout
        names = {line.split()[-1] for line in syms.splitlines()}
        assert "timebase_now_us" in names or "hal_clock" in names
        assert not {"SysTick_Handler", "systick_now_us", "systick_init"} & names
    main = (PORT / "main.c").read_text(encoding="utf-8")
    assert "return timebase_now_us();" in main.split("static uint32_t hal_clock")[1][:120]
