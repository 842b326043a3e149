"""The USB descriptors, read back the way a host reads them (GET_DESCRIPTOR through the core,
`usb_tests --descriptors`) and checked by an independent parser written from the specification
tables (tests/firmware/usb_descriptors.py): every field rule, the CDC-ACM function as Linux
cdc_acm expects it, and the same bytes in the STM32 image."""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

import pytest

from .usb_descriptors import (
    CDC_ACM,
    CDC_CALL_MANAGEMENT,
    CDC_HEADER,
    CDC_UNION,
    Configuration,
    DescriptorError,
    parse_configuration,
    parse_device,
    parse_langids,
    parse_string,
)

pytestmark = [pytest.mark.firmware, pytest.mark.subprocess]

TIMEOUT_S = 120
UID_HEX = "123456789ABCDEF001234567"  # the UID the test program gives the core


@pytest.fixture(scope="module")
def descriptors(usb_binary: Path) -> dict[str, bytes]:
    out = subprocess.run(
        [str(usb_binary), "--descriptors"],
        capture_output=True,
        text=True,
        timeout=TIMEOUT_S,
        check=True,
    ).stdout
    return {name: bytes.fromhex(hexa) for name, hexa in (line.split() for line in out.splitlines())}


@pytest.fixture(scope="module")
def config(descriptors: dict[str, bytes]) -> Configuration:
    return parse_configuration(descriptors["configuration"])


def test_device_descriptor(descriptors: dict[str, bytes]) -> None:
    dev = parse_device(descriptors["device"])
    assert dev.bcd_usb == 0x0200
    # A device with an IAD declares the multi-interface function class (IAD ECN).
    assert dev.device_class == (0xEF, 0x02, 0x01)
    assert dev.max_packet_size0 == 64
    assert (dev.vendor, dev.product) == (0x1209, 0x0001)
    assert dev.num_configurations == 1
    assert dev.strings == (1, 2, 3)


def test_configuration_chain(config: Configuration, descriptors: dict[str, bytes]) -> None:
    assert config.total_length == len(descriptors["configuration"]) == 75
    assert config.num_interfaces == len(config.interfaces) == 2
    assert config.value == 1
    assert config.attributes == 0x80  # bus powered, no remote wake-up
    assert config.max_power_ma == 250


def test_interface_association(config: Configuration) -> None:
    (iad,) = config.associations
    comm = config.interfaces[iad.first_interface]
    assert iad.interface_count == 2
    assert iad.function_class == (0x02, 0x02, 0x00)
    assert iad.function_class[:2] == comm.klass[:2]


def test_cdc_acm_function(config: Configuration) -> None:
    comm, data = config.interfaces
    assert comm.klass == (0x02, 0x02, 0x00)  # CDC, ACM, no AT commands (no modem probing)
    assert data.klass == (0x0A, 0x00, 0x00)
    assert comm.functional_order[0] == CDC_HEADER  # CDC 1.2 §5.2.3: the header comes first
    assert comm.functional[CDC_HEADER] == bytes([0x20, 0x01])  # bcdCDC 1.20
    union = comm.functional[CDC_UNION]
    assert (union[0], union[1]) == (comm.number, data.number)
    assert comm.functional[CDC_CALL_MANAGEMENT] == bytes([0x00, data.number])
    acm_caps = comm.functional[CDC_ACM][0]
    assert acm_caps & 0xF0 == 0  # reserved bits
    assert acm_caps & 0x02  # line coding and control line state requests
    assert acm_caps & 0x04  # SEND_BREAK


def test_endpoints_full_speed(config: Configuration) -> None:
    comm, data = config.interfaces
    (notify,) = comm.endpoints
    assert notify.transfer == "interrupt" and notify.is_in and notify.address == 0x82
    assert notify.max_packet >= 10  # SERIAL_STATE notification (PSTN 1.2 §6.5.4)
    assert {(e.transfer, e.is_in, e.max_packet) for e in data.endpoints} == {
        ("bulk", True, 64),
        ("bulk", False, 64),
    }
    assert {e.address for e in data.endpoints} == {0x01, 0x81}


def test_strings(descriptors: dict[str, bytes]) -> None:
    assert parse_langids(descriptors["string0"]) == [0x0409]
    assert parse_string(descriptors["string1"]) == "SpectraTac"
    assert parse_string(descriptors["string2"]) == "SpectraTac sensor board"
    serial = parse_string(descriptors["string3"])
    assert serial == UID_HEX
    assert re.fullmatch(r"[0-9A-F]{24}", serial)


@pytest.mark.parametrize(
    ("offset", "value", "rule"),
    [
        (2, 76, "wTotalLength"),
        (4, 3, "bNumInterfaces"),
        (7, 0x40, "bmAttributes"),
        (9 + 8 + 4, 2, "bNumEndpoints"),  # communication interface claims two endpoints
        (9 + 8 + 9 + 5 + 5 + 4 + 5 + 4, 0x41, "size"),  # interrupt IN 65 bytes
        (9 + 8 + 9 + 5 + 5 + 4 + 5 + 7 + 9 + 4, 0x41, "size"),  # bulk OUT 65 bytes
        (9 + 8 + 9, 6, "bLength"),  # CDC header bLength
    ],
)
def test_parser_rejects_broken_descriptors(
    descriptors: dict[str, bytes], offset: int, value: int, rule: str
) -> None:
    """The parser is not a rubber stamp: one corrupted field fails with that field's rule."""
    broken = bytearray(descriptors["configuration"])
    broken[offset] = value
    with pytest.raises(DescriptorError, match=rule):
        parse_configuration(bytes(broken))


def symbol_bytes(elf: Path, name: str) -> bytes:
    """The bytes of a data symbol as stored in the image."""
    nm = subprocess.run(
        ["arm-none-eabi-nm", "-S", str(elf)],
        capture_output=True,
        text=True,
        check=True,
        timeout=60,
    ).stdout
    addr, size = next(
        (int(a, 16), int(s, 16))
        for a, s, _, n in (line.split() for line in nm.splitlines() if len(line.split()) == 4)
        if n == name
    )
    headers = subprocess.run(
        ["arm-none-eabi-objdump", "-h", str(elf)],
        capture_output=True,
        text=True,
        check=True,
        timeout=60,
    ).stdout
    for m in re.finditer(
        r"^\s*\d+\s+(\S+)\s+([0-9a-f]+)\s+([0-9a-f]+)\s+([0-9a-f]+)", headers, flags=re.M
    ):
        section, sec_size, vma = m[1], int(m[2], 16), int(m[3], 16)
        if vma <= addr < vma + sec_size:
            out = elf.with_suffix(f".{section.strip('.')}.bin")
            subprocess.run(
                ["arm-none-eabi-objcopy", "-O", "binary", "-j", section, str(elf), str(out)],
                check=True,
                timeout=60,
            )
            return out.read_bytes()[addr - vma : addr - vma + size]
    raise AssertionError(f"{name} at {addr:#x} is in no section")


def test_image_carries_the_checked_descriptors(
    usb_image: Path, descriptors: dict[str, bytes]
) -> None:
    assert symbol_bytes(usb_image, "k_usb_device_desc") == descriptors["device"]
    assert symbol_bytes(usb_image, "k_usb_config_desc") == descriptors["configuration"]
    parse_configuration(symbol_bytes(usb_image, "k_usb_config_desc"))
