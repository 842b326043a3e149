"""Talking to a SpectraTac device: transports, the Sensor API, typed errors."""

from spectratac.device.errors import (
    BufferOverflowError,
    CommandRejectedError,
    DeviceError,
    DeviceNotFoundError,
    DeviceTimeoutError,
    DisconnectedError,
    PermissionDeniedError,
    ProtocolMismatchError,
)
from spectratac.device.records import SAMPLE_RECORD, Sample
from spectratac.device.sensor import ClockSync, Sensor, SensorStats, TimeSyncExchange
from spectratac.device.transport import open_transport

__all__ = [
    "SAMPLE_RECORD",
    "BufferOverflowError",
    "ClockSync",
    "CommandRejectedError",
    "DeviceError",
    "DeviceNotFoundError",
    "DeviceTimeoutError",
    "DisconnectedError",
    "PermissionDeniedError",
    "ProtocolMismatchError",
    "Sample",
    "Sensor",
    "SensorStats",
    "TimeSyncExchange",
    "open_transport",
]
