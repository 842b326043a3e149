"""`spectratac flash [IMAGE]`: put a firmware image on a Black Pill over USB DFU.

spectratac flash --device /dev/ttyACM0            # running our firmware: DFU by command
spectratac flash build/pio/blackpill/firmware.bin  # already in DFU (BOOT0 held, NRST tapped)
spectratac flash --set-bor                         # once per board, over an ST-Link

With --device the board is asked to restart in its ROM bootloader (ENTER_BOOTLOADER, protocol
1.4); without it, it must already be in DFU mode. --set-bor programs the brown-out reset at
level 3 (2.7 V), which the firmware needs before it accepts model uploads
(device/flashing.py).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from spectratac.cli.exit_codes import ExitCode, UsageError
from spectratac.cli.options import DEVICE_URL_HELP

DEFAULT_IMAGE = Path("build/pio/blackpill/firmware.bin")
DFU_WAIT_S = 10.0


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "flash", help="put a firmware image on a Black Pill (USB DFU; brown-out level 3)"
    )
    p.add_argument(
        "image",
        nargs="?",
        type=Path,
        help=f"firmware .bin to write (default {DEFAULT_IMAGE}, what `make firmware` builds); "
        "omit with --set-bor alone",
    )
    p.add_argument(
        "--device",
        metavar="URL",
        help=f"the board, running our firmware: restart it in its ROM bootloader first "
        f"(ENTER_BOOTLOADER) instead of BOOT0 + NRST ({DEVICE_URL_HELP})",
    )
    p.add_argument(
        "--set-bor",
        action="store_true",
        help="program the brown-out reset at level 3 (option bytes, over an ST-Link with "
        "openocd); model uploads need it",
    )
    p.add_argument(
        "--dfu-wait",
        type=float,
        default=DFU_WAIT_S,
        metavar="S",
        help=f"seconds to wait for the bootloader to appear on USB (default {DFU_WAIT_S:g})",
    )
    p.add_argument(
        "--timeout", type=float, default=2.0, metavar="S", help="seconds to wait for the device"
    )
    p.add_argument("--dfu-util", default="dfu-util", help="the dfu-util program to run")
    p.add_argument("--openocd", default="openocd", help="the openocd program to run")
    p.add_argument("--json", action="store_true", help="machine-readable output")
    p.set_defaults(func=_flash)


def _flash(args: argparse.Namespace) -> int:
    from spectratac.device.flashing import Flasher

    image = args.image
    if image is None and not args.set_bor:
        image = DEFAULT_IMAGE
    if image is not None and not image.is_file():
        raise UsageError(f"{image}: no such firmware image (build one with `make firmware`)")
    flasher = Flasher(dfu_util=args.dfu_util, openocd=args.openocd)
    steps: list[str] = []
    if image is not None:
        if args.device:
            _enter_bootloader(args.device, args.timeout)
            steps.append(f"{args.device}: restarted in its ROM bootloader (ENTER_BOOTLOADER)")
            say(steps[-1], args.json)
            flasher.wait_for_dfu(args.dfu_wait)
        flasher.download(image)
        steps.append(f"wrote {image} ({image.stat().st_size} B) over USB DFU")
        say(steps[-1], args.json)
    if args.set_bor:
        flasher.set_bor_level_3()
        steps.append("brown-out reset at level 3 (2.7 V) in the option bytes")
        say(steps[-1], args.json)
    if args.json:
        print(json.dumps({"steps": steps, "commands": flasher.log}))
    return ExitCode.OK


def say(line: str, quiet: bool) -> None:
    if not quiet:
        print(line, flush=True)


def _enter_bootloader(url: str, timeout: float) -> None:
    from spectratac.device import Sensor

    with Sensor.open(url, timeout=timeout) as sensor:
        sensor.enter_bootloader()
