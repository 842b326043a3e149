"""Firmware benchmark: frame encode cost on the native build beside a memcpy of the same bytes,
the superloop pass that turns an integration's end into a frame handed to the UART beside an
idle pass, and the flash and static RAM of both STM32F411 images (USB CDC-ACM host link, env
blackpill; USART1 host link, env blackpill_uart) against the budget.

    python -m tools.bench.firmware [--json] [--no-image]
"""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

from tools.bench import benchlib

REPO = Path(__file__).resolve().parents[2]
FLASH_BUDGET = 32 * 1024
# 8 KiB for acquisition and the link plus the on-device decoder's session state (~14.5 KiB)
# since protocol 1.1; tests/firmware/test_stm32.py holds the image to the same budgets
RAM_BUDGET = 24 * 1024
# PlatformIO env -> the host link it builds (platformio.ini).
IMAGES = {"blackpill": "USB CDC-ACM", "blackpill_uart": "USART1"}


def native_figures() -> list[benchlib.Figure]:
    from tools.firmware import build
    exe = build.build("bench")
    out = subprocess.run([str(exe)], capture_output=True, text=True, check=True, timeout=600)
    v = {k: float(x) for k, x in (line.split() for line in out.stdout.splitlines())}
    frame = int(v["frame_bytes"])
    return [
        benchlib.Figure(
            f"SAMPLE frame encode ({frame} B)", v["encode_ns"], "ns/frame",
            f"memcpy of {frame} B", v["memcpy_ns"], v["encode_ns"] / v["memcpy_ns"],
            {"what": "pack + CRC-32C + COBS + delimiter, native -O2"},
        ),
        benchlib.Figure(
            "integration end -> frame to UART", v["pass_us"], "us",
            "idle superloop pass", v["idle_pass_us"], v["pass_us"] / v["idle_pass_us"],
            {"passes": 1, "what": "one pass: poll 3 sensors, read 15 channels, frame, hand over"},
        ),
    ]


def image_figures() -> list[benchlib.Figure]:
    from tools.platformio import pio

    figures: list[benchlib.Figure] = []
    for env, link in IMAGES.items():
        result = pio.run(["run", "-e", env], timeout=600)
        if result.returncode != 0:
            raise SystemExit(result.stdout[-3000:] + result.stderr[-3000:])
        elf = REPO / "build" / "pio" / env / "firmware.elf"
        out = subprocess.run(["arm-none-eabi-size", "-A", "-d", str(elf)], capture_output=True,
                             text=True, check=True, timeout=60).stdout
        s = {m[1]: int(m[2]) for m in re.finditer(r"^(\.\S+)\s+(\d+)\s+\d+", out, flags=re.M)}
        flash = s[".isr_vector"] + s[".text"] + s.get(".ARM.exidx", 0) + s.get(".data", 0)
        ram = s.get(".data", 0) + s[".bss"]
        figures += [
            benchlib.Figure(f"STM32F411 image flash ({link})", flash, "B", "budget",
                            FLASH_BUDGET, flash / FLASH_BUDGET, {"env": env, "sections": s}),
            benchlib.Figure(f"STM32F411 static RAM ({link})", ram, "B", "budget", RAM_BUDGET,
                            ram / RAM_BUDGET,
                            {"env": env, "data": s.get(".data", 0), "bss": s[".bss"]}),
        ]
    return figures


def main() -> None:
    p = benchlib.parser(__doc__.splitlines()[0])
    p.add_argument("--no-image", action="store_true", help="skip the STM32 image figures")
    args = p.parse_args()
    figures = native_figures()
    if not args.no_image and shutil.which("arm-none-eabi-gcc"):
        figures += image_figures()
    benchlib.report(figures, args.json)


if __name__ == "__main__":
    main()
