"""An independent reader of USB descriptors, written from the specification tables rather than
from the firmware's C: USB 2.0 §9.6 (Tables 9-8 device, 9-10 configuration, 9-12 interface,
9-13 endpoint, 9-15/9-16 string), the Interface Association Descriptor ECN, CDC 1.2 §5.2.3
(Table 15 header, Table 16 union) and PSTN 1.2 §5.3 (Table 3 call management, Table 4 ACM).
Each parser checks the field rules of its table and raises DescriptorError naming the field."""

from __future__ import annotations

import struct
from dataclasses import dataclass, field


class DescriptorError(ValueError):
    """A descriptor breaks a rule of its specification table."""


DEVICE, CONFIGURATION, STRING, INTERFACE, ENDPOINT, IAD = 1, 2, 3, 4, 5, 11
CS_INTERFACE = 0x24
CDC_HEADER, CDC_CALL_MANAGEMENT, CDC_ACM, CDC_UNION = 0x00, 0x01, 0x02, 0x06
TRANSFER_TYPES = {0: "control", 1: "isochronous", 2: "bulk", 3: "interrupt"}


def need(ok: bool, what: str) -> None:
    if not ok:
        raise DescriptorError(what)


@dataclass(frozen=True)
class Device:
    bcd_usb: int
    device_class: tuple[int, int, int]
    max_packet_size0: int
    vendor: int
    product: int
    bcd_device: int
    strings: tuple[int, int, int]  # iManufacturer, iProduct, iSerialNumber
    num_configurations: int


def parse_device(data: bytes) -> Device:
    need(len(data) == 18, f"device descriptor is {len(data)} bytes, Table 9-8 says 18")
    (
        length,
        kind,
        bcd_usb,
        cls,
        sub,
        proto,
        mps0,
        vid,
        pid,
        bcd_dev,
        i_man,
        i_prod,
        i_ser,
        n_conf,
    ) = struct.unpack("<BBHBBBBHHHBBBB", data)
    need(length == 18, f"device bLength {length}")
    need(kind == DEVICE, f"device bDescriptorType {kind}")
    need(bcd_usb in (0x0110, 0x0200), f"bcdUSB {bcd_usb:#06x}")
    need(mps0 in (8, 16, 32, 64), f"bMaxPacketSize0 {mps0} (USB 2.0 §5.5.3)")
    need(n_conf >= 1, "bNumConfigurations 0")
    return Device(
        bcd_usb, (cls, sub, proto), mps0, vid, pid, bcd_dev, (i_man, i_prod, i_ser), n_conf
    )


@dataclass(frozen=True)
class Endpoint:
    address: int
    transfer: str
    max_packet: int
    interval: int

    @property
    def is_in(self) -> bool:
        return bool(self.address & 0x80)


@dataclass
class Interface:
    number: int
    alternate: int
    klass: tuple[int, int, int]
    num_endpoints: int
    endpoints: list[Endpoint] = field(default_factory=list)
    functional: dict[int, bytes] = field(default_factory=dict)  # CDC subtype -> body
    functional_order: list[int] = field(default_factory=list)


@dataclass(frozen=True)
class Association:
    first_interface: int
    interface_count: int
    function_class: tuple[int, int, int]


@dataclass
class Configuration:
    total_length: int
    num_interfaces: int
    value: int
    attributes: int
    max_power_ma: int
    interfaces: list[Interface] = field(default_factory=list)
    associations: list[Association] = field(default_factory=list)


FIXED_LENGTHS = {CONFIGURATION: 9, INTERFACE: 9, ENDPOINT: 7, IAD: 8}
CDC_LENGTHS = {CDC_HEADER: 5, CDC_CALL_MANAGEMENT: 5, CDC_ACM: 4}


def parse_endpoint(d: bytes) -> Endpoint:
    _, _, address, attributes, max_packet, interval = struct.unpack("<BBBBHB", d)
    need(address & 0x70 == 0, f"endpoint {address:#04x}: reserved address bits set")
    need(address & 0x0F != 0, "endpoint 0 has no endpoint descriptor")
    transfer = TRANSFER_TYPES[attributes & 3]
    need(transfer != "control", f"endpoint {address:#04x} is a control endpoint")
    if transfer != "isochronous":
        need(attributes & 0x3C == 0, f"endpoint {address:#04x}: bmAttributes bits 5..2 set")
    need(max_packet & 0xF800 == 0, f"endpoint {address:#04x}: wMaxPacketSize reserved bits")
    size = max_packet & 0x7FF
    # Full speed (USB 2.0 §5.7.3, §5.8.3): interrupt up to 64, bulk 8/16/32/64.
    if transfer == "bulk":
        need(size in (8, 16, 32, 64), f"bulk endpoint {address:#04x} size {size}")
    if transfer == "interrupt":
        need(1 <= size <= 64, f"interrupt endpoint {address:#04x} size {size}")
        need(1 <= interval <= 255, f"interrupt endpoint {address:#04x} bInterval {interval}")
    return Endpoint(address, transfer, size, interval)


def parse_configuration(data: bytes) -> Configuration:
    need(len(data) >= 9, "configuration descriptor shorter than its 9-byte header")
    length, kind, total, n_if, value, _, attributes, power = struct.unpack("<BBHBBBBB", data[:9])
    need(length == 9 and kind == CONFIGURATION, "not a configuration descriptor")
    need(total == len(data), f"wTotalLength {total} but {len(data)} bytes returned")
    need(attributes & 0x80 != 0, "bmAttributes bit 7 must be set (Table 9-10)")
    need(attributes & 0x1F == 0, "bmAttributes bits 4..0 are reserved")
    need(value >= 1, "bConfigurationValue 0 means unconfigured")
    need(power <= 250, f"bMaxPower {power} is over 500 mA")
    config = Configuration(total, n_if, value, attributes, 2 * power)
    at, current = 9, None
    while at < len(data):
        need(len(data) - at >= 2, f"truncated descriptor at offset {at}")
        d_len, d_kind = data[at], data[at + 1]
        need(d_len >= 2 and at + d_len <= len(data), f"bLength {d_len} at offset {at}")
        d = data[at : at + d_len]
        if d_kind in FIXED_LENGTHS:
            need(d_len == FIXED_LENGTHS[d_kind], f"type {d_kind} bLength {d_len} at {at}")
        if d_kind == INTERFACE:
            if current is not None:
                need(
                    len(current.endpoints) == current.num_endpoints,
                    f"interface {current.number}: bNumEndpoints {current.num_endpoints}, "
                    f"{len(current.endpoints)} endpoint descriptors",
                )
            _, _, number, alt, n_ep, cls, sub, proto, _ = struct.unpack("<9B", d)
            current = Interface(number, alt, (cls, sub, proto), n_ep)
            config.interfaces.append(current)
        elif d_kind == ENDPOINT:
            need(current is not None, f"endpoint before any interface at {at}")
            assert current is not None
            current.endpoints.append(parse_endpoint(d))
        elif d_kind == IAD:
            need(
                current is None or not config.associations,
                "the IAD must come before the interfaces it groups",
            )
            _, _, first, count, cls, sub, proto, _ = struct.unpack("<8B", d)
            config.associations.append(Association(first, count, (cls, sub, proto)))
        elif d_kind == CS_INTERFACE:
            need(current is not None, f"class-specific descriptor before any interface at {at}")
            assert current is not None
            subtype = d[2]
            if subtype in CDC_LENGTHS:
                need(d_len == CDC_LENGTHS[subtype], f"CDC subtype {subtype} bLength {d_len}")
            if subtype == CDC_UNION:
                need(d_len >= 5, "union descriptor names no subordinate interface")
            current.functional[subtype] = d[3:]
            current.functional_order.append(subtype)
        at += d_len
    if current is not None:
        need(
            len(current.endpoints) == current.num_endpoints,
            f"interface {current.number}: bNumEndpoints {current.num_endpoints}, "
            f"{len(current.endpoints)} endpoint descriptors",
        )
    numbers = sorted({i.number for i in config.interfaces})
    need(numbers == list(range(n_if)), f"bNumInterfaces {n_if} but interfaces {numbers}")
    addresses = [e.address for i in config.interfaces for e in i.endpoints]
    need(len(addresses) == len(set(addresses)), f"endpoint address used twice: {addresses}")
    return config


def parse_string(data: bytes) -> str:
    need(len(data) >= 2 and data[0] == len(data), "string bLength does not match its size")
    need(data[1] == STRING, f"string bDescriptorType {data[1]}")
    need(len(data) % 2 == 0, "a UTF-16 string has an even length")
    return data[2:].decode("utf-16-le")


def parse_langids(data: bytes) -> list[int]:
    need(len(data) >= 4 and data[0] == len(data) and data[1] == STRING, "bad string 0")
    need(len(data) % 2 == 0, "string 0 holds 16-bit LANGIDs")
    return [v for (v,) in struct.iter_unpack("<H", data[2:])]
