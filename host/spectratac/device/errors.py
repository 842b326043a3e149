"""Typed errors of the device layer; each message says what happened and what to do."""

from __future__ import annotations

from spectratac.errors import SpectraTacError


class DeviceError(SpectraTacError):
    """Base of errors about a device or the link to it."""


class DeviceNotFoundError(DeviceError):
    """The port or address does not exist; the message lists the serial ports that do."""


class PermissionDeniedError(DeviceError):
    """The port exists but this user may not open it."""


class ProtocolMismatchError(DeviceError):
    """The device speaks another protocol major version, or was built from other definitions."""

    def __init__(self, message: str, device: tuple[int, int], host: tuple[int, int]) -> None:
        super().__init__(message)
        self.device_version = device
        self.host_version = host


class DeviceTimeoutError(DeviceError, TimeoutError):
    """The device did not answer in time."""


class CommandRejectedError(DeviceError):
    """The device answered a command with NACK; `code` and `meaning` say why."""

    def __init__(self, command: str, code: int, name: str, meaning: str, action: str) -> None:
        super().__init__(
            f"device rejected {command}: {name} (code {code}): {meaning}"
            + (f" {action}" if action else "")
        )
        self.command = command
        self.code = code
        self.name = name
        self.meaning = meaning


class DisconnectedError(DeviceError):
    """The link was lost; samples received before the loss remain readable."""


class BufferOverflowError(DeviceError):
    """Samples were discarded because the host read them too slowly (policy 'error')."""
