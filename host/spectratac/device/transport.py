"""Byte transports behind one small interface: serial ports, pyserial URLs, plug-ins.

A transport moves bytes and nothing else; framing lives in spectratac.protocol and the
request/reply logic in spectratac.device.link. `open_transport` picks the opener by the
URL's scheme: a plug-in registered for it (the simulated device registers ``sim://``
through the ``spectratac.transports`` entry points), else pyserial for a port path or one
of pyserial's URL schemes (``socket://``, ``rfc2217://``, ``loop://``...).

>>> sorted({"loop", "sim", "socket"} & set(transport_schemes()))
['loop', 'sim', 'socket']
>>> register_scheme("loopback", lambda url, baudrate: SerialTransport("loop://", baudrate))
>>> link = open_transport("loopback://")
>>> link.write(b"ping"); link.read(1.0)
b'ping'
>>> link.close()
>>> open_transport("nosuch://x")
Traceback (most recent call last):
...
spectratac.device.transport.UnknownSchemeError: no transport opens 'nosuch://x'; ...
"""

from __future__ import annotations

import contextlib
import errno
import importlib.util
import os
import pkgutil
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
from spectratac.device.link_info import HARDWARE
from spectratac.url_schemes import SchemeRegistry, check_url

DEFAULT_BAUD = 921_600
#: Entry-point group of transport plug-ins: name = URL scheme, value = an opener.
ENTRY_POINTS = "spectratac.transports"


class BadAddressError(DeviceError):
    """A device URL is malformed (e.g. a socket:// URL without a numeric port)."""


def check_socket_url(url: str) -> None:
    """Raise BadAddressError unless `url` is socket://HOST:PORT with a port 1..65535.

    >>> check_socket_url("socket://localhost:notaport")
    Traceback (most recent call last):
    ...
    spectratac.device.transport.BadAddressError: 'socket://localhost:notaport': port ...
    """
    parts = urlsplit(url)
    fix = (
        "give socket://HOST:PORT, e.g. socket://localhost:5555 "
        "(`spectratac sim serve --tcp 0` prints the address it listens on)"
    )
    try:
        port = parts.port
    except ValueError:
        text = parts.netloc.rpartition(":")[2]
        if text.isdigit():
            raise BadAddressError(f"{url!r}: port {text} is out of range 1..65535; {fix}") from None
        raise BadAddressError(f"{url!r}: port {text!r} is not a number; {fix}") from None
    if not parts.hostname:
        raise BadAddressError(f"{url!r}: no host; {fix}")
    if port is None:
        raise BadAddressError(f"{url!r}: no port; {fix}")
    if not 1 <= port <= 65535:
        raise BadAddressError(f"{url!r}: port {port} is out of range 1..65535; {fix}")


class Transport(Protocol):
    """What a Link (and so a Sensor) needs from the bytes it talks over.

    A transport may also have `fileno() -> int | None`: a non-blocking descriptor that
    os.read() drains. The Link then reads it from the process's shared I/O thread
    (spectratac.device.iohub) instead of calling read() from a thread of its own. And it may
    have `link_info` (spectratac.device.link_info.LinkInfo): what it knows about itself;
    without one it is taken for hardware."""

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

    link_info = HARDWARE  # a port carries bytes only

    def __init__(self, url: str, baudrate: int = DEFAULT_BAUD) -> None:
        self.url = url
        if urlsplit(url).scheme == "socket":
            check_socket_url(url)  # pyserial's own message names no fix
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
            first: bytes = port.read(1)  # returns as soon as one byte arrives: keeps latency low
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


class TransportOpener(Protocol):
    """Opens a transport for a URL of its scheme; raises a DeviceError saying what to do."""

    def __call__(self, url: str, baudrate: int) -> Transport: ...


class UnknownSchemeError(DeviceError):
    """No transport plug-in and no pyserial URL handler opens the URL's scheme."""


_REGISTRY: SchemeRegistry[TransportOpener] = SchemeRegistry("transport", ENTRY_POINTS)


def register_scheme(scheme: str, opener: TransportOpener, *, replace: bool = False) -> None:
    """Open `scheme`:// URLs with `opener(url, baudrate)` from now on (in this process).
    Installed packages register theirs once for all with a ``spectratac.transports`` entry
    point instead. A scheme given twice raises SchemeConflictError unless `replace`."""
    _REGISTRY.register(scheme, opener, replace=replace)


def _pyserial_knows(scheme: str) -> bool:
    """True if pyserial has a URL handler for `scheme` (serial.serial_for_url's lookup)."""
    for package in serial.protocol_handler_packages:
        with contextlib.suppress(ImportError, ValueError):
            if importlib.util.find_spec(f"{package}.protocol_{scheme}") is not None:
                return True
    return False


def _pyserial_schemes() -> list[str]:
    from serial import urlhandler

    prefix = "protocol_"
    modules = pkgutil.iter_modules(urlhandler.__path__)
    return [m.name[len(prefix) :] for m in modules if m.name.startswith(prefix)]


def transport_schemes() -> list[str]:
    """The URL schemes open_transport accepts besides plain port paths."""
    return sorted(set(_REGISTRY.schemes()) | set(_pyserial_schemes()))


def open_transport(url: str, baudrate: int = DEFAULT_BAUD) -> Transport:
    """Open `url`: a port path, a pyserial URL, or a URL of a registered scheme (sim://…
    for the simulated device). UnknownSchemeError lists the schemes that exist; a URL too
    long or not UTF-8 is a BadAddressError before any scheme sees it."""
    check_url(url, BadAddressError)
    scheme = urlsplit(url).scheme
    if len(scheme) <= 1:  # a port path (a one-letter "scheme" is a Windows drive)
        return SerialTransport(url, baudrate)
    opener = _REGISTRY.lookup(scheme)
    if opener is not None:
        return opener(url, baudrate)
    if _pyserial_knows(scheme):
        return SerialTransport(url, baudrate)
    raise UnknownSchemeError(
        f"no transport opens {url!r}; give a serial port path or a URL of one of the schemes "
        f"{', '.join(s + '://' for s in transport_schemes())}"
    )
