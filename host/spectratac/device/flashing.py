"""Put a firmware image on a Black Pill: over USB DFU with ST's ROM bootloader, entered by
command when the board already runs our firmware (ENTER_BOOTLOADER, protocol 1.4) instead of
BOOT0 and NRST; and, once at provisioning, the brown-out reset at level 3 (option bytes, over
an ST-Link with OpenOCD), without which the firmware refuses model uploads.

The tools are run as programs (`dfu-util`, `openocd`), named so that tests and unusual
installs can give others; each step says what it runs, and every wait is bounded.
"""

from __future__ import annotations

import re
import shutil
import subprocess
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from spectratac.device.errors import DeviceError

#: ST's ROM bootloader on USB (DFU mode), as `dfu-util -l` lists it
DFU_ID = "0483:df11"
#: where the program starts (flash sector 0)
FLASH_ADDRESS = 0x0800_0000
#: FLASH_OPTCR's user byte with BOR_LEV = 00 (level 3, 2.7 V) and the factory values of the
#: other bits (nRST_STDBY, nRST_STOP, software watchdog): OpenOCD's stm32f2x options_write
#: takes it; the factory byte is 0xEC (BOR off)
OPTCR_USER_BOR3 = 0xE0
TOOL_TIMEOUT_S = 120.0  # one dfu-util download or OpenOCD session

Runner = Callable[[Sequence[str], float], "subprocess.CompletedProcess[str]"]


class FlashError(DeviceError):
    """A flashing step failed; the message names the tool, its output and what to try."""


def run_tool(argv: Sequence[str], timeout: float) -> subprocess.CompletedProcess[str]:
    return subprocess.run(list(argv), capture_output=True, text=True, timeout=timeout)


@dataclass
class Flasher:
    """The steps of `spectratac flash`, each recorded in `log` as the command it ran."""

    dfu_util: str = "dfu-util"
    openocd: str = "openocd"
    run: Runner = run_tool
    log: list[str] = field(default_factory=list)

    def _tool(self, name: str) -> str:
        found = shutil.which(name)
        if found is None:
            raise FlashError(
                f"{name} not found: install it (apt install {Path(name).name}; the Black Pill "
                f"needs dfu-util for USB DFU, openocd with an ST-Link for the option bytes), or "
                f"name it with --{Path(name).name}"
            )
        return found

    def _call(self, argv: list[str], what: str) -> str:
        self.log.append(" ".join(argv))
        try:
            done = self.run(argv, TOOL_TIMEOUT_S)
        except subprocess.TimeoutExpired as exc:
            raise FlashError(f"{what}: {argv[0]} did not finish in {TOOL_TIMEOUT_S:g} s") from exc
        out = (done.stdout or "") + (done.stderr or "")
        if done.returncode != 0:
            raise FlashError(f"{what} failed ({argv[0]} exit {done.returncode}): {out[-600:]}")
        return out

    def wait_for_dfu(self, timeout: float, poll: float = 0.25) -> None:
        """Until ST's bootloader shows up on USB (`dfu-util -l`), at most `timeout` s."""
        tool = self._tool(self.dfu_util)
        deadline = time.monotonic() + timeout
        while True:
            self.log.append(f"{tool} -l")
            listing = self.run([tool, "-l"], TOOL_TIMEOUT_S)
            if DFU_ID in (listing.stdout or "") + (listing.stderr or ""):
                return
            if time.monotonic() >= deadline:
                raise FlashError(
                    f"no DFU device ({DFU_ID}) appeared within {timeout:g} s: check the USB "
                    "cable (a charge-only cable carries no data), or hold BOOT0, tap NRST and "
                    "run again without --device"
                )
            time.sleep(poll)

    def download(self, image: Path) -> None:
        """Write `image` at the start of flash and leave DFU (the board starts it)."""
        tool = self._tool(self.dfu_util)
        self._call(
            [tool, "-d", DFU_ID, "-a", "0", "-s", f"0x{FLASH_ADDRESS:08X}:leave", "-D", str(image)],
            "the DFU download",
        )

    def set_bor_level_3(self) -> None:
        """Program the option bytes' brown-out level 3 over an ST-Link (OpenOCD's stm32f2x
        driver, which covers the F4), and read them back."""
        tool = self._tool(self.openocd)
        commands = [
            "init",
            "reset halt",
            f"stm32f2x options_write 0 0x{OPTCR_USER_BOR3:02X}",
            "stm32f2x options_read 0",
            "reset run",
            "shutdown",
        ]
        argv = [tool, "-f", "interface/stlink.cfg", "-f", "target/stm32f4x.cfg"]
        for c in commands:
            argv += ["-c", c]
        out = self._call(argv, "setting the brown-out level (option bytes)")
        read = re.search(r"user_options 0x([0-9a-fA-F]+)", out)
        if read is None or int(read.group(1), 16) & 0xFF != OPTCR_USER_BOR3:
            raise FlashError(
                "OpenOCD ran but the option bytes did not read back with brown-out level 3 "
                f"(user_options 0x{OPTCR_USER_BOR3:X}): {out[-600:]}"
            )
