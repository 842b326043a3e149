"""What the UART image leaves in the registers once it runs, read under QEMU through its
monitor (`x`, which reads through the CPU, NVIC and peripherals included): the host link's
interrupt at its own low priority (every priority was 0 before), the device clock on TIM5 at
1 MHz from the HSI fallback's 16 MHz (QEMU has no PLL) over the full 32 bits, and SysTick off
(the clock needs no interrupt). QEMU does not model DBGMCU (its freeze bit reads 0 whatever is
written), so the debugger freeze of the watchdog is checked only against ST's SVD
(test_regs_svd.py) and on a board; nor RCC (its enables read 0), so TIM5's clock enable is
checked by the register model (test_timebase.py).
"""

from __future__ import annotations

import contextlib
import re
import socket
import subprocess
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from .conftest import need

pytestmark = [pytest.mark.firmware, pytest.mark.subprocess, pytest.mark.qemu]

USART1_IRQ = 37
NVIC_IPR = 0xE000_E400
TIM5 = 0x4000_0C00
SYST_CSR = 0xE000_E010
BOOT_TIMEOUT_S = 20.0


class Monitor:
    """QEMU's human monitor on a Unix socket: `x /1wx ADDRESS` reads a word."""

    def __init__(self, path: Path) -> None:
        deadline = time.monotonic() + BOOT_TIMEOUT_S
        while True:
            try:
                self.sock = socket.socket(socket.AF_UNIX)
                self.sock.connect(str(path))
                break
            except OSError:
                self.sock.close()
                if time.monotonic() > deadline:
                    raise
                time.sleep(0.05)
        self.sock.settimeout(0.2)

    def word(self, address: int) -> int:
        self.sock.sendall(f"x /1wx {address:#x}\n".encode())
        text, deadline = "", time.monotonic() + BOOT_TIMEOUT_S
        pattern = re.compile(rf"{address:08x}: 0x([0-9a-f]{{8}})")
        while time.monotonic() < deadline:
            with contextlib.suppress(TimeoutError):
                text += self.sock.recv(4096).decode(errors="replace")
            found = pattern.search(text)
            if found:
                return int(found.group(1), 16)
        raise AssertionError(f"the monitor did not answer for {address:#010x}: {text[-300:]}")


@pytest.fixture
def monitor(image: Path, tmp_path: Path) -> Iterator[Monitor]:
    need("qemu-system-arm", "qemu-system-arm")
    path = tmp_path / "monitor.sock"
    argv = ["qemu-system-arm", "-M", "netduinoplus2", "-nographic", "-kernel", str(image)]
    argv += ["-icount", "shift=0,align=off,sleep=off", "-serial", "null"]
    argv += ["-monitor", f"unix:{path},server=on,wait=off"]
    qemu = subprocess.Popen(
        argv,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    try:
        mon = Monitor(path)
        deadline = time.monotonic() + BOOT_TIMEOUT_S
        while mon.word(NVIC_IPR + 4 * (USART1_IRQ // 4)) == 0:  # until the link is up
            assert time.monotonic() < deadline, "the image never enabled its host link"
            time.sleep(0.05)
        yield mon
        mon.sock.close()
    finally:
        qemu.kill()
        qemu.wait(timeout=30)


def test_link_interrupt_priority_clock_and_no_systick(monitor: Monitor) -> None:
    ipr = monitor.word(NVIC_IPR + 4 * (USART1_IRQ // 4))
    assert ipr >> (8 * (USART1_IRQ % 4)) & 0xFF == 0xC0
    assert monitor.word(TIM5 + 0x28) == 16_000_000 // 1_000_000 - 1  # PSC: 1 MHz from HSI
    assert monitor.word(TIM5 + 0x2C) == 0xFFFF_FFFF  # ARR: the full 32 bits
    assert monitor.word(TIM5) & 1  # CR1.CEN
    assert monitor.word(SYST_CSR) & 1 == 0  # SysTick not running
