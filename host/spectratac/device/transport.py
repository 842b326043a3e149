"""Byte transports behind one small interface: serial ports, pyserial URLs, simulated devices.

A transport moves bytes and nothing else; framing lives in spectratac.protocol and the
request/reply logic in spectratac.device.sensor.
"""

from __future__ import annotations

import contextlib
import errno
import os
from typing import Protocol
from urllib.parse import urlsplit

import serial
import serial.tools.list_ports
from serial.urlhandler import protocol_socket

from spectratac.device.errors import (
    DeviceError,
    DeviceNotFoundError,
    DisconnectedError,
    PermissionDeniedError,
)

DEFAULT_BAUD = 921_600


class Transport(Protocol):
    """What Sensor needs from a link.

    A transport may also have `fileno() -> int | None`: a non-blocking descriptor that
    os.read() drains. Sensor then reads it from the process's shared I/O thread
    (spectratac.device.iohub) instead of calling read() from a thread of its own."""

    url: str

    def read(self, timeout: float) -> bytes:
        """Bytes available now, waiting up to `timeout` s for the first; b"" if none came.
        Raises DisconnectedError when the link is gone."""
        ...

    def write(self, data: bytes) -> None: ...

    def close(self) -> None: ...


def existing_ports() -> list[str]:
    return sorted(p.device for p in serial.tools.list_ports.comports())


def _ports_hint() -> str:
    ports = existing_ports()
    if not ports:
        return "No serial ports exist on this machine: is the board plugged in?"
    return "Serial ports that exist: " + ", ".join(ports) + "."


class SerialTransport:
    """A serial port path or any pyserial URL (socket://, rfc2217://, loop://)."""

    def __init__(self, url: str, baudrate: int = DEFAULT_BAUD) -> None:
        self.url = url
        try:
            self._port = serial.serial_for_url(url, baudrate=baudrate, timeout=0.05)
        except serial.SerialException as exc:
            raise _open_error(url, exc) from None
        except ValueError as exc:
            raise DeviceError(f"cannot open {url!r}: {exc}") from None

    def fileno(self) -> int | None:
        """The descriptor of a POSIX serial port or pty, or of a socket:// link; None for
        links a selector cannot watch (rfc2217://, loop://, spy://, non-POSIX systems)."""
        port = self._port
        if os.name != "posix" or not port.is_open:
            return None
        if type(port) is serial.Serial:  # serialposix: opened O_NONBLOCK
            return int(port.fd)
        if type(port) is protocol_socket.Serial:  # its socket is non-blocking
            return int(port._socket.fileno())
        return None

    def read(self, timeout: float) -> bytes:
        port = self._port
        try:
            if port.timeout != timeout:
                port.timeout = timeout
            first = port.read(1)  # returns as soon as one byte arrives: keeps latency low
            if not first:
                return b""
            waiting = port.in_waiting
            return first + port.read(waiting) if waiting else first
        except (serial.SerialException, OSError, TypeError, AttributeError) as exc:
            # TypeError/AttributeError: pyserial's state after close() raced with this read
            raise DisconnectedError(f"lost the link to {self.url}: {exc}") from None

    def write(self, data: bytes) -> None:
        try:
            self._port.write(data)
        except (serial.SerialException, OSError) as exc:
            raise DisconnectedError(f"lost the link to {self.url}: {exc}") from None

    def close(self) -> None:
        with contextlib.suppress(serial.SerialException, OSError):
            self._port.close()  # closing a port that vanished is not an error


def _open_error(url: str, exc: serial.SerialException) -> DeviceError:
    code = getattr(exc, "errno", None)
    text = str(exc)
    if code == errno.ENOENT or "[Errno 2]" in text or "No such file" in text:
        return DeviceNotFoundError(f"no device at {url!r}. {_ports_hint()}")
    if code == errno.EACCES or "Permission denied" in text or "[Errno 13]" in text:
        return PermissionDeniedError(
            f"permission denied opening {url!r}. On Linux add yourself to the group that owns "
            f"the port (usually 'dialout'): sudo usermod -aG dialout $USER, then log out and in "
            f"again; or install a udev rule giving the device mode 0666."
        )
    if url.startswith("socket://") and ("refused" in text or "[Errno 111]" in text):
        return DeviceNotFoundError(
            f"nothing is listening at {url!r}: start the device server first "
            f"(e.g. `spectratac sim serve --tcp PORT`)"
        )
    return DeviceError(f"cannot open {url!r}: {text}")


def open_transport(url: str, baudrate: int = DEFAULT_BAUD) -> Transport:
    """Open `url`: a port path, a pyserial URL, or sim://… for the simulated device."""
    scheme = urlsplit(url).scheme
    if scheme == "sim":
        from spectratac.sim.transport import SimTransport  # the native firmware + twin

        return SimTransport(url)
    return SerialTransport(url, baudrate)
