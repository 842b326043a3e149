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
        self.action = action


class DisconnectedError(DeviceError):
    """The link was lost; samples received before the loss remain readable."""


class DeviceStalledError(DisconnectedError):
    """A streaming device sent no data for longer than the sensor's stall timeout (a frozen
    device, a held link): the link is dropped (or reopened, with reconnect=True) instead of
    waiting for ever. Samples received before the stall remain readable. The message names
    the device and the setting that bounds the wait."""


class BufferOverflowError(DeviceError):
    """Samples were discarded because the host read them too slowly (policy 'error')."""


class MissingCapabilityError(DeviceError):
    """The device lacks an optional feature (a CAP_* bit of INFO) that was asked for; nothing
    was sent to it. `capability` names the bit."""

    def __init__(self, message: str, capability: str) -> None:
        super().__init__(message)
        self.capability = capability


class ModelUploadError(DeviceError):
    """Uploading a model failed (after one retry where a retry can help). `name` is the NACK's
    error name (e.g. MODEL_BAD_CRC) or TIMEOUT, `action` what to do about it."""

    def __init__(self, message: str, name: str, action: str) -> None:
        super().__init__(f"{message}: {action}" if action else message)
        self.name = name
        self.action = action
