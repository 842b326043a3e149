"""Service commands of protocol 1.4: restart a device in its ROM DFU bootloader
(ENTER_BOOTLOADER, for `spectratac flash`) and inject a fault into a test image (DEBUG_FAULT,
for bring-up and the post-mortem tests). Both refuse, with a typed error saying what to do,
a device that cannot: older than 1.4, or without the capability bit."""

from __future__ import annotations

from spectratac.device.errors import MissingCapabilityError
from spectratac.device.link import Link
from spectratac.protocol.generated import messages as m


def _require(link: Link, since: int, capability: m.Capabilities, wanted: str, fix: str) -> None:
    info = link.info
    version = f"{info.protocol_major}.{info.protocol_minor}"
    if info.protocol_minor < since or not info.capabilities & capability:
        raise MissingCapabilityError(
            f"{link.url} cannot {wanted}: it speaks protocol {version} and does not report "
            f"{capability.name} (protocol 1.{since}); {fix}",
            str(capability.name),
        )


def enter_bootloader(link: Link) -> None:
    """ENTER_BOOTLOADER: the device ACKs, then restarts in its ROM DFU bootloader and leaves
    the link (close it afterwards). Raises MissingCapabilityError for a device without it."""
    _require(
        link,
        m.EnterBootloader.SINCE,
        m.Capabilities.CAP_BOOTLOADER,
        "enter its bootloader by command",
        "hold BOOT0 and press NRST to enter the ROM bootloader by hand",
    )
    link.command(m.EnterBootloader(), attempts=1)


def debug_fault(link: Link, kind: m.FaultKind) -> None:
    """DEBUG_FAULT: a test image ACKs, then faults (FAULT_HARD) or hangs until its watchdog
    resets it (FAULT_HANG); STATUS reports it after the reset. Raises MissingCapabilityError
    for a release image (which would answer NACK NOT_A_TEST_IMAGE)."""
    _require(
        link,
        m.DebugFault.SINCE,
        m.Capabilities.CAP_DEBUG_FAULT,
        "inject a fault",
        "flash a test image (make firmware-test, build flag STAC_TEST_COMMANDS)",
    )
    link.command(m.DebugFault(kind=kind), attempts=1)
