"""The handshake that opens (and reopens) every link: read the device's INFO and refuse a
device that speaks another protocol major version or, unless told otherwise, was built from
other protocol definitions."""

from __future__ import annotations

import dataclasses
import logging
import time
from typing import Any, Protocol, TypeVar

from spectratac.device.errors import DeviceTimeoutError, ProtocolMismatchError
from spectratac.errors import printable
from spectratac.protocol.generated import messages as m
from spectratac.protocol.schema import Message
from spectratac.protocol.versions import expected_definition_hash

log = logging.getLogger("spectratac.device")
R = TypeVar("R", bound=Message)


class Requester(Protocol):
    """What the handshake needs of a link (`Link` has it): its URL, timeout and hash policy,
    raw writes and requests."""

    url: str
    timeout: float
    strict_hash: bool

    def write(self, data: bytes) -> None: ...

    def request(
        self, msg: Message, expect: type[R], *, timeout: float | None = None, attempts: int = 2
    ) -> R: ...


def read_info(link: Requester) -> m.Info:
    """The device's INFO, its text fields made printable. Asks again every 0.5 s within the
    link's timeout; raises DeviceTimeoutError or ProtocolMismatchError saying what to do (a
    definition hash mismatch only warns unless `link.strict_hash`)."""
    link.write(b"\x00")  # ends any partial frame the device holds from earlier garbage
    # A board that is still booting (or reset by opening its port) loses what it receives
    # before its UART is up: hence the repeated short requests.
    deadline = time.monotonic() + link.timeout
    while True:
        remaining = deadline - time.monotonic()
        try:
            info = link.request(m.GetInfo(), m.Info, timeout=min(0.5, remaining), attempts=1)
            break
        except DeviceTimeoutError:
            if deadline - time.monotonic() <= 0:
                raise DeviceTimeoutError(
                    f"no reply to GET_INFO from {link.url} within {link.timeout:.1f} s: is "
                    f"the device powered, running SpectraTac firmware, and on this "
                    f"port/baud rate?"
                ) from None
    host = (m.PROTOCOL_MAJOR, m.PROTOCOL_MINOR)
    device = (info.protocol_major, info.protocol_minor)
    if info.protocol_major != m.PROTOCOL_MAJOR:
        raise ProtocolMismatchError(
            f"{link.url} speaks protocol {device[0]}.{device[1]}, this host library "
            f"{host[0]}.{host[1]}: update the library or reflash the firmware",
            device,
            host,
        )
    # compare with the hash of the device's own minor version; a newer one is a superset
    expected = expected_definition_hash(info.protocol_minor)
    if expected is not None and info.definition_hash != expected:
        text = (
            f"{link.url} was built from other protocol definitions (hash "
            f"0x{info.definition_hash:08X}, protocol {device[0]}.{device[1]} has "
            f"0x{expected:08X}): rebuild firmware and host from one checkout"
        )
        if link.strict_hash:
            raise ProtocolMismatchError(text, device, host)
        log.warning(text)
    return printable_info(info)


def printable_info(info: m.Info) -> m.Info:
    """INFO with its text fields made safe to print (a device names itself).

    >>> printable_info(m.Info(board="tac\\x1b[2J")).board
    'tac\\\\x1b[2J'
    """
    text: dict[str, Any] = {
        f.name: printable(getattr(info, f.name)) for f in info.FIELDS if f.type == "char"
    }
    return dataclasses.replace(info, **text)
